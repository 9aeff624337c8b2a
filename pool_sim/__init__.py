"""pool_sim: spheres falling through air into a pool of water, as a ROS 2 node.

pool_sim.physics is the numpy core (no ROS); pool_sim.node is the rclpy node around it.
"""
