"""Patched messages read back as exactly the messages rclpy would build for the same values.

(Not byte for byte: the serializer leaves CDR padding bytes uninitialised.)"""
import array

from hypothesis import given, settings, strategies as st
from hypothesis.extra.numpy import arrays
import numpy as np
import pytest
from rclpy.serialization import deserialize_message, serialize_message
from geometry_msgs.msg import PoseArray
from nav_msgs.msg import Odometry
from std_msgs.msg import Float64MultiArray
from visualization_msgs.msg import MarkerArray

from pool_sim.ros import messages as messages_module, serialized
from pool_sim.ros.messages import (LAST_STAMP_S, odometry_messages, pose_array,
                                   sphere_colour, sphere_colours, sphere_markers,
                                   sphere_odometry, sphere_states, SphereMessages, stamp_of)


def round_trip(message):
    """What a subscriber receives of `message`: float32 fields (colours) come back rounded."""
    return deserialize_message(serialize_message(message), type(message))


def differences(received, expected, path='message'):
    """Paths of the fields (every one, nested, each element of each sequence) that differ."""
    if hasattr(type(expected), 'get_fields_and_field_types'):
        if type(received) is not type(expected):
            return [f'{path}: {type(received).__name__} != {type(expected).__name__}']
        return [difference for field in type(expected).get_fields_and_field_types()
                for difference in differences(getattr(received, field),
                                              getattr(expected, field), f'{path}.{field}')]
    if isinstance(expected, (list, tuple, array.array, np.ndarray)):
        if len(received) != len(expected):
            return [f'{path}: {len(received)} elements != {len(expected)}']
        return [difference for i, (got, wanted) in enumerate(zip(received, expected))
                for difference in differences(got, wanted, f'{path}[{i}]')]
    return [] if received == expected else [f'{path}: {received!r} != {expected!r}']


def assert_reads_back_as(data, expected):
    """`data` deserializes to `expected` as a subscriber receives it, field by field, and
    has the length rclpy's own serialization of it has."""
    received = deserialize_message(data, type(expected))
    assert differences(received, round_trip(expected)) == []
    assert received == round_trip(expected)
    assert len(data) == len(serialize_message(expected))


def random_frame_id(length, seed):
    return ''.join(np.random.default_rng(seed).choice(list('abcXYZ019_/'), length))


# Every length 0..9 puts what follows header.frame_id at each alignment; 'é' is 2 bytes.
FRAME_IDS = (['', 'é', 'pool_frame'] + [random_frame_id(length, length)
                                        for length in (1, 2, 3, 4, 5, 6, 7, 8, 9, 23)])


@pytest.mark.parametrize('count, frame_id', [
    (count, frame_id) for count in (0, 1, 2, 3, 17) for frame_id in FRAME_IDS]
    + [(257, frame_id) for frame_id in FRAME_IDS[:4]])
def test_pose_marker_and_state_arrays_read_back_as_the_python_messages(count, frame_id):
    """Assembled from a few elements' serialization, each reads back as the message built
    element by element in Python (pose_array, sphere_markers, sphere_states): before any
    fill, and after each fill with the values filled in."""
    rng = np.random.default_rng(count)
    messages = SphereMessages([f's{i}' for i in range(count)], frame_id, odometry=False)
    assert_reads_back_as(messages.poses.to_bytes(), pose_array(count, frame_id))
    assert_reads_back_as(messages.markers.to_bytes(), sphere_markers(count, frame_id))
    assert_reads_back_as(messages.states_bytes(), sphere_states(count))
    for time_s in (0.0, 12.345678901, 1e5 + 0.5):
        position, velocity = rng.normal(size=(3, count)), rng.normal(size=(3, count))
        radius = rng.uniform(0.01, 1.0, count)
        messages.fill(time_s, position, velocity, radius)
        stamp = stamp_of(time_s)
        expected_poses = pose_array(count, frame_id)
        expected_poses.header.stamp = stamp
        expected_markers = sphere_markers(count, frame_id)
        for i in range(count):
            point = expected_poses.poses[i].position
            point.x, point.y, point.z = position[:, i].tolist()
            marker = expected_markers.markers[i]
            marker.header.stamp = stamp
            marker.pose.position.x, marker.pose.position.y, marker.pose.position.z = \
                position[:, i].tolist()
            marker.scale.x = marker.scale.y = marker.scale.z = 2.0 * float(radius[i])
        assert_reads_back_as(messages.poses.to_bytes(), expected_poses)
        assert_reads_back_as(messages.markers.to_bytes(), expected_markers)
        assert_reads_back_as(messages.states_bytes(), expected_states(position, velocity))


