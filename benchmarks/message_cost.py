"""What one PoseArray / MarkerArray costs to build and hand to rclpy, before and after.

    .venv/bin/python -m benchmarks.message_cost

Before: fill a Python message field by field, then rclpy converts it to C (done here with
serialize_message, the same conversion publish() runs). After: patch the numbers into a
message serialized once (pool_sim/ros/serialized.py) and take its bytes, which publish()
sends as they are. Median of repeats, all in one run.
"""
import numpy as np
from rclpy.serialization import serialize_message

from benchmarks.common import timed
from pool_sim.ros.messages import pose_array, sphere_markers, SphereMessages


def fill_poses(poses, position):
    xs, ys, zs = position.tolist()
    for i, pose in enumerate(poses.poses):
        point = pose.position
        point.x, point.y, point.z = xs[i], ys[i], zs[i]


def fill_markers(markers, position, radius):
    xs, ys, zs = position.tolist()
    diameters = (2.0 * radius).tolist()
    for i, marker in enumerate(markers.markers):
        point = marker.pose.position
        point.x, point.y, point.z = xs[i], ys[i], zs[i]
        marker.scale.x = marker.scale.y = marker.scale.z = diameters[i]


def main():
    print('ms per message (median of 5):')
    print('| spheres | PoseArray before | PoseArray after | MarkerArray before | '
          'MarkerArray after | speed-up |')
    print('|---:|---:|---:|---:|---:|---:|')
    for count in (100, 1_000, 5_000, 10_000):
        rng = np.random.default_rng(0)
        position, radius = rng.normal(size=(3, count)), rng.uniform(0.01, 0.3, count)
        poses, markers = pose_array(count, 'world'), sphere_markers(count, 'world')
        patched = SphereMessages([f's{i}' for i in range(count)], 'world')
        diameter = 2.0 * radius
        x, y, z = position
        cases = {
            'poses before': lambda: (fill_poses(poses, position), serialize_message(poses)),
            'poses after': lambda: (patched.poses.patch(1, 0, x=x, y=y, z=z),
                                    patched.poses.to_bytes()),
            'markers before': lambda: (fill_markers(markers, position, radius),
                                       serialize_message(markers)),
            'markers after': lambda: (patched.markers.patch(
                1, 0, x=x, y=y, z=z, scale_x=diameter, scale_y=diameter, scale_z=diameter),
                patched.markers.to_bytes()),
        }
        ms = {name: timed(case, budget_s=1.0, repeats=5) * 1e3 for name, case in cases.items()}
        speedup = (ms['poses before'] + ms['markers before']) / (
            ms['poses after'] + ms['markers after'])
        print(f'| {count:,} | {ms["poses before"]:.2f} | {ms["poses after"]:.3f} | '
              f'{ms["markers before"]:.2f} | {ms["markers after"]:.3f} | {speedup:.0f}x |')


if __name__ == '__main__':
    main()
