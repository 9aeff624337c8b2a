"""The physics core at two commits, in one process, stepped in turns a few steps at a time,
so that a change's cost is measured against the machine's drift (shared machines here run
30 % slower from one hour to the next, and two runs of one benchmark an hour apart differ
by more than most changes).

    .venv/bin/python -m benchmarks.compare_commits --base f7d363b [--spheres 10000]
        [--scattered] [--least-density 300] [--solvers soft_step] [--rounds 15]
        [--out results/collisions/compare.md]

The base commit's `pool_sim/physics` (which imports nothing outside itself) is taken out of
git into a temporary folder as a package of another name, with its own numba cache. Each
solver's scene (benchmarks/contact_stages.py's: the dropped lattice, or with --scattered
node_rate's spheres) is built for both and stepped in lockstep to each moment
(contact_stages.MOMENTS_S and --seconds); there each takes CHUNK steps, in turns, `--rounds`
times, on one thread. The table gives the median µs a step of each, their ratio, and
whether the two made the same numbers to the bit up to then.
"""
import argparse
import importlib
from pathlib import Path
import statistics
import subprocess
import sys
import tarfile
import tempfile
import time

import numpy as np

import benchmarks.common
from benchmarks.common import provenance, write_results
from benchmarks.contact_stages import MOMENTS_S, scene
from benchmarks.collisions import RATE_HZ
import pool_sim.physics
from pool_sim.physics.contacts import SOLVERS

ROOT = Path(__file__).resolve().parent.parent
CHUNK = 10  # steps a turn


def base_physics(commit, folder):
    """The commit's pool_sim/physics, imported as the package pool_sim_base_physics."""
    archive = Path(folder) / 'physics.tar'
    with open(archive, 'wb') as out:
        subprocess.run(['git', 'archive', commit, 'pool_sim/physics'], cwd=ROOT, check=True,
                       stdout=out)
    with tarfile.open(archive) as tar:
        tar.extractall(folder, filter='data')
    (Path(folder) / 'pool_sim' / 'physics').rename(Path(folder) / 'pool_sim_base_physics')
    sys.path.insert(0, str(folder))
    return importlib.import_module('pool_sim_base_physics')


def pair_of_simulations(physics_base, count, solver, least_density, scattered):
    """(this commit's Simulation, the base's) of one scene, each prepared, one thread."""
    made = []
    for physics in (pool_sim.physics, physics_base):
        benchmarks.common.Scene = physics.Scene  # the scene builders' Scene
        try:
            simulation = physics.Simulation(scene(count, solver, True, least_density, None,
                                                  scattered))
        finally:
            benchmarks.common.Scene = pool_sim.physics.Scene
        physics.stepper.use_threads(1)
        simulation.prepare()
        made.append(simulation)
    return made


def same_numbers(one, other):
    return all(np.array_equal(getattr(one.spheres, name), getattr(other.spheres, name))
               for name in ('position', 'velocity'))


def compare(physics_base, count, solver, least_density, scattered, seconds, rounds):
    """[(moment, base µs a step, this µs a step, same numbers so far)]."""
    this, base = pair_of_simulations(physics_base, count, solver, least_density, scattered)
    moments = {**MOMENTS_S, seconds: 'pile'}
    rows, steps_done, dt = [], 0, 1.0 / RATE_HZ
    for at, name in sorted(moments.items()):
        steps = max(int(round(at * RATE_HZ)) - steps_done, 0)
        for simulation in (base, this):
            simulation.run(steps, dt)
        steps_done += steps
        same = same_numbers(this, base)
        times = {'base': [], 'this': []}
        for _ in range(rounds):
            for label, simulation in (('base', base), ('this', this)):
                began = time.perf_counter()
                simulation.run(CHUNK, dt)
                times[label].append((time.perf_counter() - began) / CHUNK)
        steps_done += rounds * CHUNK
        rows.append((name, statistics.median(times['base']), statistics.median(times['this']),
                     same))
    return rows


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument('--base', required=True, help='the commit to compare against')
    parser.add_argument('--spheres', type=int, default=10000)
    parser.add_argument('--seconds', type=float, default=12.0)
    parser.add_argument('--least-density', type=float, default=300.0)
    parser.add_argument('--scattered', action='store_true')
    parser.add_argument('--solvers', nargs='+', choices=sorted(SOLVERS), default=list(SOLVERS))
    parser.add_argument('--rounds', type=int, default=15)
    parser.add_argument('--out', default='results/collisions/compare.md')
    arguments = parser.parse_args()
    base = subprocess.run(['git', 'rev-parse', '--short', arguments.base], cwd=ROOT,
                          check=True, capture_output=True, text=True).stdout.strip()
    scene_words = ('--scattered' if arguments.scattered
                   else f'--least-density {arguments.least_density:g}')
    lines = [provenance(
        f'.venv/bin/python -m benchmarks.compare_commits --base {base} --spheres '
        f'{arguments.spheres} --seconds {arguments.seconds:g} {scene_words} --solvers '
        f'{" ".join(arguments.solvers)} --rounds {arguments.rounds}'), '',
        f'{arguments.spheres} spheres ({"node_rate" if arguments.scattered else "collisions"}'
        f"'s scene), one thread: µs a step at {base} (base) and at this commit, in one "
        f'process, {CHUNK} steps a turn in turns, the median of {arguments.rounds} turns',
        '', '| solver | moment | base | this commit | this / base | the same numbers |',
        '|---|---|---:|---:|---:|---|']
    with tempfile.TemporaryDirectory() as folder:
        physics_base = base_physics(base, folder)
        for solver in arguments.solvers:
            for name, before, after, same in compare(
                    physics_base, arguments.spheres, solver, arguments.least_density,
                    arguments.scattered, arguments.seconds, arguments.rounds):
                lines.append(f'| {solver} | {name} | {before * 1e6:.0f} | {after * 1e6:.0f} | '
                             f'{after / before:.2f} | {"yes" if same else "no"} |')
                print(lines[-1], flush=True)
    write_results(arguments.out, '\n'.join(lines) + '\n')


if __name__ == '__main__':
    main()
