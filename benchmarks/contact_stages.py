"""Where a colliding step's time goes, for each contact solver: the smooth step, the broad
and narrow phase, the warm start's sort, and the solve; and how a dropped pile lands and
rests under each.

    .venv/bin/python -m benchmarks.contact_stages [--spheres 10000] [--seconds 10]
        [--least-density 300] [--solvers soft_step] [--substeps 8] [--scattered]
        [--out results/collisions/stages.md]

The scene is benchmarks/collisions.py's (spheres dropped from a lattice into the default
pool, 200 Hz, one thread), run for `--seconds` with each solver. Its densities start at
300 kg/m^3: a quarter float, and those a little denser than water are still sinking at 12 s.
`--least-density 1500` makes every sphere sink and come to rest: a resting pile.
`--scattered` takes benchmarks/node_rate.py's scene instead (common.scattered_spheres:
radii 0.02 to 0.1 m strewn through the pool's air and water in no spatial order, the node's
defaults). Every half
second of simulated time it samples the deepest overlap (of the smaller radius), the rms and the
fastest speed. At three moments (MOMENTS_S: falling through the water, landing on the
floor and on each other, and the end: the pile), it times, from the same state, turn by
turn, the median of REPEATS:

- one step without `collisions` (the smooth step and the faces);
- contact detection alone (detection.detect_contacts, the workspace the step uses);
- soft_step's warm-start matching: the detected pairs' keys, in detection's order, each
  looked up in the memory the step left (memory.matched; sequential_impulses remembers
  nothing, and its rows leave the column empty);
- one step with `collisions`.

The solve is the colliding step less the step without collisions and less detection: it
holds the matching, the colouring, the rows, the substeps and the restitution pass. Its cost per
contact per pass divides it by the contacts (pairs, and faces touched by spheres in pairs,
as the solver remembers them) and the sweeps over them: three a substep (warm start, solve,
relax) for soft_step; for sequential_impulses, its sweeps are not counted here, so the
column is left empty.
"""
import argparse
import statistics
import time

import numpy as np

from benchmarks.collisions import deepest_overlap, FRICTION, RATE_HZ, RESTITUTION
from benchmarks.common import dropped_scene, provenance, scattered_scene, write_results
from pool_sim.physics import Simulation, stepper
from pool_sim.physics.contacts import soft_step, SOLVERS, workspace
from pool_sim.physics.contacts.detection import detect_contacts
from pool_sim.physics.contacts.memory import matched

REPEATS = 15
MOMENTS_S = {1.5: 'falling', 5.0: 'landing'}  # and the end: 'pile'
SAMPLE_S = 0.5


def scene(count, solver, collisions=True, least_density=300.0, substeps=None,
          scattered=False):
    """The dropped-spheres scene (scattered: node_rate's); substeps: soft_step's (None:
    its default)."""
    chosen = (scattered_scene(count, collisions, solver) if scattered else
              dropped_scene(count, collisions, solver, RATE_HZ, RESTITUTION, FRICTION,
                            least_density))
    return chosen if substeps is None else chosen.with_values(
        **{'soft_step.substeps': substeps})


def contacts_of(colliding, smooth):
    """(pairs detected from colliding's state, contacts its solver remembers after a step
    from there: pairs and faces, or None, detect_contacts' input: the state, where the
    smooth step (smooth, at the same state) ends, the workspace; and the pairs' memory keys
    and home rows, in detection's order, as soft_step makes them)."""
    dt = colliding.max_step
    state = colliding.spheres.position.copy(), colliding.spheres.velocity.copy()
    smooth.step()
    after = smooth.spheres.position.copy(), smooth.spheres.velocity.copy()
    colliding.step()
    remembered = int(colliding._memory[2].sum()) if colliding._memory[0].size else None
    colliding.spheres.position[:], colliding.spheres.velocity[:] = state
    reals, wholes = workspace(colliding.spheres.count)
    contacts, _, _ = detect_contacts(*state, *after, colliding.spheres.radius, dt, reals,
                                     wholes)
    spheres = contacts.order[contacts.pairs]
    identity = colliding._identity[spheres]
    lower = np.argmin(identity, axis=0)
    columns = np.arange(spheres.shape[1])
    keys = (identity[lower, columns] << 32) | identity[1 - lower, columns]
    return (contacts.pairs.shape[1], remembered, (state, after, reals, wholes),
            (keys, spheres[lower, columns]))


