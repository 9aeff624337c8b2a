"""The node started as a user starts it: achieved publish rate, real-time factor and CPU.

    .venv/bin/python -m benchmarks.node_rate [--seconds 10]

For each real_time_factor asked for, one node process runs the default pool; a client in
this process counts ~/poses and reads their stamps. Achieved RTF = simulated seconds (from
the stamps) / wall seconds; publish rate is per wall second and per simulated second.
"""
import argparse
import os
import signal
import subprocess
import sys
import time

from geometry_msgs.msg import PoseArray
import rclpy
from rclpy.context import Context
from rclpy.executors import SingleThreadedExecutor

CLOCK_TICKS = os.sysconf('SC_CLK_TCK')


def cpu_seconds(pid):
    with open(f'/proc/{pid}/stat') as stat:
        fields = stat.read().rsplit(')', 1)[1].split()
    return (int(fields[11]) + int(fields[12])) / CLOCK_TICKS


def measure(real_time_factor, seconds):
    namespace = f'/bench{os.getpid()}_{str(real_time_factor).replace(".", "_")}'
    node = subprocess.Popen(
        [sys.executable, '-m', 'pool_sim.ros.simulator_node', '--ros-args',
         '-p', f'real_time_factor:={real_time_factor}', '-r', f'__ns:={namespace}'],
        stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    context = Context()
    rclpy.init(context=context)
    try:
        client = rclpy.create_node('rate_client', context=context)
        executor = SingleThreadedExecutor(context=context)
        executor.add_node(client)
        stamps = []
        client.create_subscription(
            PoseArray, f'{namespace}/pool_sim/poses',
            lambda m: stamps.append((time.monotonic(), m.header.stamp.sec
                                     + 1e-9 * m.header.stamp.nanosec)), 100)
        while not stamps:  # discovery, then start measuring
            executor.spin_once(timeout_sec=0.05)
        start_wall, start_cpu, start_count = time.monotonic(), cpu_seconds(node.pid), len(stamps)
        start_stamp = stamps[-1][1]
        while time.monotonic() - start_wall < seconds:
            executor.spin_once(timeout_sec=0.05)
        wall = time.monotonic() - start_wall
        cpu = cpu_seconds(node.pid) - start_cpu
        received = len(stamps) - start_count
        simulated = stamps[-1][1] - start_stamp
        executor.shutdown()
        client.destroy_node()
    finally:
        rclpy.shutdown(context=context)
        node.send_signal(signal.SIGINT)
        node.wait(timeout=20)
    return simulated / wall, received / wall, received / simulated, 100.0 * cpu / wall


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument('--seconds', type=float, default=10.0)
    seconds = parser.parse_args().seconds
    print(f'default pool (3 spheres, 200 Hz physics, 30 Hz publishing), {seconds:g} s each')
    print('| asked RTF | achieved RTF | poses / wall s | poses / sim s | node CPU % |')
    print('|----------:|-------------:|---------------:|--------------:|-----------:|')
    for real_time_factor in (1.0, 10.0, 0.0):
        rtf, per_wall, per_sim, cpu = measure(real_time_factor, seconds)
        print(f'| {real_time_factor:9g} | {rtf:12.3f} | {per_wall:14.1f} | {per_sim:13.2f} '
              f'| {cpu:10.0f} |')


if __name__ == '__main__':
    main()
