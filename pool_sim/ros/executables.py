"""The executables' entry points: a signal at any moment, from the first import to the
last clean-up, ends the process cleanly (exit code 0, no traceback).

This module imports nothing heavy. It takes SIGINT and SIGTERM before the node's modules
(rclpy, numpy, numba) are imported; the first signal raises Stop in the main thread,
wherever it is (importing, building the node, spinning), and main() cleans up. From the
clean-up on, a further signal ends the process at once.
"""
import importlib
import os
import signal

SIGNALS = (signal.SIGINT, signal.SIGTERM)


class Stop(BaseException):
    """SIGINT or SIGTERM arrived: stop cleanly. A BaseException, like KeyboardInterrupt,
    so no `except Exception` on the way swallows it."""


def _raise_stop(signum, frame):
    exit_on_signal()  # the next signal, during clean-up, ends the process at once
    raise Stop(signal.Signals(signum).name)


def _exit_now(signum, frame):
    os._exit(0)


def take_signals():
    """From now on the first SIGINT or SIGTERM raises Stop in the main thread."""
    for number in SIGNALS:
        signal.signal(number, _raise_stop)


def exit_on_signal():
    """From now on SIGINT or SIGTERM ends the process at once (used during clean-up)."""
    for number in SIGNALS:
        signal.signal(number, _exit_now)


def _run(module_name):
    take_signals()
    try:
        main = importlib.import_module(module_name).main
    except Stop:
        return 0
    return main()


def pool_sim():
    """`ros2 run pool_sim pool_sim`."""
    return _run('pool_sim.ros.simulator_node')


def depth_keeper():
    """`ros2 run pool_sim depth_keeper`."""
    return _run('pool_sim.ros.depth_keeper')