def time_stages(colliding, smooth, detection_input, lookups):
    """Median seconds of each stage, timed in turns from colliding's state (lookups: the
    pairs' memory keys and home rows)."""
    state = (colliding.spheres.position.copy(), colliding.spheres.velocity.copy())
    (start, end, reals, wholes), dt = detection_input, colliding.max_step
    memory = colliding._memory

    def restore(simulation):
        simulation.spheres.position[:], simulation.spheres.velocity[:] = state

    def step(simulation):
        restore(simulation)
        began = time.perf_counter()
        simulation.step()
        return time.perf_counter() - began

    def detect():
        began = time.perf_counter()
        detect_contacts(*start, *end, colliding.spheres.radius, dt, reals, wholes)
        return time.perf_counter() - began

    def match():
        began = time.perf_counter()
        matched(*lookups, memory[0], memory[2])
        return time.perf_counter() - began
    stages = {'without collisions': lambda: step(smooth), 'detection': detect,
              'with collisions': lambda: step(colliding)}
    if memory[0].shape[0]:  # a solver that remembers (rows of memory are the spheres')
        stages['matching'] = match
    times = {name: [] for name in stages}
    for _ in range(REPEATS):
        for name, stage in stages.items():
            times[name].append(stage())
    restore(colliding)
    return {name: statistics.median(values) for name, values in times.items()}


def run(count, seconds, solver, least_density, substeps, scattered=False):
    colliding = Simulation(scene(count, solver, True, least_density, substeps, scattered))
    smooth = Simulation(scene(count, solver, False, least_density, substeps, scattered))
    colliding.prepare()
    smooth.prepare()
    samples, rows = [], []
    steps_per_sample = int(round(SAMPLE_S * RATE_HZ))
    moments = {int(round(at / SAMPLE_S)): name for at, name in MOMENTS_S.items()}
    moments[int(round(seconds / SAMPLE_S))] = 'pile'
    for sample in range(1, int(round(seconds / SAMPLE_S)) + 1):
        colliding.run(steps_per_sample, 1.0 / RATE_HZ)
        spheres = colliding.spheres
        speed = np.linalg.norm(spheres.velocity, axis=0)
        fastest = int(np.argmax(speed))
        samples.append((sample * SAMPLE_S, deepest_overlap(colliding),
                        float(np.sqrt(np.mean(speed**2))), float(speed[fastest]),
                        float(spheres.mass[fastest] / spheres.volume[fastest])))
        if sample in moments:
            smooth.spheres.position[:] = colliding.spheres.position
            smooth.spheres.velocity[:] = colliding.spheres.velocity
            pairs, remembered, detection_input, lookups = contacts_of(colliding, smooth)
            stages = time_stages(colliding, smooth, detection_input, lookups)
            rows.append((moments[sample], pairs, remembered, stages))
    return samples, rows


def stage_table(count, results, substeps=None):
    lines = [f'{count} spheres, one step, µs (median of {REPEATS}, in turns); the solve is '
             'the step with collisions less the step without and less detection', '',
             '| solver | moment | pairs | contacts remembered | step without collisions | '
             'detection | warm-start matching | solve | step with collisions | '
             'ns per sphere-step | broad phase share | matching share | solve share | '
             'ns per contact per pass |', '|' + '---|' * 2 + '---:|' * 12]
    for solver, (_, rows) in results.items():
        passes = 3 * (substeps or soft_step.SUBSTEPS) if solver == 'soft_step' else None

        def match(value, form, matches=solver == 'soft_step'):
            return format(value, form) if matches else ''  # sequential_impulses: no memory
        for moment, pairs, remembered, t in rows:
            total = t['with collisions']
            solve = total - t['without collisions'] - t['detection']
            per_contact = (f'{solve / ((remembered or pairs) * passes) * 1e9:.1f}'
                           if passes and (remembered or pairs) else '')
            matching = t.get('matching', 0.0)
            lines.append(
                f'| {solver} | {moment} | {pairs} | {remembered if remembered else ""} | '
                f'{t["without collisions"] * 1e6:.0f} | {t["detection"] * 1e6:.0f} | '
                f'{match(matching * 1e6, ".0f")} | {solve * 1e6:.0f} | {total * 1e6:.0f} | '
                f'{total / count * 1e9:.0f} | {t["detection"] / total:.2f} | '
                f'{match(matching / total, ".2f")} | {solve / total:.2f} | {per_contact} |')
    return lines


