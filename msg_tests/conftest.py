"""Test-run settings: every run gets its own ROS domain, discovery stays on this machine."""
import os
import random

# Before any rclpy import starts DDS: runs on one machine must not hear each other.
os.environ.setdefault('ROS_DOMAIN_ID', str(random.SystemRandom().randint(1, 100)))
os.environ.setdefault('ROS_AUTOMATIC_DISCOVERY_RANGE', 'LOCALHOST')
