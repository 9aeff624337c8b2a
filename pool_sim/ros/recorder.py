"""Recording: every published instant and every applied input into one MCAP file
(mcap_file.py), written on a thread of the recorder's own.

The node's clock thread only hands over what it published (serialized bytes it already has)
and a copy of the spheres' positions and velocities, from which the recorder's thread makes
every sphere's odometry while per-sphere topics are on: the recording holds each sphere's
~/<sphere>/odom at every instant, whoever subscribes. Inputs come with their receive time
(simulated ns). Log time is simulated time, so a recording is dense in simulated time at
any real_time_factor and in lockstep.

Writing never stalls the physics: what waits for the writer is bounded (MAX_WAITING_BYTES);
an instant that would pass the bound is dropped and counted in the status line. A file that
fails while running (a full disk) stops the recording with one error; the simulation goes on.
"""
from collections import deque
import threading
import time

import numpy as np

from nav_msgs.msg import Odometry
from rclpy.qos import QoSProfile
from rclpy.serialization import serialize_message

from pool_sim.ros.mcap_file import McapFile
from pool_sim.ros.messages import odometry_messages
from pool_sim.ros.publishing import STATE_QOS

# Bytes handed over and not yet written beyond which an instant is dropped (counted).
MAX_WAITING_BYTES = 256 * 1024 * 1024
# Wall s between two flushes of the chunk in progress: a kill -9 loses at most about this.
FLUSH_PERIOD_S = 1.0
# Wall s the clean-up at a stop may spend writing what waits before it finishes the file.
CLOSE_DRAIN_S = 5.0
ODOMETRY_BYTES = 720  # about one serialized Odometry with a short name, for the bound
CLOCK_QOS = QoSProfile(depth=10)  # as the node publishes /clock
INPUT_QOS = QoSProfile(depth=10)  # the inputs' publishers are other nodes': rclpy's default


class SpheresAt:
    """A copy of what the odometry of one instant needs, made on the clock's thread."""

    def __init__(self, spheres):
        self.names = tuple(spheres.names)
        self.position = spheres.position.copy()
        self.velocity = spheres.velocity.copy()


