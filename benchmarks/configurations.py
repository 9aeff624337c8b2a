"""What every configuration costs: each integrator with the default effects, with lift and
with added mass, and the linear submerged volume, all compiled, side by side in one run.

    .venv/bin/python -m benchmarks.configurations [--out results/configurations.md]

- 3 spheres (the default pool): µs per step, many steps in one call (as
  Simulation.advance and the node's tick run them: 2 000 steps from the start, the
  configurations taking turns, median of 15 turns) and one step per call from Python;
  the goal: no more than the integrator's force evaluations x the default's cost + 1 µs,
  and lift or added mass no more than 1.3x the same integrator without them.
- 10 000 spheres (random sizes and densities through air and water, one thread, as the
  node runs it): ns per sphere-step against the memory-bandwidth bound of the bytes that
  configuration's step must move (the arrays it reads and writes), from a copy bandwidth
  measured in the same run; the goal: within 1.5x.
- 1 sphere, the default step beside MuJoCo's with its fluid model, both ways of calling.
- Compile time of the default step, cold (an empty numba cache) and warm (from the cache),
  each in a fresh process: the seconds pool_sim's node spends on it before its first state.
"""
import argparse
import os
from pathlib import Path
import platform
import statistics
import subprocess
import sys
import tempfile
import time

import numpy as np

from benchmarks.common import many_spheres_scene, provenance, seconds_per_step_in_turns, timed, \
    write_results
from benchmarks.scaling import copy_bandwidth_bytes_per_s, mujoco_cost, pool_sim_cost
from pool_sim.physics import DEFAULT_EFFECTS, INTEGRATORS, Scene, Simulation, stepper
from pool_sim.physics.integrators import DEFAULT_INTEGRATOR, FORCE_EVALUATIONS

VARIANTS = [('default effects', list(DEFAULT_EFFECTS), 'cap'),
            ('+ lift', list(DEFAULT_EFFECTS) + ['lift'], 'cap'),
            ('+ added_mass', list(DEFAULT_EFFECTS) + ['added_mass'], 'cap'),
            ('linear volume', list(DEFAULT_EFFECTS), 'linear')]
# Bytes a sphere-step must move: it reads position, velocity, external force, mass,
# radius, volume, cross-section and drag coefficient (doubles), writes position and velocity
# (into the other pair of state arrays) and one byte that marks it for the contact pass.
BYTES_DEFAULT = 8 * ((3 + 3 + 3 + 5) + (3 + 3)) + 1
BYTES_LIFT = 8 * 5  # lift also reads its coefficient, its area and its normal
SMALL_STEPS, SMALL_TURNS = 2000, 15
LIFT_COEFFICIENT = 0.2  # every sphere's, so that lift, where listed, acts
LARGE_COUNT, LARGE_STEPS, LARGE_TURNS = 10_000, 20, 11

COMPILE_ONCE = '''
import time
started = time.perf_counter()
from pool_sim.physics import Scene, Simulation
imported = time.perf_counter()
print(imported - started, Simulation(Scene.default()).prepare())
'''


def small_costs():
    """{(integrator, variant): (µs per step many a call, µs per step one a call)}."""
    keys, simulations = [], []
    for integrator in INTEGRATORS:
        for label, effects, volume in VARIANTS:
            keys.append((integrator, label))
            scene = Scene.default().with_values(integrator=integrator, effects=effects)
            simulations.append(Simulation(scene.with_spheres(
                scene.sphere_names, {'spheres.lift_coefficient': [LIFT_COEFFICIENT] * 3}),
                volume))
    many = seconds_per_step_in_turns(simulations, SMALL_STEPS, SMALL_TURNS, restart=True)
    one = [timed(simulation.step) for simulation in simulations]
    return {key: (m * 1e6, o * 1e6) for key, m, o in zip(keys, many, one)}


def large_costs():
    """{(integrator, variant): ns per sphere-step at LARGE_COUNT spheres}."""
    stepper.use_threads(1)
    keys, simulations = [], []
    for integrator in INTEGRATORS:
        for label, effects, volume in VARIANTS:
            keys.append((integrator, label))
            simulations.append(Simulation(many_spheres_scene(
                LARGE_COUNT, effects, integrator=integrator,
                **{'spheres.lift_coefficient': [LIFT_COEFFICIENT] * LARGE_COUNT}), volume))
    seconds = seconds_per_step_in_turns(simulations, LARGE_STEPS, LARGE_TURNS, restart=True)
    return {key: s / LARGE_COUNT * 1e9 for key, s in zip(keys, seconds)}


