"""Under load: 4 publisher nodes send wrenches at 1 kHz each to 4 spheres, one in ten NaN.

    .venv/bin/python -m benchmarks.flood [--seconds 10]

The node runs as a user starts it (its own process, real_time_factor 1). Each publisher is
a process of its own, paced to 1 kHz. Reported: messages sent, achieved real-time factor
(pose stamps over wall time), whether any published position was not finite, and the
node's resident memory each second (flat means no queue or leak grows).
"""
import argparse
import math
import os
from pathlib import Path
import re
import signal
import subprocess
import sys
import tempfile
import time

from benchmarks.common import cpu_seconds
from benchmarks.node_rate import node_own_figures
from geometry_msgs.msg import PoseArray, Wrench
import rclpy
from rclpy.context import Context
from rclpy.executors import SingleThreadedExecutor

SPHERES = ('a', 'b', 'c', 'd')
RATE_HZ = 1000.0


def params_file(path):
    lines = ['/**:', '  ros__parameters:', f'    sphere_names: [{", ".join(SPHERES)}]',
             '    real_time_factor: 1.0']
    for i, name in enumerate(SPHERES):
        lines.append(f'    {name}: {{mass: 2.0, radius: 0.1, position: [{i - 1.5}, 0.0, -1.0]}}')
    path.write_text('\n'.join(lines) + '\n')
    return path


def publish(namespace, sphere, seconds, index):
    """One publisher node: a wrench every millisecond, every tenth one NaN."""
    context = Context()
    rclpy.init(context=context)
    node = rclpy.create_node(f'flood_{index}', context=context)
    publisher = node.create_publisher(Wrench, f'{namespace}/pool_sim/{sphere}/wrench', 10)
    time.sleep(1.0)  # discovery
    message, sent = Wrench(), 0
    start = time.monotonic()
    while time.monotonic() - start < seconds:
        sent += 1
        message.force.x = math.nan if sent % 10 == 0 else 3.0 * math.sin(sent / 100.0)
        publisher.publish(message)
        next_time = start + sent / RATE_HZ
        delay = next_time - time.monotonic()
        if delay > 0:
            time.sleep(delay)
    print(sent, flush=True)
    node.destroy_node()
    rclpy.shutdown(context=context)


def resident_megabytes(pid):
    with open(f'/proc/{pid}/status') as status:
        return int(re.search(r'VmRSS:\s+(\d+)', status.read()).group(1)) / 1024.0


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument('--seconds', type=float, default=10.0)
    parser.add_argument('--publisher', nargs=3, metavar=('NAMESPACE', 'SPHERE', 'INDEX'))
    args = parser.parse_args()
    if args.publisher:
        publish(args.publisher[0], args.publisher[1], args.seconds, int(args.publisher[2]))
        return
    namespace = f'/flood{os.getpid()}'
    with tempfile.TemporaryDirectory() as folder:
        launched = time.monotonic()
        node = subprocess.Popen(
            [sys.executable, '-m', 'pool_sim.ros.simulator_node', '--ros-args',
             '--params-file', str(params_file(Path(folder) / 'flood.yaml')),
             '-r', f'__ns:={namespace}'], stdout=subprocess.DEVNULL, stderr=subprocess.PIPE,
            text=True)
        context = Context()
        rclpy.init(context=context)
        client = rclpy.create_node('flood_client', context=context)
        executor = SingleThreadedExecutor(context=context)
        executor.add_node(client)
        poses = []
        client.create_subscription(PoseArray, f'{namespace}/pool_sim/poses',
                                   lambda m: poses.append((time.monotonic(), m)), 100)
        while not poses:
            executor.spin_once(timeout_sec=0.05)
        warm_up = time.monotonic() + 2.0
        while time.monotonic() < warm_up:
            executor.spin_once(timeout_sec=0.05)
        publishers = [subprocess.Popen(
            [sys.executable, '-m', 'benchmarks.flood', '--seconds', str(args.seconds),
             '--publisher', namespace, sphere, str(i)], stdout=subprocess.PIPE, text=True)
            for i, sphere in enumerate(SPHERES)]
        first = len(poses)
        memory = []
        start = time.monotonic()
        next_sample = start
        while time.monotonic() - start < args.seconds + 1.0:
            executor.spin_once(timeout_sec=0.01)
            if time.monotonic() >= next_sample:
                memory.append(resident_megabytes(node.pid))
                next_sample += 1.0
        wall = time.monotonic() - start
        window = poses[first:]
        publisher_cpu = sum(cpu_seconds(p.pid) for p in publishers) / wall
        sent = sum(int(p.communicate(timeout=30)[0].split()[-1]) for p in publishers)
        executor.shutdown()
        client.destroy_node()
        rclpy.shutdown(context=context)
        node_cpu = cpu_seconds(node.pid) / (time.monotonic() - launched)
        node.send_signal(signal.SIGINT)
        _, log = node.communicate(timeout=30)
    stamp = lambda m: m.header.stamp.sec + 1e-9 * m.header.stamp.nanosec  # noqa: E731
    simulated = stamp(window[-1][1]) - stamp(window[0][1])
    elapsed = window[-1][0] - window[0][0]
    finite = all(math.isfinite(v) for _, m in window for p in m.poses
                 for v in (p.position.x, p.position.y, p.position.z))
    # inputs.py's throttled warning, one a sphere per THROTTLE_S at most
    refused = sum('/wrench: refused:' in line and 'must be finite' in line
                  for line in log.splitlines())
    print(f'{len(SPHERES)} publishers x {RATE_HZ:g} Hz for {args.seconds:g} s, one message in '
          'ten NaN, node at real_time_factor 1')
    own = node_own_figures(log, args.seconds)
    print('| messages sent | RTF, node clocks | simulated s given up to the catch-up bound | '
          'RTF, client stamps | all positions finite | '
          'NaN warnings logged (throttled) | node RSS first / last / max, MB | CPU: node / '
          '4 publishers, cores | node wall time in |')
    print('|---:|---:|---:|---:|---|---:|---|---|---|')
    print(f'| {sent:,} | {own[0]:.3f} | {own[3]:.2f} | {simulated / elapsed:.3f} | {finite} | '
          f'{refused} | '
          f'{memory[0]:.1f} / {memory[-1]:.1f} / {max(memory):.1f} | {node_cpu:.2f} / '
          f'{publisher_cpu:.2f} | {own[2]} |')
    print()
    print('node RSS each second, MB: ' + ', '.join(f'{m:.1f}' for m in memory))


if __name__ == '__main__':
    main()