class Recorder:
    """Records into `path` (InvalidInput naming it when it cannot: refused at start).

    odometry_topic: name -> the topic of a sphere's odometry, or None when per-sphere topics
    are off (no odometry recorded). frame_id: the odometry's frame. logger: rclpy's, or
    anything with info/warning/error.
    """

    def __init__(self, path, logger, frame_id, odometry_topic=None):
        self.file = McapFile(path)
        self.path, self.logger, self.frame_id = path, logger, frame_id
        self.odometry_topic = odometry_topic
        self.waiting = deque()
        self.waiting_bytes = 0
        self.ready = threading.Condition()
        self.running, self.failed = True, None
        self.instants = 0  # state instants written
        self.dropped = 0  # state instants dropped: the writer was behind
        self.inputs = 0  # inputs written
        self.odometry_names, self.odometry = None, None  # the names last seen, their Odometry
        self.thread = threading.Thread(target=self._run, name='pool_sim_recorder', daemon=True)
        try:
            self.thread.start()
            logger.info(f'recording every published instant and applied input into {path} '
                        '(MCAP, rosbag2 conventions)')
        except BaseException:  # a signal: no file left without its footer
            self.close()
            raise

    @classmethod
    def for_node(cls, node):
        scene = node.scene
        prefix = node.get_fully_qualified_name().rstrip('/')
        odometry_topic = ((lambda name: f'{prefix}/{name}/odom')
                          if scene['per_sphere_topics'] else None)
        recorder = cls(scene['record'], node.get_logger(), scene['frame_id'], odometry_topic)
        try:
            node.publishing.listen(recorder.published)
            node.inputs.listen(recorder.applied)
            node.clock.reports.append(recorder.report)
        except BaseException:  # a signal half-way: the file is finished before it goes
            recorder.close()
            raise
        return recorder

    # -- on the publishing thread: hand over, never wait -------------------------------------

    def published(self, published):
        """A publishing listener: the instant's messages, and for odometry the spheres."""
        if published.again:
            return  # the instant published last, unchanged: recorded already
        entries = [(topic, kind, data) for topic, kind, data in published.messages
                   if kind is not Odometry]
        size = sum(len(data) for _, _, data in entries)
        spheres = None
        if published.spheres is not None and self.odometry_topic is not None:
            spheres = SpheresAt(published.spheres)
            size += ODOMETRY_BYTES * len(spheres.names)
        with self.ready:
            if self.failed is not None or not self.running:
                return
            if published.spheres is not None and (
                    self.waiting_bytes + size > MAX_WAITING_BYTES and self.waiting):
                self.dropped += 1
                return
            self.waiting.append((published.stamp_ns, entries, spheres, size,
                                 published.spheres is not None))
            self.waiting_bytes += size
            self.ready.notify()

    def applied(self, applied):
        """An inputs listener: an input the node applied, at its receive time."""
        with self.ready:
            if self.failed is None and self.running:
                self.waiting.append((applied.received_ns, applied, None, 0, False))
                self.ready.notify()

    # -- the writer's thread ------------------------------------------------------------------

    def _run(self):
        last_flush = time.monotonic()
        while True:
            with self.ready:
                while self.running and not self.waiting:
                    self.ready.wait(FLUSH_PERIOD_S)
                    if not self.waiting:
                        break
                if not self.waiting and not self.running:
                    return
                item = self.waiting.popleft() if self.waiting else None
                if item is not None:
                    self.waiting_bytes -= item[3]
            try:
                if item is not None:
                    self._write(*item[:3], is_state=item[4])
                if time.monotonic() - last_flush >= FLUSH_PERIOD_S:
                    self.file.flush()
                    last_flush = time.monotonic()
            except OSError as error:
                self._fail(error)
                return

    def _write(self, time_ns, entries, spheres, is_state):
        if not isinstance(entries, list):  # an input
            applied = entries
            self.file.write(applied.topic, applied.message_type,
                            serialize_message(applied.message), time_ns, INPUT_QOS)
            self.inputs += 1
            return
        for topic, kind, data in entries:
            qos = CLOCK_QOS if topic == '/clock' else STATE_QOS
            self.file.write(topic, kind, data, time_ns, qos)
        if spheres is not None:
            self._write_odometry(time_ns, spheres)
        self.instants += is_state

    def _write_odometry(self, time_ns, spheres):
        if self.odometry_names != spheres.names:  # spheres spawned or removed
            self.odometry = odometry_messages(spheres.names, self.frame_id)
            self.odometry_names = spheres.names
        seconds, nanoseconds = divmod(time_ns, 1_000_000_000)
        self.odometry.patch(np.arange(len(spheres.names)), seconds, nanoseconds,
                            np.concatenate((spheres.position, spheres.velocity)).T)
        for index, name in enumerate(spheres.names):
            self.file.write(self.odometry_topic(name), Odometry, self.odometry[index],
                            time_ns, STATE_QOS)

    def _fail(self, error):
        with self.ready:
            self.failed = f'{error.strerror or error}'
            lost = len(self.waiting)
            self.waiting.clear()
            self.waiting_bytes = 0
        self.logger.error(f'recording into {self.path} stopped: {self.failed} ({lost} items '
                          'not written); the simulation goes on')
        try:
            self.file.close()
        except (OSError, ValueError):
            pass  # what was written up to the last chunk stays readable

    # -- the status line and the end ----------------------------------------------------------

    def report(self) -> str:
        if self.failed is not None:
            return f'recording stopped ({self.failed}) after {self.instants} instants'
        return (f'recorded {self.instants} instants and {self.inputs} inputs into '
                f'{self.path}, {self.dropped} instants dropped (writer behind)')

    def close(self):
        """Write what waits (for at most CLOSE_DRAIN_S), then finish the file: complete,
        with its summary and footer. Idempotent."""
        with self.ready:
            if not self.running:
                return
            self.running = False
            self.ready.notify()
        if self.thread.ident is not None:  # started
            self.thread.join(timeout=CLOSE_DRAIN_S)
        with self.ready:
            left = len(self.waiting)
            self.waiting.clear()  # the thread, if still writing, stops after its item
        if self.thread.is_alive():
            self.thread.join()  # the item in hand
        if self.failed is not None:
            return
        try:
            self.file.close()
        except OSError as error:
            self.logger.error(f'recording into {self.path}: could not finish the file: '
                              f'{error.strerror or error}')
            return
        self.logger.info(f'recorded {self.instants} instants and {self.inputs} inputs into '
                         f'{self.path}' + (f' ({left} left unwritten at the stop)'
                                           if left else ''))
