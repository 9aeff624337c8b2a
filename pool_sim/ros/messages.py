"""ROS messages from the simulation's arrays.

Every message is serialized once (the arrays: assembled from rclpy's serialization of a few
elements) and patched in place each publish (serialized.py), then published as bytes:
PoseArray, MarkerArray, the Float64MultiArray of every sphere's state and the Odometry of
each sphere (all in one buffer; only the spheres someone listens to are patched). rclpy's
per-message conversion (~10 us per pose, ~30 us per marker, ~24 us per Odometry refilled
and converted) no longer runs on publish.
"""
import array
import colorsys

from builtin_interfaces.msg import Time
from geometry_msgs.msg import Point, Pose, PoseArray
from nav_msgs.msg import Odometry
from std_msgs.msg import ColorRGBA, Float64MultiArray, MultiArrayDimension
from visualization_msgs.msg import Marker, MarkerArray

import numpy as np

from pool_sim.ros.serialized import PatchedDoubleBlock, PatchedMessage, PatchedMessages


# The water's r, g, b, a in the scene markers, the Foxglove scene and pool_sim.picture's GIF:
# translucent blue; the pool's edges light grey, lines POOL_EDGE_WIDTH_M wide.
WATER_RGBA = (0.1, 0.4, 0.9, 0.3)
POOL_EDGE_RGBA = (0.8, 0.8, 0.8, 1.0)
POOL_EDGE_WIDTH_M = 0.02
# builtin_interfaces/Time holds seconds in an int32: the last simulated second it can carry.
LAST_STAMP_S = 2**31 - 1


def stamp_nanoseconds(seconds: float) -> int:
    """Simulated seconds as the nanoseconds of their ROS stamp."""
    return int(round(seconds * 1e9))