@pytest.mark.parametrize('count', [1, 2, 6, 7, 12, 1000])
def test_sphere_colours_are_sphere_colour_of_every_index_exactly(count):
    expected = [sphere_colour(i, count) for i in range(count)]
    assert sphere_colours(count).tolist() == [[c.r, c.g, c.b, c.a] for c in expected]


def test_arrays_are_serialized_with_at_most_3_elements_whatever_the_count(monkeypatch):
    """Building costs O(n) numpy, not rclpy's conversion of n Python elements."""
    serialized_sizes = []

    def counted(message):
        elements = {PoseArray: 'poses', MarkerArray: 'markers', Float64MultiArray: 'data'}
        serialized_sizes.append((type(message), len(getattr(message, elements[type(message)]))))
        return serialize_message(message)
    monkeypatch.setattr(serialized, 'serialize_message', counted)
    for count in (10, 1000):
        serialized_sizes.clear()
        messages = SphereMessages([f's{i}' for i in range(count)], 'world', odometry=False)
        assert len(deserialize_message(messages.markers.to_bytes(), MarkerArray).markers) == \
            count
        assert sorted(serialized_sizes, key=str) == sorted(
            [(message_type, elements) for message_type in (PoseArray, MarkerArray)
             for elements in (0, 1, 2, 3, 3)]
            + [(Float64MultiArray, doubles) for doubles in (0, 1, 2, 3, 3)], key=str)


def test_a_patched_marker_array_reads_back_as_markers():
    messages = SphereMessages(['a', 'b'], 'world')
    messages.fill(3.5, np.array([[1.0, 2.0], [3.0, 4.0], [5.0, 6.0]]), np.zeros((3, 2)),
                  np.array([0.1, 0.25]))
    markers = deserialize_message(messages.markers.to_bytes(), MarkerArray).markers
    assert [m.id for m in markers] == [0, 1]
    assert [m.scale.x for m in markers] == [0.2, 0.5]
    assert (markers[1].pose.position.x, markers[1].header.stamp.sec,
            markers[1].header.stamp.nanosec) == (2.0, 3, 500_000_000)


# Odometry and the states message: every sphere's bytes read back as the message rclpy would
# build from the last values it was patched with.

NAME_CHARACTERS = 'abcXYZ019_é'  # é: two bytes in UTF-8, so byte and character lengths differ


def expected_odometry(name, frame_id, time_s, position, velocity):
    odometry = sphere_odometry(name, frame_id)
    odometry.header.stamp = stamp_of(time_s)
    point, linear = odometry.pose.pose.position, odometry.twist.twist.linear
    point.x, point.y, point.z = (float(v) for v in position)
    linear.x, linear.y, linear.z = (float(v) for v in velocity)
    return round_trip(odometry)


def expected_states(position, velocity):
    count = position.shape[1]
    states = sphere_states(count)
    states.data = array.array('d', np.concatenate((position, velocity)).T.ravel().tolist())
    return states


class LastPatched:
    """What each sphere's Odometry should hold: the values of the last fill that wanted it
    (zeros and stamp 0 before any)."""

    def __init__(self, names, frame_id):
        self.names, self.frame_id = names, frame_id
        count = len(names)
        self.time_s = np.zeros(count)
        self.position, self.velocity = np.zeros((3, count)), np.zeros((3, count))

    def fill(self, messages, time_s, position, velocity, wanted):
        messages.fill(time_s, position, velocity, np.full(len(self.names), 0.1), wanted)
        self.time_s[wanted] = time_s
        self.position[:, wanted], self.velocity[:, wanted] = (position[:, wanted],
                                                               velocity[:, wanted])

    def check(self, messages, position, velocity):
        for i, name in enumerate(self.names):
            data = messages.odometry_bytes(i)
            expected = expected_odometry(name, self.frame_id, self.time_s[i],
                                         self.position[:, i], self.velocity[:, i])
            assert deserialize_message(data, Odometry) == expected, (i, name)
            assert messages.odometry[i] == data
            # The same layout as rclpy's own: the same length.
            assert len(data) == len(serialize_message(expected))
        assert deserialize_message(messages.states_bytes(), Float64MultiArray) == \
            expected_states(position, velocity)


finite = st.floats(allow_nan=False, allow_infinity=False)


