"""Start-up, shutdown and memory of the node against the sphere count, as users start it.

    .venv/bin/python -m benchmarks.startup [--spheres 100,1000,10000,100000]
        [--per-sphere 100,1000,2500] [--out results/node/startup.md]

Each row is one node process (`python -m pool_sim --ros-args --params-file f`), the scene
given as `spheres.<key>` arrays (mass, radius, position as x, y, z). First pose published:
the node's own log, process start to its first ~/poses. Received: wall seconds from
launching the process to a client in this process holding the first ~/poses
(transient-local, so a pose sent before the client matched counts); the difference is DDS
discovery, which on this machine takes 0.1 s or, when the first announcement is missed,
about 3 s. Shutdown: SIGINT to exit. Node memory: the node's resident set
once running, less that of the core alone (a process that builds the same Scene and
Simulation and steps it): what the ROS layer adds, per sphere above the 100-sphere row.
Medians of --repeats processes a row.
"""
import argparse
import os
from pathlib import Path
import re
import shlex
import signal
import statistics
import subprocess
import sys
import tempfile
import time

from benchmarks.common import provenance
from geometry_msgs.msg import PoseArray
import numpy as np
import rclpy
from rclpy.context import Context
from rclpy.executors import SingleThreadedExecutor
from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy

LIMIT_S = 900.0
# A DDS domain of its own: other participants on the machine (a test run) would slow the
# discovery being measured.
DOMAIN_ID = 100 + os.getpid() % 100
SETTLE_S = 2.0  # after the first pose, before reading the resident set


def params_file(count, per_sphere_topics, path):
    """`count` spheres scattered through the pool, every per-sphere key as an array."""
    rng = np.random.default_rng(count)
    radius = rng.uniform(0.005, 0.02, count)
    mass = rng.uniform(100.0, 3000.0, count) * 4.0 / 3.0 * np.pi * radius**3
    position = rng.uniform(-3.5, 3.5, (count, 3))

    def numbers(values):
        return '[' + ', '.join(f'{v:.6e}' for v in np.ravel(values)) + ']'  # all doubles
    names = ', '.join(f's{i}' for i in range(count))
    path.write_text(
        '/**:\n  ros__parameters:\n'
        f'    sphere_names: [{names}]\n'
        f'    per_sphere_topics: {"true" if per_sphere_topics else "false"}\n'
        f'    spheres:\n      mass: {numbers(mass)}\n      radius: {numbers(radius)}\n'
        '      position:\n'
        + ''.join(f'        {c}: {numbers(position[:, i])}\n' for i, c in enumerate('xyz')))
    return path


def resident_bytes(pid):
    with open(f'/proc/{pid}/status') as status:
        for line in status:
            if line.startswith('VmRSS:'):
                return int(line.split()[1]) * 1024
    return 0


CORE_ONLY = '''
import sys
from pool_sim.physics import Scene, Simulation
from pool_sim.ros.node_keys import NODE_SCENE
sim = Simulation(Scene.from_yaml(sys.argv[1], extension=NODE_SCENE))
for _ in range(10):
    sim.step()
with open('/proc/self/status') as status:
    print(next(l for l in status if l.startswith('VmRSS:')).split()[1])
'''


def core_resident_bytes(path):
    out = subprocess.run([sys.executable, '-c', CORE_ONLY, str(path)], check=True,
                         capture_output=True, text=True).stdout
    return int(out.split()[-1]) * 1024