def compile_seconds(repeats=3):
    """(import s, cold compile s, warm load s): medians, each a fresh process; cold with an
    empty numba cache of its own, warm from the cache that run left."""
    cold, warm, imports = [], [], []
    for _ in range(repeats):
        with tempfile.TemporaryDirectory() as cache:
            environment = {**os.environ, 'NUMBA_CACHE_DIR': cache}
            for into in (cold, warm):
                out = subprocess.run([sys.executable, '-c', COMPILE_ONCE], env=environment,
                                     capture_output=True, text=True, check=True).stdout
                imported, prepared = map(float, out.split())
                into.append(prepared)
                imports.append(imported)
    return statistics.median(imports), statistics.median(cold), statistics.median(warm)


def table(small, large, bandwidth, one_sphere, compiling):
    default_small = small[(DEFAULT_INTEGRATOR, 'default effects')][0]
    lines = [f'Machine: {platform.machine()}, {os.cpu_count()} cores, Python '
             f'{platform.python_version()}, numpy {np.__version__}; copy bandwidth '
             f'{bandwidth / 1e9:.1f} GB/s (read + write); measured at '
             f'{time.strftime("%Y-%m-%d")}, one run.', '',
             f'3 spheres (the default pool): µs per step, {SMALL_STEPS} steps a call (median '
             f'of {SMALL_TURNS} turns); goal: force evaluations × the default '
             f'({default_small:.3f} µs) + 1 µs. {LARGE_COUNT:,} spheres: ns per sphere-step '
             f'(median of {LARGE_TURNS} turns of {LARGE_STEPS} steps, one thread) against '
             'the bandwidth bound of the bytes its step moves; goal: within 1.5×.', '',
             '| integrator | effects | force evaluations | 3 spheres, µs/step | goal, µs | '
             'vs same integrator, default effects | one step per call, µs | '
             f'{LARGE_COUNT:,} spheres, ns/sphere-step | bandwidth bound, ns | ratio |',
             '|---|---|---:|---:|---:|---:|---:|---:|---:|---:|']
    worst_ratio = worst_share = worst_large = 0.0
    for integrator in INTEGRATORS:
        evaluations = FORCE_EVALUATIONS[integrator]
        base = small[(integrator, 'default effects')][0]
        for label, effects, _ in VARIANTS:
            many, one = small[(integrator, label)]
            goal = evaluations * default_small + 1.0
            worst_share = max(worst_share, many / goal)
            share = many / base
            if label in ('+ lift', '+ added_mass'):
                worst_ratio = max(worst_ratio, share)
            bound = (BYTES_DEFAULT + (BYTES_LIFT if 'lift' in effects else 0)) / bandwidth * 1e9
            ratio = large[(integrator, label)] / bound
            worst_large = max(worst_large, ratio)
            lines.append(f'| {integrator} | {label} | {evaluations} | {many:.3f} | {goal:.2f} | '
                         f'{share:.2f} | {one:.2f} | {large[(integrator, label)]:.1f} | '
                         f'{bound:.1f} | {ratio:.2f} |')
    ours_many, ours_one, mujoco_many, mujoco_one = one_sphere
    imported, cold, warm = compiling
    lines += ['', f'Largest share of its 3-sphere goal: {worst_share:.2f} (≤ 1 meets it); '
              f'largest cost of lift or added mass over the same integrator: '
              f'{worst_ratio:.2f}× (goal ≤ 1.3); largest ratio to the bandwidth bound at '
              f'{LARGE_COUNT:,} spheres: {worst_large:.2f} (goal ≤ 1.5).', '',
              '1 sphere, µs per step, side by side: '
              f'pool_sim default {ours_many:.3f} many steps a call, {ours_one:.2f} one step '
              f'a call; MuJoCo with its fluid model {mujoco_many:.3f} many steps a call '
              f'(mj_step nstep), {mujoco_one:.2f} one step a call.', '',
              f'Compile of the default step (fresh processes, medians of 3): cold '
              f'{cold:.2f} s (empty numba cache), warm {warm:.2f} s (loaded from the cache); '
              f'importing pool_sim.physics (numba with it) {imported:.2f} s.']
    return '\n'.join(lines) + '\n'


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument('--out', default='results/configurations.md')
    out = Path(parser.parse_args().out)
    compiling = compile_seconds()
    print('compile', compiling, flush=True)
    bandwidth = copy_bandwidth_bytes_per_s()
    small = small_costs()
    print('small done', flush=True)
    large = large_costs()
    print('large done', flush=True)
    pool_sim_cost(1, DEFAULT_EFFECTS)  # the first timing in a process runs slow
    one_sphere = (pool_sim_cost(1, DEFAULT_EFFECTS) / 1000,
                  pool_sim_cost(1, DEFAULT_EFFECTS, one_per_call=True) / 1000,
                  mujoco_cost(1, True) / 1000, mujoco_cost(1, True, one_per_call=True) / 1000)
    text = table(small, large, bandwidth, one_sphere, compiling)
    write_results(out, provenance('.venv/bin/python -m benchmarks.configurations') + '\n\n'
                  + text)


if __name__ == '__main__':
    main()
