"""Whether a change of code costs time: the default step and RK4, at 10 000 and 3 spheres
(and the default step with the collision pass at 1 000), of two checkouts side by side in
one run.

    .venv/bin/python -m benchmarks.layout_cost BEFORE_TREE AFTER_TREE [--rounds 8]

Each round starts one process per tree, in turn (before, after, then after, before, ...),
each importing pool_sim from its own tree only; so the shared machine's slow spells fall
on both alike. A process times every case in turns (10 000 and 1 000 spheres, random
sizes and densities through air and water: 20 steps a call, one thread; 3 spheres, the
default pool: 2 000 steps a call), each from the scene's start.
Printed: ns per sphere-step, the median over every turn of every round, for each tree,
and after / before.
"""
import argparse
import json
import os
import platform
import statistics
import subprocess
import sys
import time

# (integrator, spheres, with collisions): the default effects, and the collision pass too.
CASES = [('linearly_implicit_euler', 10_000, False), ('rk4', 10_000, False),
         ('linearly_implicit_euler', 3, False), ('rk4', 3, False),
         ('linearly_implicit_euler', 1_000, True)]

# Run in a process whose only pool_sim is one tree's; prints {case: [ns per sphere-step]}.
MEASURE = r'''
import json, sys, time
from benchmarks.common import many_spheres_scene
from pool_sim.physics import DEFAULT_EFFECTS, Scene, Simulation, stepper
cases, turns = json.loads(sys.argv[1]), int(sys.argv[2])
stepper.use_threads(1)
simulations = []
for integrator, count, collisions in cases:
    effects = list(DEFAULT_EFFECTS) + (['collisions'] if collisions else [])
    scene = (many_spheres_scene(count, effects, integrator=integrator) if count > 3
             else Scene.default().with_values(integrator=integrator))
    simulations.append((Simulation(scene), 20 if count > 3 else 2000, count))
for simulation, _, _ in simulations:
    simulation.step()  # compiles (or loads) it, outside the timing
samples = [[] for _ in simulations]
for _ in range(turns):
    for (simulation, steps, count), mine in zip(simulations, samples):
        simulation.reset()
        start = time.perf_counter()
        simulation.run(steps, simulation.max_step)
        mine.append((time.perf_counter() - start) / steps / count * 1e9)
print(json.dumps(samples))
'''


def measure(tree, turns):
    """[[ns per sphere-step of each turn] for each case] from one process on `tree`."""
    environment = {**os.environ, 'PYTHONPATH': tree}
    done = subprocess.run([sys.executable, '-c', MEASURE, json.dumps(CASES), str(turns)],
                          cwd=tree, env=environment, capture_output=True, text=True,
                          check=True)
    return json.loads(done.stdout.strip().splitlines()[-1])


def commit_of(tree):
    return subprocess.run(['git', '-C', tree, 'rev-parse', '--short', 'HEAD'],
                          capture_output=True, text=True, check=True).stdout.strip()


def main():
    parser = argparse.ArgumentParser(description=__doc__.split('\n')[0])
    parser.add_argument('before')
    parser.add_argument('after')
    parser.add_argument('--rounds', type=int, default=8)
    parser.add_argument('--turns', type=int, default=7)
    arguments = parser.parse_args()
    trees = {'before': os.path.abspath(arguments.before),
             'after': os.path.abspath(arguments.after)}
    for tree in trees.values():
        measure(tree, 1)  # fills each tree's numba cache: no compiling in the rounds
    samples = {label: [[] for _ in CASES] for label in trees}
    for round_ in range(arguments.rounds):
        order = list(trees) if round_ % 2 == 0 else list(reversed(trees))
        for label in order:
            for mine, got in zip(samples[label], measure(trees[label], arguments.turns)):
                mine.extend(got)
    print(f'{time.strftime("%Y-%m-%d %H:%M")}, {platform.machine()}, {os.cpu_count()} '
          f'cores (shared), Python {platform.python_version()}; before '
          f'{commit_of(trees["before"])}, after {commit_of(trees["after"])}; '
          f'{arguments.rounds} rounds x {arguments.turns} turns per tree, medians.\n')
    print('| integrator | spheres | before, ns/sphere-step | after, ns/sphere-step '
          '| after / before |')
    print('|---|---:|---:|---:|---:|')
    for (integrator, count, collisions), before, after in zip(CASES, samples['before'],
                                                              samples['after']):
        low, high = statistics.median(before), statistics.median(after)
        spheres = f'{count:,}' + (' + collisions' if collisions else '')
        print(f'| {integrator} | {spheres} | {low:.1f} | {high:.1f} | {high / low:.3f} |')


if __name__ == '__main__':
    main()
