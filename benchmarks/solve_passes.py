"""What each pass of soft_step's substeps costs, per contact: the solver's own pass
functions (contacts/soft_step.py) timed on the rows it builds from a scene's state, so that
the next step (SIMD over a colour, or the GPU) knows which pass to take on.

    .venv/bin/python -m benchmarks.solve_passes [--spheres 10000 1000] [--seconds 12]
        [--out results/collisions/solve_passes.md]

Two scenes, each at every count: contact_stages' resting pile (the lattice dropped into the
pool, every sphere denser than water) and node_rate's scene (common.scattered_spheres), run
with soft_step for --seconds. From that state, as the step would: detection, then
soft_step.contact_rows (the contacts' rows, warm-started from the memory the last step
left, the members' velocities). Then, in turns, each pass on fresh copies of the rows and
velocities, the median of REPEATS: the velocity change, the carried impulses, the solve (the
spring's bias on), the support sweep, the move, the relax (bias off; a contact still apart
held, as in every substep but the last); the solve again with friction off (every row's
mu_s 0: how much of it friction takes); the whole of one step's substeps; and, on the rows
and velocities those substeps leave, the restitution pass as the step runs it (the rows
marked to bounce) and reading every row (all marked; the same numbers). One thread. A step
runs `substeps` of each pass but the restitution, which runs once. Each pass is timed as a
function compiled on its own; in the step they are inlined into one loop
(benchmarks/compare_commits times the whole step).
"""
import argparse
import math
import statistics
import time

import numpy as np

from benchmarks.common import provenance, write_results
from benchmarks.contact_stages import contacts_of, scene
from pool_sim.physics import Simulation, stepper
from pool_sim.physics.contacts import soft_step
from pool_sim.physics.contacts.detection import detect_contacts
from pool_sim.physics.contacts.soft_contact import MU_S

REPEATS = 31
SCENES = {'resting pile': False, "node_rate's scene": True}  # name: scattered
# Passes timed per contact; the rest (velocity change, move) per member sphere.
PER_MEMBER = ('velocity change', 'move')
WHOLE = "a step's substeps"


def prepared(count, seconds, scattered):
    """prepared_from a resting pile or node_rate's scene (scattered) of count spheres."""
    return prepared_from(scene(count, 'soft_step', True, 1500.0, None, scattered), seconds)


def prepared_from(colliding_scene, seconds, initial_spheres=None):
    """(soft_step.Prepared, settings, dt s, threshold m/s, restitution) of a soft_step
    scene's state (its spheres, or initial_spheres) after `seconds`, its memory as its last
    step left it; the arguments of contact_rows as physics/stepper.py's run_steps passes
    them."""
    return rows_of(*step_inputs(colliding_scene, seconds, initial_spheres))


def step_inputs(colliding_scene, seconds, initial_spheres=None):
    """(colliding: the scene's Simulation after `seconds`; memory: its contact memory as
    its last step left it, copies; state, after: (position, velocity) at the next step's
    start and where the smooth step ends it, detect_contacts' input; reals, wholes: its
    workspace)."""
    effects = [name for name in colliding_scene['effects'] if name != 'collisions']
    colliding = Simulation(colliding_scene, initial_spheres=initial_spheres)
    smooth = Simulation(colliding_scene.with_values(effects=effects),
                        initial_spheres=initial_spheres)
    dt = colliding.max_step
    colliding.run(int(round(seconds / dt)), dt)
    memory = [array.copy() for array in colliding._memory]  # contacts_of steps it again
    smooth.spheres.position[:] = colliding.spheres.position
    smooth.spheres.velocity[:] = colliding.spheres.velocity
    _, _, (state, after, reals, wholes), _ = contacts_of(colliding, smooth)
    return colliding, memory, state, after, reals, wholes


def rows_of(colliding, memory, state, after, reals, wholes):
    """prepared_from's tuple, from step_inputs' (coloured as contacts are found, the CPU's
    default)."""
    spheres, effects, dt = colliding.spheres, colliding.scene['effects'], colliding.max_step
    contacts, used_real, used_whole = detect_contacts(*state, *after, spheres.radius, dt,
                                                      reals, wholes)
    _, _, pool, contact, settings = colliding._constants
    gx, gy, gz = colliding.environment.gravity  # the stepper's resting speed, |g| dt
    threshold = soft_step.RESTING_FACTOR * math.sqrt(gx * gx + gy * gy + gz * gz) * dt
    ready = soft_step.contact_rows(contacts, used_real, used_whole, *state, *after,
                                   spheres.mass, spheres.radius, tuple(pool),
                                   'contact' in effects, tuple(contact),
                                   'friction' in effects, colliding._identity, *memory,
                                   settings, threshold, dt, reals, wholes, False)
    return ready, settings, dt, threshold, contact[0]


