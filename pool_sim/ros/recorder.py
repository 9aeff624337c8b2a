"""Recording: every published instant and every applied input into one MCAP file
(mcap_file.py), written on a thread of the recorder's own.

The node's clock thread only hands over what it published (serialized bytes it already has)
and a copy of the spheres' positions and velocities, from which the recorder's thread makes
every sphere's odometry while per-sphere topics are on: the recording holds each sphere's
~/<sphere>/odom at every instant, whoever subscribes. Inputs come with their receive time
(simulated ns). Log time is simulated time, so a recording is dense in simulated time at
any real_time_factor and in lockstep; after a ~/reset (simulated time back to 0) log times
go on from where they were, so players do not interleave the runs (the messages' stamps
stay as published).

Writing never stalls the node's physics: what waits for the writer is bounded
(MAX_WAITING_BYTES); what would pass the bound is dropped and counted in the status line.
Headless, which has no pace to keep, waits for the writer instead (block=True). A file that
fails while running (a full disk) stops the recording with one error; the simulation goes on.
"""
from collections import deque
import threading
import time
from typing import NamedTuple

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
# Wall s a stop may spend writing what waits before it finishes the file: well within the
# executables' clean-up limit (10 s) and launch's 5 s from SIGINT to SIGTERM, with the
# finishing itself (the summary: ~0.5 s at 10 000 channels).
CLOSE_DRAIN_S = 2.0
ODOMETRY_BYTES = 720  # about one serialized Odometry with a short name, for the bound
INPUT_BYTES = 120  # about one serialized Wrench(Stamped); an array counts its doubles
CLOCK_QOS = QoSProfile(depth=10)  # as the node publishes /clock
INPUT_QOS = QoSProfile(depth=10)  # the inputs' publishers are other nodes': rclpy's default


class SpheresAt:
    """A copy of what the odometry of one instant needs, made on the clock's thread."""

    def __init__(self, spheres):
        self.names = tuple(spheres.names)
        self.position = spheres.position.copy()
        self.velocity = spheres.velocity.copy()


class Item(NamedTuple):
    """What waits for the writer: a published instant's messages, or an applied input."""
    log_ns: int  # the stamp (simulated ns), plus the simulated time before any reset
    messages: tuple = ()  # ((topic, message type, CDR bytes), ...)
    spheres: SpheresAt = None  # a state instant's spheres, for their odometry
    applied: object = None  # an inputs.Applied
    size: int = 0  # bytes, for the bound
    is_state: bool = False  # a state instant (counted), not /clock or the scene markers
    offset_ns: int = 0  # log_ns less the stamp


def input_size(applied) -> int:
    data = getattr(applied.message, 'data', None)
    return INPUT_BYTES + (8 * len(data) if data is not None else 0)


