"""A closed loop at machine speed: the default pool, depth_keeper holding ice at 1 m depth
for 20 simulated seconds, with lockstep and without.

    .venv/bin/python -m benchmarks.lockstep [--runs 10] [--process-runs 3]
        [--baseline DIR] [--free-runs 7] [--out results/node/lockstep.md]

Rows:
- in-process, lockstep (pool_sim.testing, EventsExecutor / SingleThreadedExecutor): wall
  seconds of `advance(20.0)`; digest: sha256 of every sphere's state after each simulated
  second.
- the same loop with a recorder node answering for cork (it sees every instant): digest of
  every instant's ~/states, to compare with the processes.
- across processes: `python -m pool_sim` (lockstep, params file) and
  `python -m pool_sim.ros.depth_keeper`, the recorder in this process; wall seconds from
  the recorder holding t = 0 to holding t = 20 s.
- lockstep off, in-process with the node's clock thread (as before issue 14): ice z at
  20 s at real_time_factor 5 and 0.
- free running, no controller, real_time_factor 0, lockstep off: simulated seconds per
  wall second over 5 s; with --baseline DIR also for the checkout in DIR (another commit),
  in the same run.
Each row is medians (and ranges) over its runs, all in one run of this script.
"""
import argparse
from collections import Counter
import hashlib
import os
from pathlib import Path
import statistics
import subprocess
import sys
import tempfile
import time

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO / 'msg_tests'))
os.environ.setdefault('ROS_DOMAIN_ID', str(150 + os.getpid() % 50))
os.environ.setdefault('ROS_AUTOMATIC_DISCOVERY_RANGE', 'LOCALHOST')

from lockstep_nodes import (LOCKSTEP_PARAMS, record_across_processes,  # noqa: E402
                            record_in_process)
from benchmarks.common import provenance  # noqa: E402
from pool_sim.ros.depth_keeper import DepthKeeper  # noqa: E402
from pool_sim.testing import PoolSim  # noqa: E402

SCENE = {'lockstep_inputs': ['ice'], 'wrench_timeout': 0.0, 'real_time_factor': 0.0}
FREE_RUN = '''
import sys, time
sys.path.insert(0, {tree!r}); sys.path.insert(0, {tree!r} + '/msg_tests')
from ros_harness import Harness
with Harness({{'real_time_factor': 0.0}}) as ros:
    ros.spin_for(1.0)
    with ros.sim.lock():
        s0, w0 = ros.sim.clock.simulated_s, time.monotonic()
    ros.spin_for(5.0)
    with ros.sim.lock():
        print((ros.sim.clock.simulated_s - s0) / (time.monotonic() - w0))
'''


def in_process(executor):
    with PoolSim(SCENE, executor=executor) as sim:
        sim.add(DepthKeeper)
        digest = hashlib.sha256()
        started = time.perf_counter()
        for _ in range(20):
            sim.advance(1.0)
            digest.update(sim.states().tobytes())
        wall = time.perf_counter() - started
        return wall, sim.state('ice')[0][2], digest.hexdigest()


def with_recorder(params_file):
    with PoolSim(params_file=params_file) as sim:
        digest, _, _ = record_in_process(sim)
        return digest, sim.state('ice')[0][2]


def free_running(tree):
    output = subprocess.run([sys.executable, '-c', FREE_RUN.format(tree=str(tree))],
                            capture_output=True, text=True, timeout=120)
    return float(output.stdout.strip().splitlines()[-1])


def lockstep_off(real_time_factor):
    from ros_harness import Harness
    with Harness({'real_time_factor': real_time_factor, 'wrench_timeout': 0.0},
                 extra_nodes=[DepthKeeper]) as ros:
        started = time.perf_counter()
        ros.spin_until(lambda: ros.sim.simulation.time >= 20.0, 60.0)
        with ros.sim.lock():
            return (time.perf_counter() - started, ros.sim.simulation.sphere_state('ice')[0][2],
                    ros.sim.simulation.time)


def spread(values, digits=3):
    return (f'{statistics.median(values):.{digits}f} ({min(values):.{digits}f}–'
            f'{max(values):.{digits}f})')


