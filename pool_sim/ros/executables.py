"""The executables' entry points: a signal at any moment, from the first import to the
last clean-up, ends the process cleanly (exit code 0, no traceback).

This module imports nothing heavy. It takes SIGINT and SIGTERM before the node's modules
(rclpy, numpy, numba) are imported; the first signal raises Stop in the main thread,
wherever it is (importing, building the node, spinning), and run_node cleans up. From the
clean-up on, a further signal ends the process at once.
"""
import importlib
import os
import signal
import sys

SIGNALS = (signal.SIGINT, signal.SIGTERM)
_stopping = False


class Stop(BaseException):
    """SIGINT or SIGTERM arrived: stop cleanly. A BaseException, like KeyboardInterrupt,
    so no `except Exception` on the way swallows it."""


def _raise_stop(signum, frame):
    global _stopping
    _stopping = True
    exit_on_signal()  # the next signal, during clean-up, ends the process at once
    raise Stop(signal.Signals(signum).name)


def _exit_now(signum, frame):
    os._exit(0)


def _quiet_once_stopping(unraisable, previous_hook=sys.unraisablehook):
    # Stop can land while rclpy builds something (an executor in spin, a node); its
    # __del__ then fails and Python prints 'Exception ignored in ...' with a traceback.
    # Once stopping, that is noise.
    if not _stopping:
        previous_hook(unraisable)


def take_signals():
    """From now on the first SIGINT or SIGTERM raises Stop in the main thread."""
    sys.unraisablehook = _quiet_once_stopping
    for number in SIGNALS:
        signal.signal(number, _raise_stop)


def exit_on_signal():
    """From now on SIGINT or SIGTERM ends the process at once (used during clean-up)."""
    for number in SIGNALS:
        signal.signal(number, _exit_now)


def run_node(name, make_node, refused, args=None, check_arguments=None):
    """The main() of the executable `name`; returns its exit code.

    rclpy.init without rclpy's own signal handlers (ours raise Stop; rclpy's would only
    shut the context down under a node half built), then make_node() and spin it until a
    signal. refused: an exception type; one raised by check_arguments(argv), by make_node
    or (as rcl's parse error) by rclpy.init is a refusal to start: one fatal log line naming
    the key or file, exit code 1.
    """
    import rclpy
    from rclpy.executors import ExternalShutdownException
    from rclpy.signals import SignalHandlerOptions

    take_signals()  # already taken when started through pool_sim() or depth_keeper()
    node, code = None, 0
    try:
        if check_arguments is not None:
            check_arguments(sys.argv if args is None else args)
        try:
            rclpy.init(args=args, signal_handler_options=SignalHandlerOptions.NO)
        except RuntimeError as error:  # rcl could not parse the arguments or a params file
            raise refused(str(error).splitlines()[0]) from None
        node = make_node()
        rclpy.spin(node)
    except (Stop, KeyboardInterrupt, ExternalShutdownException):
        pass
    except refused as error:
        rclpy.logging.get_logger(name).fatal(f'refusing to start: {error}')
        code = 1
    finally:
        exit_on_signal()
        if node is not None:
            node.destroy_node()
        rclpy.try_shutdown()
    return code


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