@st.composite
def fills(draw, count):
    """(time_s, position (3, n), velocity (3, n), wanted indices) of one fill."""
    time_s = draw(st.floats(0.0, float(LAST_STAMP_S)))
    position = draw(arrays(np.float64, (3, count), elements=finite))
    velocity = draw(arrays(np.float64, (3, count), elements=finite))
    wanted = [i for i, on in enumerate(draw(st.lists(st.booleans(), min_size=count,
                                                     max_size=count))) if on]
    return time_s, position, velocity, wanted


@st.composite
def names_and_fills(draw):
    names = draw(st.lists(st.text(NAME_CHARACTERS, min_size=1, max_size=64), min_size=1,
                          max_size=12, unique=True))
    frame_id = draw(st.text(NAME_CHARACTERS, min_size=1, max_size=20))
    return names, frame_id, draw(st.lists(fills(len(names)), min_size=1, max_size=3))


@settings(deadline=None)
@given(names_and_fills())
def test_patched_odometry_and_states_read_back_as_the_last_values_patched(case):
    names, frame_id, all_fills = case
    messages = SphereMessages(names, frame_id)
    last = LastPatched(names, frame_id)
    for time_s, position, velocity, wanted in all_fills:
        last.fill(messages, time_s, position, velocity, wanted)
        last.check(messages, position, velocity)


@pytest.mark.parametrize('count', [1, 64, 257])
def test_every_name_length_from_1_to_64_reads_back(count):
    """Name lengths cycle 1..64, so every alignment of what follows child_frame_id occurs;
    spheres left out of a fill keep their last values."""
    rng = np.random.default_rng(count)
    letters = list('abcdefghijklmnopqrstuvwxyz_0123456789')
    names = [''.join(rng.choice(letters, i % 64 + 1)) for i in range(count)]
    assert {len(name) for name in names} == set(range(1, min(count, 64) + 1))
    messages = SphereMessages(names, 'odom')
    last = LastPatched(names, 'odom')
    for time_s, wanted in ((1.25, range(count)), (2.5, range(0, count, 3)), (3.75, [])):
        position, velocity = rng.normal(size=(3, count)), rng.normal(size=(3, count))
        last.fill(messages, time_s, position, velocity, list(wanted))
        last.check(messages, position, velocity)


def test_odometry_is_serialized_twice_per_name_length_not_per_sphere(monkeypatch):
    calls = []

    def counted(message):
        calls.append(type(message))
        return serialize_message(message)
    monkeypatch.setattr(serialized, 'serialize_message', counted)
    messages = odometry_messages([f's{i}' for i in range(1000)], 'world')  # 3 lengths
    assert len(messages) == 1000
    assert calls == [Odometry] * 6


def test_without_odometry_no_per_sphere_message_is_built(monkeypatch):
    def refuse(*args, **kwargs):
        raise AssertionError('a per-sphere message was built')
    monkeypatch.setattr(messages_module, 'PatchedMessages', refuse)
    monkeypatch.setattr(messages_module, 'sphere_odometry', refuse)
    names = ['a', 'bb', 'ccc']
    messages = SphereMessages(names, 'world', odometry=False)
    assert len(messages.odometry) == 0
    with pytest.raises(IndexError):
        messages.odometry_bytes(0)
    position, velocity = np.arange(9.0).reshape(3, 3), -np.arange(9.0).reshape(3, 3)
    messages.fill(4.0, position, velocity, np.ones(3))
    assert deserialize_message(messages.states_bytes(), Float64MultiArray) == \
        expected_states(position, velocity)
    with pytest.raises(ValueError, match='odometry=False'):
        messages.fill(4.0, position, velocity, np.ones(3), [1])


def test_states_layout_names_its_dimensions():
    messages = SphereMessages(['a', 'b'], 'world')
    messages.fill(1.0, np.array([[1.0, 2.0], [3.0, 4.0], [5.0, 6.0]]),
                  np.array([[7.0, 8.0], [9.0, 10.0], [11.0, 12.0]]), np.ones(2))
    states = deserialize_message(messages.states_bytes(), Float64MultiArray)
    assert [(d.label, d.size, d.stride) for d in states.layout.dim] == [
        ('spheres', 2, 12), ('position_velocity', 6, 6)]
    assert states.layout.data_offset == 0
    assert states.data.tolist() == [1.0, 3.0, 5.0, 7.0, 9.0, 11.0,
                                    2.0, 4.0, 6.0, 8.0, 10.0, 12.0]
