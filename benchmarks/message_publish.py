"""What one sphere's Odometry costs the node per publish, before and after, and the states.

    .venv/bin/python -m benchmarks.message_publish [--spheres 1000]

A real rclpy publisher in a private Context with one subscriber in this process (matched
before timing, never spun: its reader still takes every message, so publish is not free).
Before: refill one Python nav_msgs/Odometry per sphere field by field and publish it (rclpy
converts it). After: SphereMessages patches every sphere's serialized Odometry in one numpy
operation and publishes its bytes. Each case runs once per sphere for all n spheres, as one
publish of the node does; us per message = median seconds of that / n. Also the cost of
building all n Odometry (start-up) and of patching and taking the states message, and the
start-up and per-publish cost of the PoseArray, MarkerArray and states at 1e3 to 1e5 spheres.
"""
import argparse
import os
import time

import numpy as np
import rclpy
from rclpy.context import Context
from nav_msgs.msg import Odometry
from std_msgs.msg import Float64MultiArray

from benchmarks.common import timed
from pool_sim.ros.messages import (odometry_messages, sphere_odometry, SphereMessages,
                                   stamp_of)

MATCH_TIMEOUT_S = 10.0
ARRAY_SPHERE_COUNTS = (1_000, 10_000, 100_000)


def old_fill(odometry, stamp, position, velocity, wanted):
    """The per-sphere refill SphereMessages did before its Odometry was serialized."""
    for i in wanted:
        message = odometry[i]
        message.header.stamp = stamp
        point, linear = message.pose.pose.position, message.twist.twist.linear
        point.x, point.y, point.z = (float(v) for v in position[:, i])
        linear.x, linear.y, linear.z = (float(v) for v in velocity[:, i])


def matched_publisher(node, message_type, topic):
    """A publisher of topic with one subscriber of the same node, once they have matched."""
    publisher = node.create_publisher(message_type, topic, 10)
    node.create_subscription(message_type, topic, lambda message: None, 10)
    deadline = time.monotonic() + MATCH_TIMEOUT_S
    while publisher.get_subscription_count() < 1:
        if time.monotonic() > deadline:
            raise RuntimeError(f'no subscriber matched {topic}')
        time.sleep(0.01)
    return publisher


def array_costs_ms(count):
    """(build, fill) ms of the PoseArray, MarkerArray and states of `count` spheres: building
    SphereMessages without Odometry (start-up), then one fill (each publish)."""
    rng = np.random.default_rng(0)
    names = [f's{i}' for i in range(count)]
    position, velocity = rng.normal(size=(3, count)), rng.normal(size=(3, count))
    radius = rng.uniform(0.01, 0.3, count)
    build_s = timed(lambda: SphereMessages(names, 'world', odometry=False), budget_s=0.5,
                    repeats=3)
    messages = SphereMessages(names, 'world', odometry=False)
    fill_s = timed(lambda: messages.fill(12.5, position, velocity, radius), budget_s=0.3,
                   repeats=5)
    return build_s * 1e3, fill_s * 1e3


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument('--spheres', type=int, default=1000)
    count = parser.parse_args().spheres
    rng = np.random.default_rng(0)
    names = [f's{i}' for i in range(count)]
    position, velocity = rng.normal(size=(3, count)), rng.normal(size=(3, count))
    wanted = list(range(count))
    stamp = stamp_of(12.5)

    # Its one topic pair stays on this machine (read when DDS starts, in rclpy.init).
    os.environ.setdefault('ROS_AUTOMATIC_DISCOVERY_RANGE', 'LOCALHOST')
    context = Context()
    rclpy.init(context=context)
    try:
        node = rclpy.create_node('message_publish_benchmark', context=context)
        odometry_publisher = matched_publisher(node, Odometry, 'odom')
        states_publisher = matched_publisher(node, Float64MultiArray, 'states')
        old_odometry = [sphere_odometry(name, 'world') for name in names]
        messages = SphereMessages(names, 'world')
        odometry = messages.odometry

        def new_patch():
            wanted_index = np.asarray(wanted, np.intp)  # as fill converts the node's list
            odometry.patch(wanted_index, stamp.sec, stamp.nanosec,
                           np.concatenate((position[:, wanted_index],
                                           velocity[:, wanted_index])).T)

        def old_publish():
            for i in wanted:
                odometry_publisher.publish(old_odometry[i])

        def new_publish():
            for i in wanted:
                odometry_publisher.publish(messages.odometry_bytes(i))

        def new_bytes():
            for i in wanted:
                messages.odometry_bytes(i)

        def states_patch():
            messages.states.block[...] = np.concatenate((position, velocity)).T
        per_message = {
            'before: refill Python Odometry': lambda: old_fill(
                old_odometry, stamp, position, velocity, wanted),
            'before: publish(Odometry)': old_publish,
            'after: patch all wanted (vectorised)': new_patch,
            'after: odometry_bytes(i)': new_bytes,
            'after: publish(odometry_bytes(i))': new_publish,
        }
        us = {name: timed(case, budget_s=0.8, repeats=5) / count * 1e6
              for name, case in per_message.items()}
        before = us['before: refill Python Odometry'] + us['before: publish(Odometry)']
        after = us['after: patch all wanted (vectorised)'] + us[
            'after: publish(odometry_bytes(i))']
        build_all_ms = {
            n: timed(lambda: odometry_messages([f's{i}' for i in range(n)], 'world'),
                     budget_s=0.5, repeats=3) * 1e3
            for n in (1_000, 10_000)}
        states_us = timed(states_patch, budget_s=0.3, repeats=5) * 1e6
        states_publish_us = timed(lambda: states_publisher.publish(messages.states_bytes()),
                                  budget_s=0.3, repeats=5) * 1e6
    finally:
        rclpy.shutdown(context=context)

    print(f'Odometry at {count:,} spheres, us per message (median of 5, '
          f'one publisher, one subscriber):')
    print('| step | us per message |')
    print('|---|---:|')
    for name, value in us.items():
        print(f'| {name} | {value:.2f} |')
    print(f'| **before total** | **{before:.2f}** |')
    print(f'| **after total** (patch + publish bytes) | **{after:.2f}** |')
    print(f'\nspeed-up {before / after:.1f}x; at 30 Hz the node spends '
          f'{before * count * 30 / 1e4:.1f} % of a core before, '
          f'{after * count * 30 / 1e4:.1f} % after.')
    print('\n| other | cost |')
    print('|---|---:|')
    for n, ms in build_all_ms.items():
        print(f'| build all {n:,} Odometry (start-up) | {ms:.1f} ms |')
    print(f'| patch states ({count:,} × 6 doubles) | {states_us:.1f} us |')
    print(f'| publish(states_bytes()) | {states_publish_us:.1f} us |')
    print('\nPoseArray + MarkerArray + states, ms (median of 3 builds, 5 fills):')
    print('| spheres | build (start-up) | fill (each publish) |')
    print('|---:|---:|---:|')
    for array_count in ARRAY_SPHERE_COUNTS:
        build_ms, fill_ms = array_costs_ms(array_count)
        print(f'| {array_count:,} | {build_ms:.1f} | {fill_ms:.2f} |')


if __name__ == '__main__':
    main()
