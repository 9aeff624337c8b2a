"""`python -m pool_sim [--ros-args ...]`: the pool_sim node, as `ros2 run pool_sim pool_sim`."""
# First, before any import that builds an enum (signal's does, for milliseconds, and a
# SIGINT 50 ms after `bash dev.sh run` started Python once landed there: a traceback):
# until the node takes signals (executables.take_signals), one ends the process at once.
# _signal and posix are built in: importing them runs no Python code.
import _signal
import posix


def _exit_before_ready(signum, frame):
    posix._exit(0)  # nothing has started: nothing to clean up


for _number in (_signal.SIGINT, _signal.SIGTERM):
    _signal.signal(_number, _exit_before_ready)

import sys  # noqa: E402 (after the handlers, on purpose)

from pool_sim.ros.executables import pool_sim  # noqa: E402

sys.exit(pool_sim())