def stamp_of(seconds: float) -> Time:
    nanoseconds = stamp_nanoseconds(seconds)
    return Time(sec=nanoseconds // 1_000_000_000, nanosec=nanoseconds % 1_000_000_000)


def sphere_colour(index: int, count: int) -> ColorRGBA:
    """Evenly spaced hues, so spheres tell apart in RViz."""
    red, green, blue = colorsys.hsv_to_rgb(index / max(count, 1), 0.75, 0.95)
    return ColorRGBA(r=red, g=green, b=blue, a=1.0)


# sphere_colour's (r, g, b) in each hue sector of colorsys.hsv_to_rgb, as indices into
# (value, t, p, q) of its arithmetic.
_SECTOR_RGB = np.array([[0, 1, 2], [3, 0, 2], [2, 0, 1], [2, 3, 0], [1, 2, 0], [0, 2, 3]])


def sphere_colours(count) -> np.ndarray:
    """(count, 4) r, g, b, a of sphere_colour(i, count) for every i, vectorised: the same
    arithmetic as colorsys.hsv_to_rgb, so the same doubles."""
    saturation, value = 0.75, 0.95
    hue_6 = np.arange(count) / max(count, 1) * 6.0
    sector = hue_6.astype(np.int64)  # int() truncates: hue >= 0
    fraction = hue_6 - sector
    candidates = np.stack(np.broadcast_arrays(
        value, value * (1.0 - saturation * (1.0 - fraction)), value * (1.0 - saturation),
        value * (1.0 - saturation * fraction)))
    rgb = candidates[_SECTOR_RGB[sector % 6], np.arange(count)[:, None]]
    return np.column_stack((rgb, np.ones(count)))


def pose_array(count, frame_id) -> PoseArray:
    poses = PoseArray()
    poses.header.frame_id = frame_id
    poses.poses = [Pose() for _ in range(count)]
    return poses


def sphere_markers(count, frame_id) -> MarkerArray:
    """One SPHERE marker per sphere: ns 'spheres', id = index, a hue each."""
    markers = MarkerArray()
    for i in range(count):
        marker = Marker(ns='spheres', id=i, type=Marker.SPHERE, action=Marker.ADD)
        marker.header.frame_id = frame_id
        marker.pose.orientation.w = 1.0
        marker.color = sphere_colour(i, count)
        markers.markers.append(marker)
    return markers


def _stamp_paths(*path):
    """PatchedMessage's stamp fields, stamp_sec and stamp_nanosec, of the
    builtin_interfaces/Time at `path`: name -> (numpy dtype, path of the number)."""
    return {'stamp_sec': ('<i4', (*path, 'sec')), 'stamp_nanosec': ('<u4', (*path, 'nanosec'))}


def _setter(*path):
    """(message, index, value) -> sets element index's field at `path` (attribute names)."""
    *parents, last = path

    def set_value(message, index, value):
        target = message
        for name in parents:
            target = target[index] if name == '[]' else getattr(target, name)
        setattr(target, last, value)
    return set_value


def sphere_odometry(name, frame_id) -> Odometry:
    """A sphere's Odometry before any state: orientation w = 1, covariances zero."""
    odometry = Odometry(child_frame_id=name)
    odometry.header.frame_id = frame_id
    odometry.pose.pose.orientation.w = 1.0
    return odometry


# A sphere's state in the states message: position (m), then velocity (m/s).
STATE_COLUMNS = 6


def sphere_states(count, data_length=None) -> Float64MultiArray:
    """count × 6 row-major zeros: dim[0] 'spheres', dim[1] 'position_velocity'. No header:
    std_msgs' arrays have none; its time is the stamp of the PoseArray published with it.
    data_length: doubles in data if not count × 6 (a template for count spheres)."""
    states = Float64MultiArray()
    states.layout.dim = [
        MultiArrayDimension(label='spheres', size=count, stride=STATE_COLUMNS * count),
        MultiArrayDimension(label='position_velocity', size=STATE_COLUMNS,
                            stride=STATE_COLUMNS)]
    states.layout.data_offset = 0
    # array.array skips rclpy's per-element check of a list (600 000 doubles at 100 000).
    if data_length is None:
        data_length = STATE_COLUMNS * count
    states.data = array.array('d', bytes(8 * data_length))
    return states


def _field_setter(*path):
    """(message, value) -> sets the number at `path` (attribute names) of message."""
    *parents, last = path

    def set_value(message, value):
        target = message
        for name in parents:
            target = getattr(target, name)
        setattr(target, last, value)
    return set_value


def odometry_messages(names, frame_id) -> PatchedMessages:
    """Every sphere's Odometry (sphere_odometry) serialized into one buffer; patched
    doubles, in order: position x y z (m), twist linear x y z (m/s)."""
    doubles = {axis: _field_setter('pose', 'pose', 'position', axis) for axis in 'xyz'}
    doubles.update({f'v{axis}': _field_setter('twist', 'twist', 'linear', axis)
                    for axis in 'xyz'})
    return PatchedMessages(lambda name: sphere_odometry(name, frame_id), names, doubles,
                           stamp=lambda message: message.header.stamp)


class SphereMessages:
    """The per-publish messages of n spheres, patched from (3, n) arrays.

    poses, markers: PatchedMessage (`.to_bytes()`). odometry=True builds every sphere's
    Odometry (header.frame_id = frame_id, child_frame_id = its name) in one buffer:
    `odometry_bytes(i)` (= `odometry[i]`) is sphere i's as bytes, ready to publish. With
    odometry=False none is built (no per-sphere topics; start-up stays small at 100 000).
    `states_bytes()`: every sphere's state as one Float64MultiArray (sphere_states).
    """

    def __init__(self, names, frame_id, odometry=True):
        count = len(names)
        # Each is assembled from its 0- to 3-element serializations (PatchedMessage), so
        # building costs O(count) numpy copying; the per-sphere hues and ids are written in
        # once here.
        header = {name: (dtype, _field_setter(*path)) for name, (dtype, path) in
                  _stamp_paths('header', 'stamp').items()}
        self.poses = PatchedMessage(
            lambda elements: pose_array(elements, frame_id), count, header_fields=header,
            element_fields={axis: ('<f8', _setter('poses', '[]', 'position', axis))
                            for axis in 'xyz'})
        marker_fields = {name: (dtype, _setter(*path)) for name, (dtype, path) in
                         _stamp_paths('markers', '[]', 'header', 'stamp').items()}
        marker_fields['id'] = ('<i4', _setter('markers', '[]', 'id'))
        for axis in 'xyz':
            marker_fields[axis] = ('<f8', _setter('markers', '[]', 'pose', 'position', axis))
            marker_fields[f'scale_{axis}'] = ('<f8', _setter('markers', '[]', 'scale', axis))
        for channel in 'rgba':
            marker_fields[f'color_{channel}'] = ('<f4', _setter('markers', '[]', 'color',
                                                                channel))
        self.markers = PatchedMessage(lambda elements: sphere_markers(elements, frame_id),
                                      count, element_fields=marker_fields)
        colours = sphere_colours(count)
        self.markers.write(id=np.arange(count), **{
            f'color_{channel}': colours[:, column] for column, channel in enumerate('rgba')})
        self.states = PatchedDoubleBlock(lambda doubles: sphere_states(count, doubles),
                                         count, STATE_COLUMNS)
        # odometry[i]: sphere i's serialized Odometry, which publish takes as it takes the
        # message; with odometry=False an empty sequence.
        self.odometry = odometry_messages(names, frame_id) if odometry else ()

    def fill(self, time_s, position, velocity, radius, odometry_wanted=()):
        """position, velocity: (3, n) m, m/s; radius: (n,) m; time_s: simulation time.
        odometry_wanted: indices of the spheres whose Odometry is patched; the others keep
        what they last held."""
        stamp = stamp_of(time_s)
        self.poses.patch(stamp.sec, stamp.nanosec, x=position[0], y=position[1], z=position[2])
        diameter = 2.0 * radius
        self.markers.patch(stamp.sec, stamp.nanosec, x=position[0], y=position[1],
                           z=position[2], scale_x=diameter, scale_y=diameter,
                           scale_z=diameter)
        self.states.block[...] = np.concatenate((position, velocity)).T
        if len(odometry_wanted) == 0:
            return
        if len(self.odometry) == 0:
            raise ValueError('odometry wanted from SphereMessages built with odometry=False')
        wanted = np.asarray(odometry_wanted, np.intp)
        self.odometry.patch(wanted, stamp.sec, stamp.nanosec,
                             np.concatenate((position[:, wanted], velocity[:, wanted])).T)

    def odometry_bytes(self, index: int) -> bytes:
        """Sphere `index`'s serialized nav_msgs/Odometry, as last patched by fill."""
        return self.odometry[index]

    def states_bytes(self) -> bytes:
        """std_msgs/Float64MultiArray of n × 6 row-major [x, y, z, vx, vy, vz] (m, m/s) in
        sphere order. It has no header (std_msgs' convention for arrays): its time is the
        stamp of the PoseArray filled with it."""
        return self.states.to_bytes()


def pool_edges(low, high) -> list:
    """The twelve edges of the box from corner `low` to corner `high` (m), as 24 points
    (x, y, z): each pair one edge, as a line list draws them."""
    corners = [(x, y, z) for x in (low[0], high[0]) for y in (low[1], high[1])
               for z in (low[2], high[2])]
    return [corner for a in range(8) for b in range(a + 1, 8)
            if sum(p != q for p, q in zip(corners[a], corners[b])) == 1
            for corner in (corners[a], corners[b])]


def water_top(low, high, surface_z) -> float:
    """The height (m) the water is drawn up to: its surface, clipped to the pool."""
    return min(max(surface_z, low[2]), high[2])


def water_box(low, high, surface_z):
    """(centre, size), each (x, y, z) m, of the water: the pool up to the surface, clipped
    to the pool (at least 1 um tall, so a drawing of it stays valid)."""
    top = water_top(low, high, surface_z)
    centre = (0.5 * (low[0] + high[0]), 0.5 * (low[1] + high[1]), 0.5 * (low[2] + top))
    return centre, (high[0] - low[0], high[1] - low[1], max(top - low[2], 1e-6))


def scene_markers(pool, surface_z, frame_id) -> MarkerArray:
    """The pool's edges as a line list and the water as a translucent box."""
    low, high = pool.corner_min.tolist(), pool.corner_max.tolist()
    edges = Marker(ns='pool', id=0, type=Marker.LINE_LIST, action=Marker.ADD)
    edges.scale.x = POOL_EDGE_WIDTH_M
    edges.pose.orientation.w = 1.0
    edges.color = ColorRGBA(**dict(zip('rgba', POOL_EDGE_RGBA)))
    edges.points = [Point(x=x, y=y, z=z) for x, y, z in pool_edges(low, high)]
    water = Marker(ns='water', id=0, type=Marker.CUBE, action=Marker.ADD)
    (water.pose.position.x, water.pose.position.y, water.pose.position.z), \
        (water.scale.x, water.scale.y, water.scale.z) = water_box(low, high, surface_z)
    water.pose.orientation.w = 1.0
    water.color = ColorRGBA(**dict(zip('rgba', WATER_RGBA)))
    edges.header.frame_id = water.header.frame_id = frame_id
    return MarkerArray(markers=[edges, water])