class Recorder:
    """Records into `path` (InvalidInput naming it when it cannot: refused at start).

    odometry_topic: name -> the topic of a sphere's odometry, or None when per-sphere topics
    are off (no odometry recorded). frame_id: the odometry's frame. logger: rclpy's, or
    anything with info/warning/error. block: wait for the writer rather than drop.
    """

    def __init__(self, path, logger, frame_id, odometry_topic=None, block=False):
        self.file = McapFile(path)
        self.path, self.logger, self.frame_id = path, logger, frame_id
        self.odometry_topic, self.block = odometry_topic, block
        self.waiting, self.waiting_bytes = deque(), 0
        self.ready = threading.Condition()
        self.running, self.failed, self.finished = True, None, False
        self.instants = self.inputs = 0  # written
        self.dropped = self.inputs_dropped = 0  # dropped: the writer was behind
        self.offset_ns = self.last_stamp_ns = 0  # log time = stamp + offset (resets)
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

    # -- on the publishing thread: hand over ---------------------------------------------------

    def published(self, published):
        """A publishing listener: the instant's messages, and for odometry the spheres."""
        if published.again:
            return  # the instant published last, unchanged: recorded already
        if published.stamp_ns < self.last_stamp_ns:  # a reset: time starts again
            self.offset_ns += self.last_stamp_ns - published.stamp_ns
        self.last_stamp_ns = published.stamp_ns
        messages = tuple((topic, kind, data) for topic, kind, data in published.messages
                         if kind is not Odometry)  # the recorder makes every sphere's
        size = sum(len(data) for _, _, data in messages)
        spheres = None
        if published.spheres is not None and self.odometry_topic is not None:
            spheres = SpheresAt(published.spheres)
            size += ODOMETRY_BYTES * len(spheres.names)
        is_state = published.spheres is not None
        if not self._hand_over(Item(published.stamp_ns + self.offset_ns, messages, spheres,
                                    size=size, is_state=is_state, offset_ns=self.offset_ns)):
            self.dropped += is_state

    def applied(self, applied):
        """An inputs listener (the clock's thread): an input applied, at its receive time."""
        if not self._hand_over(Item(applied.received_ns + self.offset_ns, applied=applied,
                                    size=input_size(applied))):
            self.inputs_dropped += 1

    def _hand_over(self, item) -> bool:
        """Queue `item` for the writer; False when it is dropped (the writer behind)."""
        with self.ready:
            while (self.block and self.running and self.failed is None and self.waiting
                   and self.waiting_bytes + item.size > MAX_WAITING_BYTES):
                self.ready.wait(FLUSH_PERIOD_S)
            if self.failed is not None or not self.running:
                return True  # stopped: nothing more is recorded, and nothing is behind
            if self.waiting and self.waiting_bytes + item.size > MAX_WAITING_BYTES:
                return False
            self.waiting.append(item)
            self.waiting_bytes += item.size
            self.ready.notify_all()
            return True

    # -- the writer's thread ------------------------------------------------------------------

    def _run(self):
        last_flush = time.monotonic()
        while True:
            with self.ready:
                if self.running and not self.waiting:
                    self.ready.wait(FLUSH_PERIOD_S)
                if not self.waiting and not self.running:
                    return
                item = self.waiting.popleft() if self.waiting else None
                if item is not None:
                    self.waiting_bytes -= item.size
                    self.ready.notify_all()  # room for a blocked hand-over
            try:
                if item is not None:
                    self._write(item)
                if time.monotonic() - last_flush >= FLUSH_PERIOD_S:
                    self.file.flush()
                    last_flush = time.monotonic()
            except Exception as error:  # a full disk, or anything else: said, never silent
                self._fail(error)
                return

    def _write(self, item):
        if item.applied is not None:
            applied = item.applied
            self.file.write(applied.topic, applied.message_type,
                            serialize_message(applied.message), item.log_ns, INPUT_QOS)
            self.inputs += 1
            return
        for topic, kind, data in item.messages:
            self.file.write(topic, kind, data, item.log_ns,
                            CLOCK_QOS if topic == '/clock' else STATE_QOS)
        if item.spheres is not None:
            self._write_odometry(item.log_ns, item.log_ns - item.offset_ns, item.spheres)
        self.instants += item.is_state

    def _write_odometry(self, log_ns, stamp_ns, spheres):
        if self.odometry_names != spheres.names:  # spheres spawned or removed
            self.odometry = odometry_messages(spheres.names, self.frame_id)
            self.odometry_names = spheres.names
        seconds, nanoseconds = divmod(stamp_ns, 1_000_000_000)
        self.odometry.patch(np.arange(len(spheres.names)), seconds, nanoseconds,
                            np.concatenate((spheres.position, spheres.velocity)).T)
        for index, name in enumerate(spheres.names):
            self.file.write(self.odometry_topic(name), Odometry, self.odometry[index],
                            log_ns, STATE_QOS)

    def _fail(self, error):
        with self.ready:
            self.failed = getattr(error, 'strerror', None) or f'{type(error).__name__}: {error}'
            lost = len(self.waiting)
            self.waiting.clear()
            self.waiting_bytes = 0
            self.ready.notify_all()
        self.logger.error(f'recording into {self.path} stopped: {self.failed} ({lost} items '
                          'not written); the simulation goes on')
        try:
            self.file.close()
        except Exception:  # what was written up to the last chunk stays readable
            pass

    # -- the status line and the end ----------------------------------------------------------

    def report(self) -> str:
        if self.failed is not None:
            return f'recording stopped ({self.failed}) after {self.instants} instants'
        return (f'recorded {self.instants} instants and {self.inputs} inputs into '
                f'{self.path}; dropped, the writer behind: {self.dropped} instants, '
                f'{self.inputs_dropped} inputs')

    def close(self):
        """Write what waits (for at most CLOSE_DRAIN_S), then finish the file: complete,
        with its summary and footer. Idempotent; a call cut short by a signal can be made
        again and finishes the file."""
        with self.ready:
            if self.finished:
                return
            self.running = False
            self.ready.notify_all()
        if self.thread.ident is not None:  # started
            self.thread.join(timeout=CLOSE_DRAIN_S)
        with self.ready:
            left = len(self.waiting)
            self.waiting.clear()  # the thread, if still writing, stops after its item
        if self.thread.is_alive():
            self.thread.join()  # the item in hand
        if self.failed is not None or self.finished:
            return
        try:
            self.file.close()
        except OSError as error:
            self.logger.error(f'recording into {self.path}: could not finish the file: '
                              f'{error.strerror or error}')
            return
        finally:
            self.finished = True
        self.logger.info(f'{self.report()}' + (f'; {left} items left unwritten at the stop'
                                                if left else ''))
