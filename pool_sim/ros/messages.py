"""ROS messages from the simulation's arrays.

PoseArray and MarkerArray are serialized once and patched in place each publish
(serialized.py): their cost no longer grows with rclpy's per-element conversion. Odometry
is one small message per sphere, refilled in place and built only for spheres someone
listens to.
"""
import colorsys

from builtin_interfaces.msg import Time
from geometry_msgs.msg import Point, Pose, PoseArray
from nav_msgs.msg import Odometry
from std_msgs.msg import ColorRGBA
from visualization_msgs.msg import Marker, MarkerArray

from pool_sim.ros.serialized import PatchedMessage


# builtin_interfaces/Time holds seconds in an int32: the last simulated second it can carry.
LAST_STAMP_S = 2**31 - 1


def stamp_of(seconds: float) -> Time:
    nanoseconds = int(round(seconds * 1e9))
    return Time(sec=nanoseconds // 1_000_000_000, nanosec=nanoseconds % 1_000_000_000)


def sphere_colour(index: int, count: int) -> ColorRGBA:
    """Evenly spaced hues, so spheres tell apart in RViz."""
    red, green, blue = colorsys.hsv_to_rgb(index / max(count, 1), 0.75, 0.95)
    return ColorRGBA(r=red, g=green, b=blue, a=1.0)


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


def _setter(*path):
    """(message, index, value) -> sets element index's field at `path` (attribute names)."""
    *parents, last = path

    def set_value(message, index, value):
        target = message
        for name in parents:
            target = target[index] if name == '[]' else getattr(target, name)
        setattr(target, last, value)
    return set_value


class SphereMessages:
    """The per-publish messages of n spheres, refilled from (3, n) arrays."""

    def __init__(self, names, frame_id):
        count = len(names)
        self.poses = PatchedMessage(
            lambda: pose_array(count, frame_id), count,
            {axis: _setter('poses', '[]', 'position', axis) for axis in 'xyz'},
            stamp=lambda message, index: message.header.stamp, stamp_count=1)
        doubles = {axis: _setter('markers', '[]', 'pose', 'position', axis) for axis in 'xyz'}
        doubles.update({f'scale_{axis}': _setter('markers', '[]', 'scale', axis)
                        for axis in 'xyz'})
        self.markers = PatchedMessage(
            lambda: sphere_markers(count, frame_id), count, doubles,
            stamp=lambda message, index: message.markers[index].header.stamp,
            stamp_count=count)
        self.odometry = []
        for name in names:
            odometry = Odometry(child_frame_id=name)
            odometry.header.frame_id = frame_id
            odometry.pose.pose.orientation.w = 1.0
            self.odometry.append(odometry)

    def fill(self, time_s, position, velocity, radius, odometry_wanted=()):
        """position, velocity: (3, n) m, m/s; radius: (n,) m; time_s: simulation time.
        odometry_wanted: indices of the spheres whose Odometry is refilled."""
        stamp = stamp_of(time_s)
        self.poses.patch(stamp.sec, stamp.nanosec, x=position[0], y=position[1], z=position[2])
        diameter = 2.0 * radius
        self.markers.patch(stamp.sec, stamp.nanosec, x=position[0], y=position[1],
                           z=position[2], scale_x=diameter, scale_y=diameter,
                           scale_z=diameter)
        for i in odometry_wanted:
            odometry = self.odometry[i]
            odometry.header.stamp = stamp
            point, linear = odometry.pose.pose.position, odometry.twist.twist.linear
            point.x, point.y, point.z = (float(v) for v in position[:, i])
            linear.x, linear.y, linear.z = (float(v) for v in velocity[:, i])


def scene_markers(pool, surface_z, frame_id) -> MarkerArray:
    """The pool's edges as a line list and the water as a translucent box."""
    low, high = pool.corner_min.tolist(), pool.corner_max.tolist()
    edges = Marker(ns='pool', id=0, type=Marker.LINE_LIST, action=Marker.ADD)
    edges.scale.x = 0.02
    edges.pose.orientation.w = 1.0
    edges.color = ColorRGBA(r=0.8, g=0.8, b=0.8, a=1.0)
    corners = [(x, y, z) for x in (low[0], high[0]) for y in (low[1], high[1])
               for z in (low[2], high[2])]
    for a in range(8):
        for b in range(a + 1, 8):
            if sum(p != q for p, q in zip(corners[a], corners[b])) == 1:
                edges.points += [Point(x=corners[a][0], y=corners[a][1], z=corners[a][2]),
                                 Point(x=corners[b][0], y=corners[b][1], z=corners[b][2])]
    water = Marker(ns='water', id=0, type=Marker.CUBE, action=Marker.ADD)
    water_top = min(max(surface_z, low[2]), high[2])
    water.pose.position.x = 0.5 * (low[0] + high[0])
    water.pose.position.y = 0.5 * (low[1] + high[1])
    water.pose.position.z = 0.5 * (low[2] + water_top)
    water.pose.orientation.w = 1.0
    water.scale.x, water.scale.y = high[0] - low[0], high[1] - low[1]
    water.scale.z = max(water_top - low[2], 1e-6)
    water.color = ColorRGBA(r=0.1, g=0.4, b=0.9, a=0.3)
    edges.header.frame_id = water.header.frame_id = frame_id
    return MarkerArray(markers=[edges, water])
