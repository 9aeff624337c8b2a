"""Run a scene without ROS and print a table of the spheres over time.

    python -m pool_sim.headless [params.yaml] [--seconds 20] [--every 1]
    python -m pool_sim.headless [params.yaml] --record run.mcap   # as the node records
    python -m pool_sim.headless [params.yaml] --foxglove [PORT]   # live, in real time
    python -m pool_sim.headless [params.yaml] --animate pool.gif [--seconds 10] [--fps 20]

With --record, the instants the node would publish (publish_rate_hz of simulated time, as
fast as the machine goes) go into an MCAP file under the node's topic names (/pool_sim/...).
"""
import argparse
import math
import signal
import sys
import time

from pool_sim.physics import InvalidInput, Scene, Simulation
from pool_sim.physics.schema import check_integer
from pool_sim.ros.node_keys import FOXGLOVE_PORT_RANGE, NODE_SCENE


def parse(argv):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument('params_file', nargs='?', help='ROS params YAML (default: the pool)')
    parser.add_argument('--seconds', type=float, default=20.0, help='simulated time, s')
    parser.add_argument('--every', type=float, default=1.0, help='table row interval, s')
    parser.add_argument('--record', metavar='PATH',
                        help="an MCAP file of every instant the node would publish")
    parser.add_argument('--animate', metavar='PATH.gif',
                        help='write a side-view GIF (pool_sim.picture) instead of the table')
    parser.add_argument('--fps', type=float, default=20.0,
                        help='GIF frames per simulated s (dividing 100: real-time playback)')
    parser.add_argument('--foxglove', type=int, nargs='?', const=8765, metavar='PORT',
                        help='serve a live view to Foxglove on PORT (default 8765) and run '
                        'in real time')
    return parser.parse_args(argv)


def refuse(error):
    """As the node refuses a params file: one line, exit 1."""
    print(f'pool_sim.headless: refusing to start: {error}', file=sys.stderr)
    return 1


def check_arguments(args):
    """Flags that cannot go together, and numbers out of range: InvalidInput."""
    if args.animate and (args.record is not None or args.foxglove is not None):
        raise InvalidInput('--animate draws a GIF; --record and --foxglove run the pool: '
                           'one at a time')
    if not (math.isfinite(args.seconds) and args.seconds >= 0.0):
        raise InvalidInput(f'--seconds: must be finite and >= 0, got {args.seconds!r}')
    if not (math.isfinite(args.every) and args.every > 0.0):
        raise InvalidInput(f'--every: must be finite and > 0, got {args.every!r}')
    if args.foxglove is not None:
        check_integer('--foxglove', args.foxglove, 0, FOXGLOVE_PORT_RANGE[1])


def main(argv=None):
    args = parse(argv)
    try:
        check_arguments(args)
        if args.animate:  # refused before any simulating, as a bad params file is
            from pool_sim.picture import checked_animation
            checked_animation(args.animate, args.seconds, args.fps)
        # A params file written for the node: its keys are checked, the node's read by none.
        scene = (Scene.from_yaml(args.params_file, extension=NODE_SCENE) if args.params_file
                 else Scene.default(NODE_SCENE))
    except InvalidInput as error:
        return refuse(error)
    if args.animate:
        from pool_sim.picture import write_gif
        sim = write_gif(scene, args.animate, args.seconds, args.fps)
        print(f'{args.animate}: {sim.time:.2f} s simulated, {args.fps:g} frames/s')
        return 0
    sim = Simulation(scene)
    if args.record is not None or args.foxglove is not None:
        return run_published(args, scene, sim)
    print_header(sim)
    rows = round(args.seconds / args.every)
    for row in range(rows + 1):
        sim.advance(row * args.every - sim.time)
        print_row(sim)
    return 0


def print_header(sim):
    print('   t [s] ' + ''.join(f'| {n:>8} z [m]  vz [m/s] ' for n in sim.spheres.names))


def print_row(sim):
    cells = ''.join(f'| {z:>15.3f} {vz:>9.3f} ' for z, vz in zip(
        sim.spheres.position[2], sim.spheres.velocity[2]))
    print(f'{sim.time:8.2f} {cells}')


def run_published(args, scene, sim):
    """Step as the node's clock does, telling each instant to the recorder (--record) and
    the live view (--foxglove: then in real time, as the node at real_time_factor 1); print
    a row at the first instant of each --every s. SIGINT or SIGTERM end it, the recording
    complete."""
    from pool_sim.ros.headless_topics import HeadlessTopics, node_topic
    topics = HeadlessTopics(scene)
    recorder = view = None
    # Restored at the end: main() is also called in-process (tests, a user's script), and an
    # ignored signal would outlive it, inherited by every process started after.
    handlers = {number: signal.getsignal(number) for number in (signal.SIGINT, signal.SIGTERM)}
    try:
        for number in (signal.SIGINT, signal.SIGTERM):
            signal.signal(number, _interrupt)
        try:
            if args.record is not None:
                from pool_sim.ros.recorder import Recorder
                odometry = ((lambda name: node_topic('pool_sim', f'{name}/odom'))
                            if scene['per_sphere_topics'] else None)
                # No pace to keep: wait for the writer rather than drop an instant.
                recorder = Recorder(args.record, Logger(), scene['frame_id'], odometry,
                                    block=True)
                topics.listen(recorder.published)
            if args.foxglove is not None:
                from pool_sim.ros.foxglove_view import FoxgloveView
                view = FoxgloveView.for_headless(topics, sim, args.foxglove)
        except InvalidInput as error:
            return refuse(error)
        print_header(sim)
        topics.run(sim, args.seconds, on_instant=instant_rows(
            args.every, paced=view is not None, start_s=sim.time))
    except KeyboardInterrupt:
        print(f'pool_sim.headless: stopped at {sim.time:.3f} s simulated', file=sys.stderr)
    finally:
        # A further signal must not cut the clean-up short: the file is finished first.
        for number in (signal.SIGINT, signal.SIGTERM):
            signal.signal(number, signal.SIG_IGN)
        if recorder is not None:
            recorder.close()  # it says its last counts as it closes
        if view is not None:
            view.close()
            print(f'pool_sim.headless: {view.report()}', file=sys.stderr)
        for number, handler in handlers.items():
            signal.signal(number, handler)
    return 0


def instant_rows(every_s, paced, start_s):
    """What HeadlessTopics.run calls after each instant: a table row every `every_s`
    simulated s and, paced, a wait until the instant's wall time (real time)."""
    next_row = [start_s]
    started_wall = time.monotonic()

    def on_instant(simulation):
        if simulation.time >= next_row[0] - 1e-9:
            print_row(simulation)
            next_row[0] += every_s
        ahead_s = (simulation.time - start_s) - (time.monotonic() - started_wall)
        if paced and ahead_s > 0:
            time.sleep(ahead_s)
    return on_instant


def _interrupt(signum, frame):
    """SIGINT's and SIGTERM's handler while headless runs: the first stops the run; any
    later one is ignored from here on, so that it cannot cut short the clean-up (a second
    signal 50 ms after the first once landed in the `except` clause, before the `finally`
    could ignore it, and the process ended in a traceback)."""
    for number in (signal.SIGINT, signal.SIGTERM):
        signal.signal(number, signal.SIG_IGN)
    raise KeyboardInterrupt(signal.Signals(signum).name)


class Logger:
    """rclpy's logger's three levels, on stderr."""

    def info(self, text):
        print(f'pool_sim.headless: {text}', file=sys.stderr)

    warning = error = info


if __name__ == '__main__':
    sys.exit(main())
