"""The executables' entry points: a signal at any moment, from the first import to the
last clean-up, ends the process cleanly (exit code 0, no traceback).

This module imports nothing heavy. It takes SIGINT and SIGTERM before the node's modules
(rclpy, numpy, numba) are imported; the first signal raises Stop in the main thread,
wherever it is (importing, building the node, spinning), and run_node cleans up. From the
clean-up on, a further signal ends the process at once.
"""
import faulthandler
import gc
import importlib
import os
import signal
import sys
import time

SIGNALS = (signal.SIGINT, signal.SIGTERM)
_stopping = False
_exit_code = 0  # what a signal during clean-up ends the process with: 1 after a refusal


# Wall seconds the clean-up after a stop may take before the process ends regardless.
CLEANUP_LIMIT_S = 10.0
_devnull = None


class Stop(BaseException):
    """SIGINT or SIGTERM arrived: stop cleanly. A BaseException, like KeyboardInterrupt,
    so no `except Exception` on the way swallows it."""


def _raise_stop(signum, frame):
    global _stopping
    _stopping = True
    exit_on_signal()  # the next signal, during clean-up, ends the process at once
    raise Stop(signal.Signals(signum).name)


def _exit_now(signum, frame):
    _flush_and_exit(_exit_code)


def _flush_and_exit(code):
    for stream in (sys.stdout, sys.stderr):
        try:
            stream.flush()
        except (OSError, ValueError):
            pass
    os._exit(code)


def _quiet_once_stopping(unraisable, previous_hook=sys.unraisablehook):
    # Stop can land while rclpy builds something (an executor in spin, a node); its
    # __del__ then fails and Python prints 'Exception ignored in ...' with a traceback.
    # Once stopping, that is noise.
    if not _stopping:
        previous_hook(unraisable)


def _quiet_excepthook_once_stopping(kind, value, traceback, previous_hook=sys.excepthook):
    # C code that prints the error it met and goes on prints through sys.excepthook: numpy's
    # import_array() in an extension module's init (numpy.linalg._umath_linalg,
    # numba._dispatcher) runs importlib's Python code, where a pending signal raises Stop,
    # and PyErr_Print()s it before turning it into an ImportError. Once stopping, noise.
    if not _stopping:
        previous_hook(kind, value, traceback)


SWITCH_INTERVAL_S = 0.0005


def _return_large_buffers():
    """glibc raises its mmap threshold to the largest block freed so far, so after one
    publish of a large scene the per-publish copies (serialized bytes, rcl's copy) stay
    in the heap for good; a fixed threshold hands every one back when it is freed
    (measured: 1.7 instead of 2.05 kB a sphere at 10 000 spheres, 1.1 instead of 1.9 at
    100 000)."""
    try:
        import ctypes
        libc = ctypes.CDLL('libc.so.6')
        libc.mallopt(-3, 256 * 1024)  # M_MMAP_THRESHOLD, bytes
    except (OSError, AttributeError):
        pass  # not glibc: its own policy applies


def process_age_s():
    """Seconds since this process started (Linux /proc), or None where that is unknown."""
    try:
        with open('/proc/self/stat') as stat:
            started_ticks = int(stat.read().rsplit(')', 1)[1].split()[19])
        return time.clock_gettime(time.CLOCK_BOOTTIME) - started_ticks / os.sysconf('SC_CLK_TCK')
    except (OSError, ValueError, IndexError, AttributeError):
        return None


def take_signals():
    """From now on the first SIGINT or SIGTERM raises Stop in the main thread (unless one
    has come already: then the later ones end the process at once, as they do)."""
    if _stopping:
        return
    sys.unraisablehook = _quiet_once_stopping
    sys.excepthook = _quiet_excepthook_once_stopping
    for number in SIGNALS:
        signal.signal(number, _raise_stop)


def stop_if_asked():
    """Raise Stop if a signal has come: a library's bare `except:` (some imports have one)
    may have swallowed the Stop it raised, and the process must not run on."""
    if _stopping:
        raise Stop('a signal came earlier')


def exit_on_signal():
    """From now on SIGINT or SIGTERM ends the process at once (used during clean-up)."""
    for number in SIGNALS:
        signal.signal(number, _exit_now)


