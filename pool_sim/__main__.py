"""`python -m pool_sim [--ros-args ...]`: the pool_sim node, as `ros2 run pool_sim pool_sim`."""
import sys

from pool_sim.ros.executables import pool_sim

sys.exit(pool_sim())