def pile_table(results, settled_s=8.0):
    lines = ['Every 0.5 s of the run: the deepest overlap / smaller radius, rms and fastest '
             'speed, m/s, and the fastest sphere\'s density, kg/m^3 (one a little denser than '
             'the water\'s 1000 sinks slowly: at 1091 kg/m^3 and 31 mm, its terminal speed '
             'sqrt(8/3 r g (rho - rho_w) / (rho_w C_d)) is 0.40 m/s)', '', '| t s | ' + ' | '.join(
                 f'{solver} overlap | {solver} rms | {solver} fastest | {solver} its density'
                 for solver in results) + ' |', '|---:|' + '---:|' * 4 * len(results)]
    columns = [samples for samples, _ in results.values()]
    for row in zip(*columns):
        lines.append(f'| {row[0][0]:g} | ' + ' | '.join(
            f'{overlap:.4f} | {rms:.2g} | {fastest:.2g} | {density:.0f}'
            for _, overlap, rms, fastest, density in row) + ' |')
    lines += ['', f'From {settled_s:g} s on (the largest of the samples), and over the whole '
              'run:', '', '| solver | rms, m/s | fastest, m/s | deepest overlap | deepest '
              'overlap over the run |', '|---|---:|---:|---:|---:|']
    for solver, (samples, _) in results.items():
        late = [sample for sample in samples if sample[0] >= settled_s] or samples[-1:]
        lines.append(f'| {solver} | {max(s[2] for s in late):.2g} | '
                     f'{max(s[3] for s in late):.2g} | {max(s[1] for s in late):.4f} | '
                     f'{max(s[1] for s in samples):.4f} |')
    return lines


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument('--spheres', type=int, default=10000)
    parser.add_argument('--seconds', type=float, default=10.0)
    parser.add_argument('--least-density', type=float, default=300.0,
                        help='kg/m^3; from 1000 up every sphere sinks and comes to rest')
    parser.add_argument('--solvers', nargs='+', choices=sorted(SOLVERS), default=list(SOLVERS))
    parser.add_argument('--substeps', type=int, help="soft_step's (default: the scene key's)")
    parser.add_argument('--scattered', action='store_true',
                        help="benchmarks/node_rate.py's scene (--least-density is not used)")
    parser.add_argument('--out', default='results/collisions/stages.md')
    arguments = parser.parse_args()
    if arguments.seconds < max(MOMENTS_S) + SAMPLE_S:
        parser.error(f'--seconds: at least {max(MOMENTS_S) + SAMPLE_S:g}')
    stepper.use_threads(1)
    results = {solver: run(arguments.spheres, arguments.seconds, solver,
                           arguments.least_density, arguments.substeps, arguments.scattered)
               for solver in arguments.solvers}
    densities = ("benchmarks/node_rate.py's scene: radii 0.02 to 0.1 m, densities from 100 to "
                 "3000 kg/m^3." if arguments.scattered else
                 f'Densities from {arguments.least_density:g} to 3000 kg/m^3.')
    text = '\n'.join([provenance(
        f'.venv/bin/python -m benchmarks.contact_stages --spheres {arguments.spheres} '
        f'--seconds {arguments.seconds:g}'
        + (' --scattered' if arguments.scattered else
           f' --least-density {arguments.least_density:g}')
        + (f' --solvers {" ".join(arguments.solvers)}' if arguments.solvers != list(SOLVERS)
           else '') + (f' --substeps {arguments.substeps}' if arguments.substeps else '')),
        densities, '',
        *stage_table(arguments.spheres, results, arguments.substeps),
        '', *pile_table(results)]) + '\n'
    write_results(arguments.out, text)


if __name__ == '__main__':
    main()
