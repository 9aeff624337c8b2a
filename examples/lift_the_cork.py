"""A controller in 20 lines: hold the cork 1 m above the water by pushing it up.

    python examples/lift_the_cork.py      # beside a running pool_sim node
"""
import rclpy
from geometry_msgs.msg import Wrench
from nav_msgs.msg import Odometry
from rclpy.node import Node

TARGET_Z_M, KP_N_PER_M, KD_N_S_PER_M, WEIGHT_N = 1.0, 400.0, 60.0, 8.3776 * 9.81


class LiftTheCork(Node):
    def __init__(self, **kwargs):
        super().__init__('lift_the_cork', **kwargs)
        self.push = self.create_publisher(Wrench, 'pool_sim/cork/wrench', 10)
        self.create_subscription(Odometry, 'pool_sim/cork/odom', self.on_state, 10)

    def on_state(self, state):
        z, vz = state.pose.pose.position.z, state.twist.twist.linear.z
        force = Wrench()  # world axes, N: weight held, plus a PD pull to the target height
        force.force.z = WEIGHT_N + KP_N_PER_M * (TARGET_Z_M - z) - KD_N_S_PER_M * vz
        self.push.publish(force)


if __name__ == '__main__':
    rclpy.init()
    rclpy.spin(LiftTheCork())
