"""Laws: energy never grows without an external force, lift does no work against the flow."""
import math

import numpy as np
import pytest

from benchmarks.reference import lift_curve
from pool_sim.physics import Scene, Simulation
from pool_sim.physics.effects import effect_flags
from pool_sim.physics.kernels.effects import lift_force
from pool_sim.physics.stepper import body_tuple, environment_tuple
from scenes import G, one_sphere

SCENES = {
    'default pool (contacts)': lambda rate: Scene.default().with_values(physics_rate_hz=rate),
    'cork dropped on the water': lambda rate: one_sphere(0.2, 250.0, position=(0, 0, 1.0),
                                                         physics_rate_hz=rate),
    'ping-pong ball under water': lambda rate: one_sphere(0.02, mass=0.0027,
                                                          physics_rate_hz=rate),
    'steel thrown sideways': lambda rate: one_sphere(0.1, 7850.0, velocity=(6.0, 2.0, 5.0),
                                                     position=(0, 0, 1.0), physics_rate_hz=rate),
}


@pytest.mark.parametrize('rate_hz', [30.0, 200.0])
@pytest.mark.parametrize('name', sorted(SCENES))
def test_mechanical_energy_never_drifts_upward_with_the_default_integrator(name, rate_hz):
    """Bound: within one step, gravity's work on a sphere is at most m*|g|*v_max*dt.

    The energy may rise above the lowest value it has reached so far by at most that (a
    one-step wobble); anything more would be a drift. It must end below where it started.
    """
    sim = Simulation(SCENES[name](rate_hz))
    start = sim.mechanical_energy()
    lowest, worst_rise, top_speed = start.copy(), np.zeros_like(start), np.zeros_like(start)
    for _ in range(int(20.0 * rate_hz)):
        sim.step()
        energy = sim.mechanical_energy()
        worst_rise = np.maximum(worst_rise, energy - lowest)
        lowest = np.minimum(lowest, energy)
        top_speed = np.maximum(top_speed, np.linalg.norm(sim.spheres.velocity, axis=0))
    bound = sim.spheres.mass * G * top_speed * sim.max_step
    assert np.all(worst_rise <= bound), (worst_rise, bound)
    assert np.all(sim.mechanical_energy() < start)


def test_lift_is_perpendicular_to_the_relative_velocity_with_the_stated_magnitude():
    rng = np.random.default_rng(7)
    n = 200
    scene = one_sphere(0.1, 500.0, position=(0, 0, 2.0), water__current=[0.3, -0.2, 0.1],
                       air__wind=[1.0, 2.0, 0.0], ball__lift_coefficient=0.8)
    sim = Simulation(scene)
    spheres = sim.spheres
    env = environment_tuple(sim.environment)
    for water_fraction in (0.0, 1.0):
        medium = sim.environment.water if water_fraction else sim.environment.air
        for _ in range(n):
            velocity = rng.normal(size=(3, 1)) * 5.0
            spheres.lift_normal = rng.normal(size=(3, 1))
            spheres.lift_normal /= np.linalg.norm(spheres.lift_normal)
            force = np.array(lift_force(effect_flags(['lift']), env, body_tuple(spheres, 0),
                                        water_fraction, tuple(velocity[:, 0]))).reshape(3, 1)
            relative = velocity[:, 0] - medium.flow_velocity
            assert abs(force[:, 0] @ relative) <= 1e-12 * np.linalg.norm(force) * np.linalg.norm(
                relative)
            # The lift curve at this angle of attack, written out in benchmarks/reference.py.
            normal = spheres.lift_normal[:, 0]
            attack = math.atan2(abs(normal @ relative),
                                np.linalg.norm(np.cross(normal, relative)))
            coefficient = lift_curve({'lift_coefficient': 0.8}, attack)
            expected = (0.5 * medium.density * coefficient * spheres.lift_area[0]
                        * relative @ relative)
            assert np.linalg.norm(force) == pytest.approx(expected, rel=1e-9, abs=1e-12)
            # In the plane of the normal and the flow: no component along n x v_rel.
            assert abs(force[:, 0] @ np.cross(spheres.lift_normal[:, 0], relative)) <= 1e-9 * (
                np.linalg.norm(force) * np.linalg.norm(relative))


@pytest.mark.parametrize('integrator, rate_hz, z0, swing', [
    # Bobbing within the waterline band the linear model is a linear spring, which RK4
    # follows to 4e-7 J of the 1 J it swings with; the energy of the exact cap swung by 2.8 J.
    ('rk4', 200.0, 0.05, 1e-6),
    # Dropped through the band's edge, damped by the default integrator: it may only fall.
    ('linearly_implicit_euler', 200.0, 0.3, None),
    ('linearly_implicit_euler', 30.0, 0.3, None)])
def test_energy_of_the_linear_submerged_volume_is_the_linear_models(integrator, rate_hz, z0,
                                                                     swing):
    sim = Simulation(one_sphere(0.2, 250.0, position=(0, 0, z0), effects=['gravity', 'buoyancy'],
                                integrator=integrator, physics_rate_hz=rate_hz),
                     submerged_volume='linear')
    energies = [sim.mechanical_energy()[0]]
    for _ in range(int(10.0 * rate_hz)):
        sim.step()
        energies.append(sim.mechanical_energy()[0])
    energies = np.array(energies)
    if swing is not None:
        assert energies.max() - energies.min() < swing
    else:
        assert np.diff(energies).max() <= 1e-12 * abs(energies[0])
        assert energies[-1] < energies[0]
