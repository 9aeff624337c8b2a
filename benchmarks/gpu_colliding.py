"""Colliding spheres stepped on the GPU: a Simulation with `backend: cuda` and `collisions`
(soft_step), the whole step on the device (docs/gpu.md), on benchmarks/gpu_solve.py's
lattice piles at rest and landing, by size. benchmarks/gpu.py runs it (--colliding-sizes);
alone:

    python3 -m benchmarks.gpu_colliding [--sizes 100000 1000000] [--out results/gpu]

For each pile: Simulation.prepare (the kernels compiled, on copies), then --steps calls of
Simulation.run(1) at the default 200 Hz, each timed to its end (the guard's count comes
home), their median in ms and ns per sphere-step and the real-time factor it allows; then
the pile stepped for --settle-s more, and how quiet it is: the rms and largest speed, and
the deepest overlap of two spheres as a share of the radius (scipy's KD-tree over the
host's copy). The issue's goal: 1 M spheres at >= 1 x real time, the pile at rest with rms
<= 5 mm/s and overlaps <= 1 %.
"""
import argparse
import statistics
import time

import numpy as np
from scipy.spatial import cKDTree

from benchmarks.gpu_solve import by_scene, pile, RADIUS, SCENES, table
from pool_sim.physics import DEFAULT_EFFECTS, Scene, Simulation


def colliding_row(count, landing, steps, settle_s):
    """The figures of one pile at one size (a dict: the CSV's row)."""
    scene = Scene({'sphere_names': ['s0'], 'backend': 'cuda', 'contact_solver': 'soft_step',
                   'effects': [*DEFAULT_EFFECTS, 'collisions']})
    sim = Simulation(scene, initial_spheres=pile(count, landing))
    row = {'scene': SCENES[landing], 'spheres': count, 'prepare_s': sim.prepare()}
    dt = sim.max_step
    samples = []
    for _ in range(steps):
        began = time.perf_counter()
        sim.run(1, dt)
        samples.append(time.perf_counter() - began)
    seconds = statistics.median(samples)
    row.update(step_ms=seconds * 1e3, ns_per_sphere_step=seconds / count * 1e9,
               real_time_factor=dt / seconds)
    sim.run(max(0, int(round(settle_s / dt)) - steps), dt)
    spheres = sim.spheres
    speed = np.linalg.norm(spheres.velocity, axis=0)
    pairs = cKDTree(spheres.position.T).query_pairs(2.0 * RADIUS, output_type='ndarray')
    apart = np.linalg.norm(spheres.position[:, pairs[:, 0]] - spheres.position[:, pairs[:, 1]],
                           axis=0)
    row.update(settled_s=sim.time, rms_speed=float(np.sqrt(np.mean(speed**2))),
               max_speed=float(speed.max()),
               deepest_overlap=float((2.0 * RADIUS - apart).max(initial=0.0) / RADIUS),
               recoveries=sim.recoveries, finite=bool(np.isfinite(spheres.position).all()))
    return row


def measure(sizes, steps, settle_s, out, command):
    """(rows, the section of gpu.md they make); gpu_colliding.csv and .md written into out
    after each row (gpu_solve.by_scene)."""
    return by_scene(sizes, lambda count, landing: colliding_row(count, landing, steps,
                                                                settle_s),
                    'gpu_colliding', lambda rows: section(rows, steps), out, command)


def section(rows, steps):
    """The markdown section of colliding_row's rows."""
    return '\n\n'.join([
        '## Colliding spheres stepped on the GPU (benchmarks/gpu_colliding.py)',
        'A Simulation with backend cuda, the default effects and collisions (soft_step, '
        f'coloured by priority), on a lattice pile (radius {RADIUS} m), at 200 Hz: '
        f'step_ms the median of {steps} calls of run(1), each to its end; then stepped to '
        'settled_s, and how quiet it is (m/s; the deepest overlap as a share of the radius).',
        table(rows)])


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument('--sizes', type=int, nargs='+', default=[100_000, 1_000_000])
    parser.add_argument('--steps', type=int, default=20)
    parser.add_argument('--settle-s', type=float, default=1.0)
    parser.add_argument('--out', default='results/gpu')
    arguments = parser.parse_args()
    command = ('python3 -m benchmarks.gpu_colliding --sizes '
               + ' '.join(map(str, arguments.sizes)))
    _, text = measure(arguments.sizes, arguments.steps, arguments.settle_s, arguments.out,
                      command)
    print(text)


if __name__ == '__main__':
    main()
