"""depth_keeper: holds one sphere at a depth by publishing forces, as any other node could.

Reads `pool_sim/<sphere>/odom`, publishes `pool_sim/<sphere>/wrench` (names relative to this
node's namespace, so remap them like any topic). A PD law on the height error, with an
optional integral term (ki, default 0) that removes the offset a net weight or buoyancy
leaves: with PD alone the sphere settles (net force) / kp away from the target.
"""
import math
import sys

from geometry_msgs.msg import Wrench
from nav_msgs.msg import Odometry
from rcl_interfaces.msg import ParameterDescriptor
import rclpy
from rclpy.executors import ExternalShutdownException
from rclpy.node import Node

PARAMETERS = {
    'sphere': ('ice', 'name of the sphere to hold'),
    'target_depth': (1.0, 'depth of the sphere centre below surface_z, m'),
    'surface_z': (0.0, 'height of the water surface, m'),
    'kp': (600.0, 'proportional gain, N/m'),
    'kd': (150.0, 'derivative gain on the vertical velocity, N*s/m'),
    'ki': (0.0, 'integral gain, N/(m*s); 0 = pure PD'),
    'max_force': (2000.0, 'largest force it will publish, N'),
}


class DepthKeeper(Node):

    def __init__(self, **node_kwargs):
        super().__init__('depth_keeper', **node_kwargs)
        for name, (default, description) in PARAMETERS.items():
            self.declare_parameter(name, default, ParameterDescriptor(description=description))
        sphere = self.get_parameter('sphere').value
        self.integral = 0.0
        self.last_stamp = None
        self.publisher = self.create_publisher(Wrench, f'pool_sim/{sphere}/wrench', 10)
        self.create_subscription(Odometry, f'pool_sim/{sphere}/odom', self._on_odometry, 10)
        self.get_logger().info(
            f'holding {sphere} at {self.get_parameter("target_depth").value} m depth')

    def _on_odometry(self, odometry):
        p = {name: self.get_parameter(name).value for name in PARAMETERS}
        target_z = p['surface_z'] - p['target_depth']
        error = target_z - odometry.pose.pose.position.z
        stamp = odometry.header.stamp.sec + 1e-9 * odometry.header.stamp.nanosec
        if self.last_stamp is not None and stamp > self.last_stamp:
            self.integral += error * (stamp - self.last_stamp)
        self.last_stamp = stamp
        force = p['kp'] * error - p['kd'] * odometry.twist.twist.linear.z + p['ki'] * self.integral
        limit = p['max_force']
        wrench = Wrench()
        wrench.force.z = math.copysign(min(abs(force), limit), force)
        self.publisher.publish(wrench)


def main(args=None):
    rclpy.init(args=args)
    node = None
    try:
        node = DepthKeeper()
        rclpy.spin(node)
    except (KeyboardInterrupt, ExternalShutdownException):
        pass
    finally:
        if node is not None:
            node.destroy_node()
        rclpy.try_shutdown()
    return 0


if __name__ == '__main__':
    sys.exit(main())