def measure(path, count):
    namespace = f'/startup{os.getpid()}_{count}'
    launched = time.monotonic()
    node = subprocess.Popen(
        [sys.executable, '-m', 'pool_sim', '--ros-args', '--params-file', str(path),
         '-r', f'__ns:={namespace}'], stdout=subprocess.DEVNULL, stderr=subprocess.PIPE,
        text=True, env={**os.environ, 'ROS_DOMAIN_ID': str(DOMAIN_ID)})
    context = Context()
    rclpy.init(context=context, domain_id=DOMAIN_ID)
    first_pose = resident = None
    try:
        client = rclpy.create_node('startup_client', context=context)
        executor = SingleThreadedExecutor(context=context)
        executor.add_node(client)
        got = []
        latched = QoSProfile(depth=1, durability=DurabilityPolicy.TRANSIENT_LOCAL,
                             reliability=ReliabilityPolicy.RELIABLE)
        client.create_subscription(PoseArray, f'{namespace}/pool_sim/poses',
                                   lambda m: got.append(len(m.poses)), latched)
        while not got and time.monotonic() - launched < LIMIT_S and node.poll() is None:
            executor.spin_once(timeout_sec=0.02)
        if got:
            first_pose = time.monotonic() - launched
            time.sleep(SETTLE_S)
            resident = resident_bytes(node.pid)
        executor.shutdown()
        client.destroy_node()
    finally:
        rclpy.shutdown(context=context)
        stopping = time.monotonic()
        node.send_signal(signal.SIGINT)
        _, log = node.communicate(timeout=LIMIT_S)
        shutdown = time.monotonic() - stopping
    if first_pose is None:
        raise RuntimeError(f'{count} spheres: no pose; the node said:\n{log[-2000:]}')
    published = re.search(r'first state published; this process started ([\d.]+) s ago', log)
    return first_pose, shutdown, resident, float(published.group(1))


def table(counts, per_sphere_topics, folder, repeats):
    rows, base = [], None
    for count in counts:
        path = params_file(count, per_sphere_topics, Path(folder) / f's{count}.yaml')
        runs = [measure(path, count) for _ in range(repeats)]
        first_poses = sorted(run[0] for run in runs)
        first_pose = statistics.median(first_poses)
        shutdown = statistics.median(run[1] for run in runs)
        resident = statistics.median(run[2] for run in runs)
        published = statistics.median(run[3] for run in runs)
        core = core_resident_bytes(path)
        above_core = resident - core
        if base is None:
            base = (count, above_core)
        per_sphere = ((above_core - base[1]) / (count - base[0]) if count > base[0]
                      else float('nan'))
        spread = ', '.join(f'{t:.2f}' for t in first_poses)
        rows.append(f'| {count:,} | {published:.2f} | {first_pose:.2f} ({spread}) | '
                    f'{shutdown:.2f} | '
                    f'{resident / 2**20:.0f} | {core / 2**20:.0f} | {per_sphere:,.0f} |')
        print(rows[-1], flush=True)
    return rows


HEADER = ('| spheres | first pose published (node), s | first pose received (client), s: '
          'median (each run) | shutdown, s | node resident, MiB | core alone, MiB | '
          'node above core, bytes per sphere (above the first row) |\n'
          '|---:|---:|---:|---:|---:|---:|---:|')


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument('--spheres', default='100,1000,10000,100000')
    parser.add_argument('--per-sphere', default='100,1000,2500')
    parser.add_argument('--out', default='results/node/startup.md')
    parser.add_argument('--repeats', type=int, default=3,
                        help='node processes per row (medians; discovery varies by seconds)')
    args = parser.parse_args()
    command = ' '.join(['.venv/bin/python -m benchmarks.startup', *(
        f'--{key.replace("_", "-")} {shlex.quote(str(value))}'
        for key, value in vars(args).items()
        if value != parser.get_default(key))])
    lines = [provenance(command), '', __doc__.split('\n\n', 2)[2].strip(), '']
    with tempfile.TemporaryDirectory() as folder:
        for flag, counts in ((False, args.spheres), (True, args.per_sphere)):
            if not counts:
                continue
            title = f'per_sphere_topics: {"true" if flag else "false"}'
            print(f'\n{title}\n{HEADER}', flush=True)
            lines += [f'### {title}', '', HEADER]
            lines += table([int(n) for n in counts.split(',')], flag, folder, args.repeats)
            lines.append('')
    Path(args.out).parent.mkdir(parents=True, exist_ok=True)
    Path(args.out).write_text('\n'.join(lines) + '\n')


if __name__ == '__main__':
    main()
