"""Patched messages read back as exactly the messages rclpy would build for the same values.

(Not byte for byte: the serializer leaves CDR padding bytes uninitialised.)"""
import numpy as np
import pytest
from rclpy.serialization import deserialize_message, serialize_message
from geometry_msgs.msg import PoseArray
from visualization_msgs.msg import MarkerArray

from pool_sim.ros.messages import pose_array, sphere_markers, SphereMessages, stamp_of


def round_trip(message):
    """What a subscriber receives of `message`: float32 fields (colours) come back rounded."""
    return deserialize_message(serialize_message(message), type(message))


@pytest.mark.parametrize('count', [1, 2, 7, 300])
def test_patched_pose_and_marker_arrays_read_back_as_the_expected_messages(count):
    rng = np.random.default_rng(count)
    messages = SphereMessages([f's{i}' for i in range(count)], 'pool_frame')
    for time_s in (0.0, 12.345678901, 1e5 + 0.5):
        position, velocity = rng.normal(size=(3, count)), rng.normal(size=(3, count))
        radius = rng.uniform(0.01, 1.0, count)
        messages.fill(time_s, position, velocity, radius)
        stamp = stamp_of(time_s)
        expected_poses = pose_array(count, 'pool_frame')
        expected_poses.header.stamp = stamp
        expected_markers = sphere_markers(count, 'pool_frame')
        for i in range(count):
            point = expected_poses.poses[i].position
            point.x, point.y, point.z = position[:, i].tolist()
            marker = expected_markers.markers[i]
            marker.header.stamp = stamp
            marker.pose.position.x, marker.pose.position.y, marker.pose.position.z = \
                position[:, i].tolist()
            marker.scale.x = marker.scale.y = marker.scale.z = 2.0 * float(radius[i])
        assert deserialize_message(messages.poses.to_bytes(), PoseArray) == round_trip(
            expected_poses)
        assert deserialize_message(messages.markers.to_bytes(), MarkerArray) == round_trip(
            expected_markers)
        # Same layout as rclpy's own: the same length.
        assert len(messages.markers.to_bytes()) == len(serialize_message(expected_markers))


def test_a_patched_marker_array_reads_back_as_markers():
    messages = SphereMessages(['a', 'b'], 'world')
    messages.fill(3.5, np.array([[1.0, 2.0], [3.0, 4.0], [5.0, 6.0]]), np.zeros((3, 2)),
                  np.array([0.1, 0.25]))
    markers = deserialize_message(messages.markers.to_bytes(), MarkerArray).markers
    assert [m.id for m in markers] == [0, 1]
    assert [m.scale.x for m in markers] == [0.2, 0.5]
    assert (markers[1].pose.position.x, markers[1].header.stamp.sec,
            markers[1].header.stamp.nanosec) == (2.0, 3, 500_000_000)