def run_node(name, make_node, refused, args=None, check_arguments=None):
    """The main() of the executable `name`; returns its exit code.

    rclpy.init without rclpy's own signal handlers (ours raise Stop; rclpy's would only
    shut the context down under a node half built), then make_node() and spin it until a
    signal. refused: an exception type; one raised by check_arguments(argv), by make_node
    or (as rcl's parse error) by rclpy.init, or a parameter rclpy itself refuses (a bad
    use_sim_time), is a refusal to start: one fatal log line naming the key or file, exit
    code 1.
    """
    global _exit_code
    import rclpy
    from rclpy.exceptions import ParameterException
    from rclpy.executors import ExternalShutdownException
    from rclpy.signals import SignalHandlerOptions

    take_signals()  # already taken when started through pool_sim() or depth_keeper()
    # The node's threads (clock, executor, odometry) share one interpreter lock; a thread
    # that wants it waits up to this long for a busy one to let go (CPython's default is
    # 5 ms, a sixth of a publish period at 30 Hz). The process is the node's: it sets it.
    sys.setswitchinterval(SWITCH_INTERVAL_S)
    node, executor, code = None, None, 0
    try:
        stop_if_asked()
        if check_arguments is not None:
            check_arguments(sys.argv if args is None else args)
        try:
            rclpy.init(args=args, signal_handler_options=SignalHandlerOptions.NO)
        except RuntimeError as error:  # rcl could not parse the arguments or a params file
            raise refused(str(error).splitlines()[0]) from None
        stop_if_asked()
        node = make_node()
        say_which_params_files_set_nothing(node, sys.argv if args is None else args)
        # Everything built so far lives as long as the node: out of the collector's full
        # passes, which walked it all (tens of ms at thousands of spheres) while the clock
        # thread waited.
        gc.freeze()
        _return_large_buffers()  # after start-up: rcl's params parser reallocs a list per number
        # rclpy's EventsExecutor (C++): the Python one rebuilds its wait set on every
        # wake-up, half a millisecond at the node's ~20 entities, which made a lockstep loop
        # across processes run at 9x real time instead of 25x.
        from rclpy.experimental import EventsExecutor  # in here: a signal during it is a stop
        executor = EventsExecutor(context=node.context)
        executor.add_node(node)
        # As rclpy.spin, but looking at _stopping too: a Stop that lands in a __del__ or a
        # weakref callback is unraisable (Python drops it), and the node must not run on.
        while not _stopping and node.context.ok():
            executor.spin_once(timeout_sec=0.25)
        stop_if_asked()
    except (Stop, KeyboardInterrupt, ExternalShutdownException):
        pass
    except (refused, ParameterException) as error:
        _exit_code = code = 1
        exit_on_signal()  # a signal while this line is written must not interrupt it
        rclpy.logging.get_logger(name).fatal(f'refusing to start: {error}')
    except BaseException:
        if not _stopping:
            raise  # a fault, shown in full; once stopping, a consequence of the stop
    finally:
        exit_on_signal()
        # A clean-up that does not end in CLEANUP_LIMIT_S (a DDS participant that waits for
        # a listener for ever) ends the process from faulthandler's own thread, which needs
        # no interpreter lock: exit code 1, never a process left spinning.
        faulthandler.dump_traceback_later(CLEANUP_LIMIT_S, exit=True, file=_quiet_stream())
        if executor is not None:
            if node is not None:
                # The C++ executor's callbacks off the node first: a DDS listener thread
                # calling one while the node is destroyed held the destroy up for ever.
                executor.remove_node(node)
            executor.shutdown()
        if node is not None:
            node.destroy_node()
        rclpy.try_shutdown()
        faulthandler.cancel_dump_traceback_later()
    return code


def say_which_params_files_set_nothing(node, argv):
    """A warning for each --params-file in argv that sets nothing for this node: empty, or
    none of its sections applies to the node's name and namespace (rclpy passes it over in
    silence, and the node would run on its defaults)."""
    from pool_sim.physics.params_file import sets_nothing_reason
    from pool_sim.ros.parameters import params_files
    for path in params_files(argv):
        reason = sets_nothing_reason(path, node.get_fully_qualified_name())
        if reason is not None:
            node.get_logger().warning(reason)


def _quiet_stream():
    global _devnull
    if _devnull is None:
        _devnull = open(os.devnull, 'w')
    return _devnull


def _run(module_name):
    """Import and run module_name's main(); then end the process at once with its code:
    the interpreter's own tear-down (about 0.6 s of it) is where Python's signal handling
    stops, and a signal there would kill the process instead."""
    take_signals()
    try:
        if sys.flags.no_site:  # `python -S` (as dev.sh starts it): site's work comes now
            import site
            site.main()
        code = importlib.import_module(module_name).main()
    except BaseException:
        if not _stopping:
            raise
        code = 0  # Stop, or what it became on its way (an import turns it to ImportError)
    _flush_and_exit(code)


def pool_sim():
    """`ros2 run pool_sim pool_sim`."""
    return _run('pool_sim.ros.simulator_node')


def depth_keeper():
    """`ros2 run pool_sim depth_keeper`."""
    return _run('pool_sim.ros.depth_keeper')