def pass_times(ready, settings, dt, threshold, restitution):
    """Median µs of each pass (see the module's docstring), timed in turns."""
    order, inverse_mass, support = ready.solve_order, ready.inverse_mass, ready.support
    h = dt / settings[0]
    push_out_speed, inverse_h = settings[3], 1.0 / h
    supported = np.zeros(ready.sphere.size, dtype=np.bool_)
    frictionless = ready.rows.copy()
    frictionless[:, MU_S] = 0.0
    # Where the substeps leave the rows and velocities: the restitution pass's start.
    solved, solved_velocity = ready.rows.copy(), ready.velocity.copy()
    soft_step._substeps(solved, order, solved_velocity, ready.moved.copy(), ready.change,
                        inverse_mass, settings, dt, support, threshold, supported)
    every_row = np.ones_like(ready.bounces)

    def solve(rows, velocity, moved, bias):
        soft_step.solve_pass(rows, order, velocity, moved, inverse_mass, push_out_speed, bias,
                             inverse_h, True)

    def restitute(rows, velocity, bounces):
        soft_step.restitution_pass(rows, order, velocity, inverse_mass, threshold,
                                   restitution, bounces)
    start = (ready.rows, ready.velocity)
    passes = {  # name: (the rows and velocities it starts from, the pass)
        'velocity change': (start, lambda rows, velocity, moved: soft_step.change_pass(
            velocity, ready.change)),
        'carried impulses': (start, lambda rows, velocity, moved: soft_step.carried_pass(
            rows, order, velocity, inverse_mass)),
        'solve': (start, lambda rows, velocity, moved: solve(rows, velocity, moved, True)),
        'support sweep': (start, lambda rows, velocity, moved: soft_step._support_sweep(
            *support, velocity, moved, inverse_h, threshold, supported)),
        'move': (start, lambda rows, velocity, moved: soft_step.move_pass(moved, velocity, h)),
        'relax': (start, lambda rows, velocity, moved: solve(rows, velocity, moved, False)),
        'solve, no friction': ((frictionless, ready.velocity),
                               lambda rows, velocity, moved: solve(rows, velocity, moved,
                                                                   True)),
        WHOLE: (start, lambda rows, velocity, moved: soft_step._substeps(
            rows, order, velocity, moved, ready.change, inverse_mass, settings, dt, support,
            threshold, supported)),
        'restitution': ((solved, solved_velocity), lambda rows, velocity, moved: restitute(
            rows, velocity, ready.bounces)),
        'restitution, every row read': ((solved, solved_velocity),
                                        lambda rows, velocity, moved: restitute(
                                            rows, velocity, every_row)),
    }
    times = {name: [] for name in passes}
    for _ in range(REPEATS):
        for name, ((rows_from, velocity_from), run_pass) in passes.items():
            rows, velocity, moved = rows_from.copy(), velocity_from.copy(), ready.moved.copy()
            began = time.perf_counter()
            run_pass(rows, velocity, moved)
            times[name].append(time.perf_counter() - began)
    return {name: statistics.median(values) * 1e6 for name, values in times.items()}


def table(results):
    """The markdown table of results: [(scene, count, contacts, members, faces, times)]."""
    names = list(results[0][5])
    lines = ['| scene | spheres | contacts (faces) | spheres in contacts | '
             + ' | '.join(f'{name}, µs' + ('' if name == WHOLE else ' (ns each)')
                          for name in names) + ' |',
             '|---|---:|---:|---:|' + '---:|' * len(names)]
    for scene_name, count, contacts, members, faces, times in results:
        cells = []
        for name in names:
            each = members if name in PER_MEMBER else contacts
            cells.append(f'{times[name]:.0f} ({times[name] * 1e3 / each:.1f})'
                         if name != WHOLE else f'{times[name]:.0f}')
        lines.append(f'| {scene_name} | {count} | {contacts} ({faces}) | {members} | '
                     + ' | '.join(cells) + ' |')
    return '\n'.join(lines)


def main():
    parser = argparse.ArgumentParser(description=__doc__.split('\n\n')[0])
    parser.add_argument('--spheres', type=int, nargs='+', default=[10000, 1000])
    parser.add_argument('--seconds', type=float, default=12.0)
    parser.add_argument('--out', default='results/collisions/solve_passes.md')
    arguments = parser.parse_args()
    stepper.use_threads(1)
    results = []
    for scene_name, scattered in SCENES.items():
        for count in arguments.spheres:
            ready, *rest = prepared(count, arguments.seconds, scattered)
            faces = int(np.sum(ready.solve_order[:, 1] == ready.sphere.size))
            results.append((scene_name, count, ready.rows.shape[0], ready.sphere.size, faces,
                            pass_times(ready, *rest)))
            print(scene_name, count, results[-1][2:], flush=True)
    command = ('.venv/bin/python -m benchmarks.solve_passes --spheres '
               + ' '.join(map(str, arguments.spheres)) + f' --seconds {arguments.seconds:g}')
    text = '\n\n'.join([
        provenance(command),
        f'soft_step after {arguments.seconds:g} s, one thread: each pass of a substep over '
        'all of its contacts (or, for the velocity change and the move, its spheres in '
        f'contacts), µs, median of {REPEATS} in turns; in brackets ns per contact (per '
        "sphere). A step runs each pass once a substep (4 by default), the restitution pass "
        'once.',
        table(results)])
    write_results(arguments.out, text + '\n')


if __name__ == '__main__':
    main()