def main():
    parser = argparse.ArgumentParser()
    parser.add_argument('--runs', type=int, default=10)
    parser.add_argument('--process-runs', type=int, default=3)
    parser.add_argument('--baseline', type=Path, default=None)
    parser.add_argument('--free-runs', type=int, default=7)
    parser.add_argument('--out', type=Path, default=REPO / 'results/node/lockstep.md')
    args = parser.parse_args()
    commit = subprocess.run(['git', 'rev-parse', '--short', 'HEAD'], cwd=REPO,
                            capture_output=True, text=True).stdout.strip()
    lines = [f'# Lockstep: the depth_keeper loop, 20 simulated s (commit {commit})', '',
             provenance(' '.join(['.venv/bin/python -m benchmarks.lockstep', *sys.argv[1:]])),
             '',
             'Default pool (3 spheres, 200 Hz physics, 30 Hz publishing), depth_keeper '
             'holding ice at 1 m depth (target z = -1.0 m); medians (ranges) of the runs.', '',
             '| loop | runs | wall s | × real time | ice z at 20 s | distinct results |',
             '|---|---:|---|---:|---|---:|']
    for executor in ('events', 'single'):
        runs = [in_process(executor) for _ in range(args.runs)]
        walls = [w for w, _, _ in runs]
        lines.append(f'| in-process lockstep, pool_sim.testing ({executor} executor) | '
                     f'{args.runs} | {spread(walls)} | {20.0 / statistics.median(walls):.0f} '
                     f'| {float(runs[0][1])!r} | {len(Counter(d for _, _, d in runs))} |')
        print(lines[-1], flush=True)
    with tempfile.TemporaryDirectory() as folder:
        params_file = Path(folder) / 'lockstep.yaml'
        params_file.write_text(LOCKSTEP_PARAMS)
        recorded = [with_recorder(params_file) for _ in range(args.process_runs)]
        lines.append(f'| in-process lockstep with the recorder (answers for cork) | '
                     f'{args.process_runs} | | | {float(recorded[0][1])!r} | '
                     f'{len(Counter(d for d, _ in recorded))} |')
        print(lines[-1], flush=True)
        processes = [record_across_processes(params_file)[:2]
                     for _ in range(args.process_runs)]
        walls = [w for w, _ in processes]
        same = all(d == recorded[0][0] for _, d in processes)
        lines.append(f'| across processes lockstep (node, depth_keeper, recorder) | '
                     f'{args.process_runs} | {spread(walls)} | '
                     f'{20.0 / statistics.median(walls):.0f} | | '
                     f'{len(Counter(d for _, d in processes))} '
                     f'({"the in-process one" if same else "NOT the in-process one"}) |')
        print(lines[-1], flush=True)
    for factor in (5.0, 0.0):
        runs = [lockstep_off(factor) for _ in range(args.process_runs)]
        zs = ', '.join(f'{float(z)!r}' for _, z, _ in runs)
        lines.append(f'| lockstep off, clock thread, real_time_factor {factor:g} | '
                     f'{args.process_runs} | {spread([w for w, _, _ in runs])} | | {zs} '
                     f'(at t = {", ".join(f"{t:.3f}" for _, _, t in runs)} s) | '
                     f'{len(Counter(z for _, z, _ in runs))} |')
        print(lines[-1], flush=True)
    lines += ['', 'Free running, no controller, lockstep off, real_time_factor 0: simulated s '
              f'per wall s over 5 s (median of {args.free_runs}, interleaved)', '', '| checkout | × real time |', '|---|---:|']
    trees = [('this commit', REPO)]
    if args.baseline:
        base = subprocess.run(['git', 'rev-parse', '--short', 'HEAD'], cwd=args.baseline,
                              capture_output=True, text=True).stdout.strip()
        trees.append((f'baseline {base}', args.baseline))
    results = {name: [] for name, _ in trees}
    for _ in range(args.free_runs):
        for name, tree in trees:  # interleaved: the same machine state for both
            results[name].append(free_running(tree))
    for name, values in results.items():
        lines.append(f'| {name} | {spread(values, 1)} |')
        print(lines[-1], flush=True)
    args.out.parent.mkdir(parents=True, exist_ok=True)
    args.out.write_text('\n'.join(lines) + '\n')
    print(f'written {args.out}')


if __name__ == '__main__':
    main()
