"""The ROS 2 side: the simulator node, its parameters and messages, and a demo controller."""
