"""ROS messages from the simulation's arrays. Objects are built once and refilled each publish:
creating rclpy messages is what costs, not filling their fields."""
import colorsys

from builtin_interfaces.msg import Time
from geometry_msgs.msg import Point, Pose, PoseArray
from nav_msgs.msg import Odometry
from std_msgs.msg import ColorRGBA
from visualization_msgs.msg import Marker, MarkerArray


def stamp_of(seconds: float) -> Time:
    nanoseconds = int(round(seconds * 1e9))
    return Time(sec=nanoseconds // 1_000_000_000, nanosec=nanoseconds % 1_000_000_000)


def sphere_colour(index: int, count: int) -> ColorRGBA:
    """Evenly spaced hues, so spheres tell apart in RViz."""
    red, green, blue = colorsys.hsv_to_rgb(index / max(count, 1), 0.75, 0.95)
    return ColorRGBA(r=red, g=green, b=blue, a=1.0)


class SphereMessages:
    """PoseArray, MarkerArray and one Odometry per sphere, refilled from (3, n) arrays."""

    def __init__(self, names, frame_id):
        self.poses = PoseArray()
        self.poses.header.frame_id = frame_id
        self.poses.poses = [Pose() for _ in names]
        self.markers = MarkerArray()
        for i, name in enumerate(names):
            marker = Marker(ns='spheres', id=i, type=Marker.SPHERE, action=Marker.ADD)
            marker.header.frame_id = frame_id
            marker.pose.orientation.w = 1.0
            marker.color = sphere_colour(i, len(names))
            self.markers.markers.append(marker)
        self.odometry = []
        for name in names:
            odometry = Odometry(child_frame_id=name)
            odometry.header.frame_id = frame_id
            odometry.pose.pose.orientation.w = 1.0
            self.odometry.append(odometry)
        # One Point per sphere, shared by its pose, marker and odometry: filled once per publish.
        for pose, marker, odometry in zip(self.poses.poses, self.markers.markers, self.odometry):
            marker.pose.position = pose.position
            odometry.pose.pose.position = pose.position

    def fill(self, time_s, position, velocity, radius):
        """position, velocity: (3, n) m, m/s; radius: (n,) m; time_s: simulation time."""
        stamp = stamp_of(time_s)
        self.poses.header.stamp = stamp
        xs, ys, zs = position.tolist()
        vxs, vys, vzs = velocity.tolist()
        diameters = (2.0 * radius).tolist()
        for i, pose in enumerate(self.poses.poses):
            point = pose.position
            point.x, point.y, point.z = xs[i], ys[i], zs[i]
            marker = self.markers.markers[i]
            marker.header.stamp = stamp
            marker.scale.x = marker.scale.y = marker.scale.z = diameters[i]
            odometry = self.odometry[i]
            odometry.header.stamp = stamp
            linear = odometry.twist.twist.linear
            linear.x, linear.y, linear.z = vxs[i], vys[i], vzs[i]


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
