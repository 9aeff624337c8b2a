"""Test-run settings: every run gets its own ROS domain, discovery stays on this machine;
hypothesis runs the profile HYPOTHESIS_PROFILE names (default 'dev')."""
import os
import random

from hypothesis import settings

# Before any rclpy import starts DDS: runs on one machine must not hear each other.
os.environ.setdefault('ROS_DOMAIN_ID', str(random.SystemRandom().randint(1, 100)))
os.environ.setdefault('ROS_AUTOMATIC_DISCOVERY_RANGE', 'LOCALHOST')

# dev: new random examples every run, so runs keep exploring. ci: the same examples every run
# (.ci/run picks it), so a red CI means a change broke something, not that the dice found
# an old fault. deep: a long search, run by hand: HYPOTHESIS_PROFILE=deep bash dev.sh test
# msg_tests/test_property_stability.py
settings.register_profile('dev', max_examples=40)
settings.register_profile('ci', max_examples=40, derandomize=True)
settings.register_profile('deep', max_examples=1000)
settings.load_profile(os.environ.get('HYPOTHESIS_PROFILE', 'dev'))

# pool_sim.testing's fixture, as an installed pool_sim gives it to a user's pytest (the
# checkout is not installed: imported here).
from pool_sim.testing import pool_sim  # noqa: E402,F401
