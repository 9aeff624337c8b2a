"""The node started as a user starts it: achieved real-time factor, publish rate and CPU.

    .venv/bin/python -m benchmarks.node_rate [--seconds 10] [--spheres 3,100,1000,5000,10000]
        [--collisions] [--contact-solver soft_step] [--no-per-sphere-topics]

Table 1: the default pool at real_time_factor 1, 10 and 0. Table 2: N spheres from a
params file (physics 200 Hz, publishing 30 Hz, real_time_factor 1), with where the node's
wall time went (its own counters, logged when it stops). One node process per row; a client
in this process counts ~/poses and reads their stamps. Achieved RTF = simulated seconds
(from the stamps) / wall seconds.
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

from benchmarks.common import cpu_seconds, scattered_spheres
from geometry_msgs.msg import PoseArray
from nav_msgs.msg import Odometry
import rclpy
from rclpy.context import Context
from rclpy.executors import SingleThreadedExecutor

WARM_UP_S = 2.0
STARTUP_LIMIT_S = 900.0  # a row whose node sends no pose by then is reported as such
# A DDS domain of its own: other participants on the machine must not share its traffic.
DOMAIN_ID = 100 + os.getpid() % 100


def spheres_params_file(count, path, collisions=False, contact_solver=None,
                        per_sphere_topics=True):
    """A params file with `count` spheres scattered through the pool's air and water;
    collisions: the default effects and `collisions`, resolved by contact_solver (None:
    the default); per_sphere_topics: the node key."""
    lines = ['/**:', '  ros__parameters:',
             f'    sphere_names: [{", ".join(f"s{i}" for i in range(count))}]']
    if collisions:
        lines.append('    effects: [gravity, buoyancy, drag, wave_radiation, contact, friction, '
                     'collisions]')
    if contact_solver:
        lines.append(f'    contact_solver: {contact_solver}')
    if not per_sphere_topics:
        lines.append('    per_sphere_topics: false')
    for i, ((x, y, z), radius, mass) in enumerate(zip(*scattered_spheres(count))):
        lines.append(f'    s{i}: {{mass: {mass:.6f}, radius: {radius:.4f}, '
                     f'position: [{x:.3f}, {y:.3f}, {z:.3f}]}}')
    path.write_text('\n'.join(lines) + '\n')
    return path


class NoPoses(Exception):
    """The node sent no pose within STARTUP_LIMIT_S."""


def measure(real_time_factor, seconds, params_file=None, odometry_of=0):
    """odometry_of: subscribe to the odometry of spheres s0 .. s(odometry_of - 1) too."""
    namespace = f'/bench{os.getpid()}_{str(real_time_factor).replace(".", "_")}'
    extra = ['--params-file', str(params_file)] if params_file else []
    launched = time.monotonic()
    node = subprocess.Popen(
        [sys.executable, '-m', 'pool_sim.ros.simulator_node', '--ros-args',
         '-p', f'real_time_factor:={real_time_factor}', '-r', f'__ns:={namespace}', *extra],
        stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True,
        env={**os.environ, 'ROS_DOMAIN_ID': str(DOMAIN_ID)})
    context = Context()
    rclpy.init(context=context, domain_id=DOMAIN_ID)
    try:
        client = rclpy.create_node('rate_client', context=context)
        executor = SingleThreadedExecutor(context=context)
        executor.add_node(client)
        stamps, odometry = [], [0]
        for i in range(odometry_of):
            client.create_subscription(
                Odometry, f'{namespace}/pool_sim/s{i}/odom',
                lambda m: odometry.__setitem__(0, odometry[0] + 1), 10)
        client.create_subscription(
            PoseArray, f'{namespace}/pool_sim/poses',
            lambda m: stamps.append((time.monotonic(), m.header.stamp.sec
                                     + 1e-9 * m.header.stamp.nanosec)), 100)
        while not stamps and time.monotonic() - launched < STARTUP_LIMIT_S:
            executor.spin_once(timeout_sec=0.05)  # start-up and discovery
        startup = time.monotonic() - launched
        if not stamps:
            raise NoPoses(startup)
        warm_up_until = time.monotonic() + WARM_UP_S  # first steps load the compiled kernel
        while time.monotonic() < warm_up_until:
            executor.spin_once(timeout_sec=0.05)
        start_wall, start_cpu, start_count = time.monotonic(), cpu_seconds(node.pid), len(stamps)
        start_stamp, start_odometry = stamps[-1][1], odometry[0]
        while time.monotonic() - start_wall < seconds:
            executor.spin_once(timeout_sec=0.05)
        wall = time.monotonic() - start_wall
        cpu = cpu_seconds(node.pid) - start_cpu
        received = len(stamps) - start_count
        odometry_rate = (odometry[0] - start_odometry) / wall
        simulated = stamps[-1][1] - start_stamp
        executor.shutdown()
        client.destroy_node()
    finally:
        rclpy.shutdown(context=context)
        node.send_signal(signal.SIGINT)
        stopping = time.monotonic()
        _, log = node.communicate(timeout=600)  # thousands of DDS endpoints to tear down
        shutdown = time.monotonic() - stopping
    client_rtf = simulated / wall if received else math.nan
    per_simulated = received / simulated if simulated > 0 else math.nan
    return (client_rtf, received / wall, per_simulated, 100.0 * cpu / wall,
            (startup, shutdown), node_own_figures(log, seconds), odometry_rate)


STATUS = re.compile(r'([\d.]+) s simulated in ([\d.]+) s running .*?, (\d+) steps, '
                    r'(\d+) publishes \(\d+ odometry sets left out for slow subscribers\), '
                    r'([\d.]+) s given up to the catch-up bound, \d+ '
                    r'put-backs by the step guard; wall time in (.*)$', re.MULTILINE)


def node_own_figures(log, seconds):
    """(RTF, publishes per wall s, time shares, simulated s given up to the catch-up bound)
    from the node's own status lines (every 5 s, cumulative): the last line against the line
    `seconds` before it. A client can lag behind large messages; the node's simulation clock
    and steady clock cannot."""
    lines = [(float(a), float(b), int(c), int(d), e, float(given_up))
             for a, b, c, d, given_up, e in STATUS.findall(log)]
    if len(lines) < 2:
        return None
    last = lines[-1]
    first = next(line for line in lines if line[1] >= last[1] - seconds - 1.0)
    if first is last:
        first = lines[-2]
    wall = last[1] - first[1]
    # The shares are of the wall time since start, start-up and kernel loading included:
    # take the window's own share of each part from the two lines.
    first_shares, last_shares = shares_of(first[4]), shares_of(last[4])
    window = ', '.join(
        f'{part} {(share * last[1] - first_shares[part] * first[1]) / wall:.1%}'
        for part, share in last_shares.items())
    return (last[0] - first[0]) / wall, (last[3] - first[3]) / wall, window, last[5] - first[5]


def shares_of(text):
    """'physics 3.4%, build 0.2%' -> {'physics': 0.034, 'build': 0.002}"""
    return {name: float(percent) / 100.0
            for name, percent in re.findall(r'(\w+) ([\d.]+)%', text)}


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument('--seconds', type=float, default=10.0,
                        help='measuring window; 10 or more (the node logs every 5 s)')
    parser.add_argument('--spheres', default='3,100,1000,5000,10000')
    parser.add_argument('--skip-default', action='store_true')
    parser.add_argument('--collisions', action='store_true',
                        help='the N-sphere table with `collisions` listed too')
    parser.add_argument('--contact-solver', help='of the N-sphere table (default: the '
                        "scene key's default)")
    parser.add_argument('--no-per-sphere-topics', action='store_true',
                        help='the N-sphere table with per_sphere_topics false')
    parser.add_argument('--odometry', default='1000',
                        help='sphere counts of the table with a subscriber on every odometry '
                             'topic (empty: none)')
    args = parser.parse_args()
    seconds = args.seconds
    if not args.skip_default:
        print(f'default pool (3 spheres, 200 Hz physics, 30 Hz publishing), {seconds:g} s each')
        print('| asked RTF | achieved RTF | poses / wall s | poses / sim s | node CPU % |')
        print('|----------:|-------------:|---------------:|--------------:|-----------:|')
        for real_time_factor in (1.0, 10.0, 0.0):
            rtf, per_wall, per_sim, cpu, _, _, _ = measure(real_time_factor, seconds)
            print(f'| {real_time_factor:9g} | {rtf:12.3f} | {per_wall:14.1f} | '
                  f'{per_sim:13.2f} | {cpu:10.0f} |')
        print()
    colliding = ' colliding (the default effects and collisions)' if args.collisions else ''
    colliding += f', contact_solver {args.contact_solver}' if args.contact_solver else ''
    colliding += ', per-sphere topics off' if args.no_per_sphere_topics else ''
    print(f'N spheres{colliding}, 200 Hz physics, 30 Hz publishing, real_time_factor 1; '
          f'RTF, publish rate and where the wall time went from the node\'s own clocks over '
          f'the last {seconds:g} s it ran; the client column is what one Python subscriber received')
    print('| spheres | start-up / shutdown s | achieved RTF | publishes / wall s | node CPU % | '
          'node wall time in | client: poses / wall s |')
    print('|---:|---:|---:|---:|---:|---|---:|')
    with tempfile.TemporaryDirectory() as folder:
        for count in (int(n) for n in args.spheres.split(',') if n):
            params = spheres_params_file(count, Path(folder) / f'spheres{count}.yaml',
                                         args.collisions, args.contact_solver,
                                         not args.no_per_sphere_topics)
            try:
                _, client_rate, _, cpu, (startup, shutdown), own, _ = measure(1.0, seconds, params)
            except NoPoses as waited:
                print(f'| {count:,} | no pose within {waited.args[0]:.0f} s | | | | | |',
                      flush=True)
                continue
            if own is None:  # status lines come every 5 s: a short or stalled run has < 2
                print(f'| {count:,} | {startup:.0f} / {shutdown:.0f} | no status lines to '
                      f'measure from | | {cpu:.0f} | | {client_rate:.1f} |', flush=True)
                continue
            rtf, publishes, shares, _ = own
            print(f'| {count:,} | {startup:.0f} / {shutdown:.0f} | {rtf:.3f} | {publishes:.1f} | '
                  f'{cpu:.0f} | {shares} | {client_rate:.1f} |', flush=True)
    if args.odometry:
        odometry_table([int(n) for n in args.odometry.split(',')], seconds)


def odometry_table(counts, seconds):
    print(f'\nN spheres with per-sphere topics, this process subscribed to every one of their '
          f'odometry topics (and the poses); the node\'s own RTF over the last {seconds:g} s')
    print('| spheres | achieved RTF | s given up to the catch-up bound | node CPU % | '
          'node wall time in | client: odometry messages / wall s |')
    print('|---:|---:|---:|---:|---|---:|')
    with tempfile.TemporaryDirectory() as folder:
        for count in counts:
            params = spheres_params_file(count, Path(folder) / f'spheres{count}.yaml')
            _, _, _, cpu, _, own, odometry_rate = measure(1.0, seconds, params, count)
            if own is None:
                print(f'| {count:,} | no status lines | | {cpu:.0f} | | {odometry_rate:.0f} |')
                continue
            rtf, _, shares, given_up = own
            print(f'| {count:,} | {rtf:.3f} | {given_up:.2f} | {cpu:.0f} | {shares} | '
                  f'{odometry_rate:.0f} |', flush=True)


if __name__ == '__main__':
    main()
