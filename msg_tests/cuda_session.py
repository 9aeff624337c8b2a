"""One session of a simulation driven through the core's API, run on either backend: the
CPU's here, `backend: cuda` in numba's CUDA simulator in a child process (test_cuda_backend).

    python -m msg_tests.cuda_session OUT.npz   # backend cuda; what session() returns

Each session runs steps between every kind of change the node makes: set_mass,
set_radius, forces one sphere at a time and all at once, a release, a spawn and a remove
(change_spheres), the step guard putting a sphere back, and a reset; it keeps the state
after each.
"""
import sys

import numpy as np

from pool_sim.physics.effects import DEFAULT_EFFECTS
from pool_sim.physics.integrators import INTEGRATORS
from pool_sim.physics.scene import Scene
from pool_sim.physics.simulation import Simulation

SPHERES = 24
# (integrator, effects): every integrator with the default effects (wave radiation among
# them), and every effect at once.
CASES = [(integrator, list(DEFAULT_EFFECTS)) for integrator in INTEGRATORS] + [
    ('linearly_implicit_euler', ['gravity', 'buoyancy', 'drag', 'lift', 'added_mass',
                                 'wave_radiation', 'contact', 'friction'])]
# With collisions (soft_step, coloured as a GPU colours): the spheres but the first three
# crowded in a column over the floor, where they collide and pile up.
COLLIDING = ('linearly_implicit_euler', [*DEFAULT_EFFECTS, 'collisions'])


def scene(backend, integrator, effects, names):
    """A scene of len(names) spheres scattered over the pool, some crossing the surface,
    some against its faces, some thrown at them."""
    rng = np.random.default_rng(7)
    count = len(names)
    position = np.column_stack([rng.uniform(-3.5, 3.5, count), rng.uniform(-3.5, 3.5, count),
                                rng.uniform(-0.3, 0.3, count)])
    velocity = rng.normal(0.0, 3.0, (count, 3))
    radius = rng.uniform(0.05, 0.1, count)
    # On the floor and at the ceiling, thrown at them; afloat.
    position[:3, 2], velocity[:2, 2], radius[:2] = [-3.9, 3.9, 0.0], [-2.0, 2.0], 0.1
    colliding = {}
    if 'collisions' in effects:  # a crowd on the floor, 3 000 kg/m^3: it piles up there
        above_floor = rng.uniform(0.0, 0.25, count - 3)
        above_floor[::2] = 0.0  # on it
        position[3:] = np.column_stack([rng.uniform(-0.2, 0.2, (count - 3, 2)),
                                        -4.0 + radius[3:] + above_floor])
        velocity[3:] = 0.0
        colliding = {'contact_solver': 'soft_step', 'soft_step.colouring': 'priority',
                     'spheres.mass': (3000.0 * 4.0 / 3.0 * np.pi * radius**3).tolist()}
    return Scene({'sphere_names': names, 'backend': backend, 'integrator': integrator,
                  'effects': effects, 'spheres.position': position.ravel().tolist(),
                  'spheres.velocity': velocity.ravel().tolist(),
                  'spheres.radius': radius.tolist(),
                  'spheres.mass': np.exp(rng.uniform(-3.0, 3.0, count)).tolist(),
                  'spheres.lift_coefficient': rng.uniform(-1.0, 1.0, count).tolist(),
                  **colliding})


def session(backend, integrator, effects, spheres=SPHERES, steps=lambda k: k):
    """{label: array}: the spheres' state after each stage, the guard's count and the
    spheres it put back; with collisions, the contacts remembered too. steps(k): the steps
    a stage takes where the full session takes k."""
    names = [f's{i}' for i in range(spheres)]
    sim = Simulation(scene(backend, integrator, effects, names))
    kept = {}

    def keep(label):
        spheres = sim.spheres
        kept[f'{label}.position'] = spheres.position.copy()
        kept[f'{label}.velocity'] = spheres.velocity.copy()
        if 'collisions' in effects:
            if sim._device is not None:
                sim._device.memory_home(sim._memory)
            for name, array in zip(('keys', 'forces', 'held'), sim._memory):
                kept[f'{label}.memory_{name}'] = array.copy()

    sim.prepare()  # compiles; moves nothing
    keep('prepared')
    sim.run(1, 0.005)
    keep('one')
    sim.run(steps(40), 0.005)
    keep('first')
    sim.set_mass('s3', 0.02)
    sim.set_radius('s5', 0.3)
    sim.set_external_force('s6', [5.0, 0.0, 40.0])
    sim.run(steps(30), 0.005)
    keep('changed')
    forces = np.zeros((spheres, 3))
    forces[:, 2] = np.linspace(-20.0, 20.0, spheres)
    sim.set_external_forces(forces)
    sim.run(steps(30), 0.005)
    sim.release_external_forces(np.arange(spheres) % 2 == 0)
    sim.run(steps(30), 0.004)
    keep('forced')
    # A velocity no step can take (past every setter's check, so written directly, and
    # said so): the guard puts s7 back where it was, at rest.
    kept['before.recovered'] = np.array(sim.take_recovered())  # unstable light spheres
    sim.spheres.velocity[:, sim.spheres.lookup('s7')] = np.nan
    sim.mark_written('velocity')
    sim.run(steps(3), 0.005)
    kept['guard.recovered'] = np.array(sim.take_recovered())
    kept['guard.recoveries'] = np.array(sim.recoveries)
    keep('guard')
    grown = names[2:] + ['new0', 'new1']  # two removed, two spawned, the rest reordered
    sim.change_spheres(scene(backend, integrator, effects, grown[::-1]))
    sim.run(steps(50), 0.005)
    keep('respawned')
    sim.run(steps(10), 0.005)
    sim.reset()  # straight after a step: the reset's state, not the step's, goes on
    sim.run(steps(20), 0.005)
    keep('reset')
    return kept


def sessions(backend):
    """session() of every case, its labels prefixed by the case's number."""
    kept = {}
    for number, (integrator, effects) in enumerate(CASES):
        for label, value in session(backend, integrator, effects).items():
            kept[f'{number}.{label}'] = value
    return kept


def colliding_session(backend):
    """session() with collisions, shortened (a step of the collision pass takes seconds in
    numba's simulator): 12 spheres, a step a stage for 20 of the full session's."""
    return session(backend, *COLLIDING, spheres=12, steps=lambda k: max(1, k // 20))


if __name__ == '__main__':  # OUT.npz [colliding]
    np.savez(sys.argv[1], **(colliding_session('cuda') if sys.argv[2:] == ['colliding']
                             else sessions('cuda')))
