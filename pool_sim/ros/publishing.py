"""The node's outputs: the state of each published instant on every state topic, per-sphere
odometry on a sender thread of its own, the pool's scene markers, /clock; and listeners that
hear each instant published (a recorder, a live viewer, the status line)."""
import threading
import time
from typing import NamedTuple

from geometry_msgs.msg import PoseArray
from nav_msgs.msg import Odometry
from rclpy.event_handler import PublisherEventCallbacks
from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy
from rclpy.serialization import serialize_message
from rosgraph_msgs.msg import Clock as ClockMessage
from std_msgs.msg import Float64MultiArray
from visualization_msgs.msg import MarkerArray

from pool_sim.ros.messages import scene_markers, SphereMessages, stamp_nanoseconds, stamp_of
from pool_sim.ros.services import THROTTLE_S

# The state topics keep their last message for subscribers that join later (a new RViz,
# `ros2 topic echo --once` while paused).
STATE_QOS = QoSProfile(depth=1, durability=DurabilityPolicy.TRANSIENT_LOCAL,
                       reliability=ReliabilityPolicy.RELIABLE)
# Per-sphere odometry goes out in chunks on its own thread, taking at most this share of
# the wall time (see OdometrySender).
ODOMETRY_CHUNK = 100
ODOMETRY_SHARE = 0.4
# Wall s between two looks at which spheres' odometry has subscribers.
LISTENER_CHECK_S = 0.5


class Published(NamedTuple):
    """What went out at one instant of simulated time, as listeners hear it."""
    time_s: float  # simulated s
    stamp_ns: int  # the messages' stamp, ns of simulated time
    messages: tuple  # ((fully qualified topic, message type, serialized CDR bytes), ...)
    # A state instant: the core's Spheres it was filled from (names, position, velocity,
    # radius, ...), live arrays: copy what you keep before the call returns. None for /clock
    # and the scene markers.
    spheres: object = None
    # True for the instant published last sent again unchanged, for subscribers that joined
    # late (a recorder keeps it once).
    again: bool = False


def scene_markers_instant(topic, simulation, scene) -> Published:
    """The pool and the water as `topic` publishes them, serialized, at the simulation's
    time (the node's and headless's alike)."""
    data = serialize_message(scene_markers(simulation.environment.pool,
                                           scene['water.surface_z'], scene['frame_id']))
    return Published(simulation.time, stamp_nanoseconds(simulation.time),
                     ((topic, MarkerArray, data),))


def clock_instant(topic, simulated_s) -> Published:
    """/clock at simulated_s, serialized once for DDS and the listeners alike."""
    data = serialize_message(ClockMessage(clock=stamp_of(simulated_s)))
    return Published(simulated_s, stamp_nanoseconds(simulated_s),
                     ((topic, ClockMessage, data),))


class StatePublishing:
    """The publishers of `node` and what they send; the node's scene and simulation are read
    at each publish. lockstep: the node's Lockstep (in lockstep every controller gets every
    instant, before the wait). inputs: the ForceInputs, told each instant before it is out
    (an unstamped answer to it comes after)."""

    def __init__(self, node, lockstep, inputs):
        self.node, self.lockstep, self.inputs = node, lockstep, inputs
        scene = node.scene
        self.per_sphere = scene['per_sphere_topics']
        self.messages = SphereMessages(scene.sphere_names, scene['frame_id'],
                                       odometry=self.per_sphere)
        self.poses = node.create_publisher(PoseArray, '~/poses', STATE_QOS)
        self.markers = node.create_publisher(MarkerArray, '~/markers', STATE_QOS)
        self.states = node.create_publisher(Float64MultiArray, '~/states', STATE_QOS)
        self.scene_markers = node.create_publisher(MarkerArray, '~/scene_markers', STATE_QOS)
        self.odometry = {}  # sphere name -> its Odometry publisher
        self.add_spheres(scene.sphere_names)
        self.clock = (node.create_publisher(ClockMessage, '/clock', 10)
                      if scene['publish_clock'] else None)
        self.listeners = []
        self.publishes = 0  # instants published, across resets
        self.last_publish_wall = time.monotonic()  # when the state last went out
        self.last_instant_s = None  # the simulated time it carried
        # Wall seconds spent filling messages and sending them, for the status line.
        self.time_spent = {'build': 0.0, 'publish': 0.0}
        self.next_listener_check, self.odometry_wanted = 0.0, []
        # Last: a thread of its own, which destroy() stops once the node has this object.
        self.odometry_sender = OdometrySender(node.get_logger())

    def listen(self, listener):
        """Call listener(Published) after each publish, on the thread publishing it (the
        clock's, or a service's), under the node's lock: keep it short. A state instant
        carries the state topics (and odometry where sent) and the spheres; /clock and the
        scene markers come as a Published of their own. A state sent again (a republish for
        late subscribers) is heard again."""
        self.listeners.append(listener)

    def destroy(self):
        self.odometry_sender.stop()

    # -- spheres come and go -----------------------------------------------------------------

    def add_spheres(self, names):
        if not self.per_sphere:
            return
        no_default_events = PublisherEventCallbacks(use_default_callbacks=False)
        for name in names:
            # Transient-local as the other state topics: a controller that starts after
            # the node still gets the instant lockstep waits for it to answer.
            self.odometry[name] = self.node.create_publisher(
                Odometry, f'~/{name}/odom', STATE_QOS, event_callbacks=no_default_events)

    def change_spheres(self, removed, added):
        """Spawn and remove: odometry publishers follow, messages are sized anew."""
        for name in removed:
            publisher = self.odometry.pop(name, None)
            if publisher is not None:
                self.node.destroy_publisher(publisher)
        self.add_spheres(added)
        scene = self.node.scene
        self.messages = SphereMessages(scene.sphere_names, scene['frame_id'],
                                       odometry=self.per_sphere)
        self.next_listener_check = 0.0

    # -- publishing --------------------------------------------------------------------------

    def publish_scene_markers(self):
        """The pool and the water, once (transient-local keeps them for late joiners); the
        listeners hear them too."""
        instant = scene_markers_instant(self.scene_markers.topic_name, self.node.simulation,
                                        self.node.scene)
        self.scene_markers.publish(instant.messages[0][2])
        self._tell(instant)

    def publish_clock(self):
        """/clock at the simulation's time, when the scene asks for it."""
        if self.clock is None:
            return
        instant = clock_instant(self.clock.topic_name, self.node.simulation.time)
        self.clock.publish(instant.messages[0][2])
        self._tell(instant)

    def publish_state(self, new_listeners=False):
        """The present instant on every state topic (and odometry where listened to).
        new_listeners: look again now for odometry subscribers (a republish for late
        joiners)."""
        if new_listeners:
            self.next_listener_check = 0.0
        started = time.perf_counter()
        simulation = self.node.simulation
        spheres = simulation.spheres
        wanted = self._odometry_listened_to()
        if self.lockstep.enabled and self.per_sphere:
            # A controller that has not matched yet gets it too (transient-local).
            listed = {spheres.index[name] for name in self.lockstep.inputs
                      if name in spheres.index}
            wanted = sorted(listed.union(wanted)) if listed else wanted
        self.messages.fill(simulation.time, spheres.position, spheres.velocity,
                           spheres.radius, wanted)
        built = time.perf_counter()
        instant_ns = stamp_nanoseconds(simulation.time)
        self.inputs.publishing(instant_ns)
        sent = ((self.poses, PoseArray, self.messages.poses.to_bytes()),
                (self.markers, MarkerArray, self.messages.markers.to_bytes()),
                (self.states, Float64MultiArray, self.messages.states_bytes()))
        for publisher, _, data in sent:
            publisher.publish(data)
        odometry = [(self.odometry[spheres.names[i]], self.messages.odometry_bytes(i))
                    for i in wanted]
        if odometry and self.lockstep.enabled:
            # Every instant to every controller, before the wait: none may be left out.
            for publisher, message in odometry:
                publisher.publish(message)
        elif odometry:
            self.odometry_sender.send(odometry)
        if self.lockstep.enabled:
            self.lockstep.published(instant_ns)
        self.time_spent['build'] += built - started
        self.time_spent['publish'] += time.perf_counter() - built
        self.publishes += 1
        self.last_publish_wall, self.last_instant_s = time.monotonic(), simulation.time
        self._tell(Published(simulation.time, instant_ns, tuple(
            [(publisher.topic_name, kind, data) for publisher, kind, data in sent]
            + [(publisher.topic_name, Odometry, data) for publisher, data in odometry]),
            spheres, new_listeners))

    def _tell(self, published):
        for listener in self.listeners:
            listener(published)

    def _odometry_listened_to(self):
        """Indices of spheres whose odometry has subscribers, looked up every half wall
        second: odometry is a message per sphere, filled only where someone listens."""
        now = time.monotonic()
        if now >= self.next_listener_check:
            self.next_listener_check = now + LISTENER_CHECK_S
            publishers = self.odometry
            self.odometry_wanted = [
                i for i, name in enumerate(self.node.simulation.spheres.names)
                if name in publishers and publishers[name].get_subscription_count() > 0]
        return self.odometry_wanted


class OdometrySender:
    """Publishes the per-sphere odometry on a thread of its own, the newest set only.

    A message per sphere is the one output whose cost grows with the subscribers: DDS
    delivers each at ~20 us, so 1 000 listened-to spheres at 30 Hz would take the clock
    more than half its time (measured: real-time factor 0.38). Here the clock hands each
    publish's messages over and goes on; a set still waiting when the next comes is
    replaced by it (counted in `dropped`), so slow subscribers get fewer, newer messages and
    the clock loses nothing.
    """

    def __init__(self, logger):
        self.logger = logger
        self.waiting = None  # [(publisher, serialized Odometry)] of the newest publish
        self.dropped = 0
        self.running = True
        self.ready = threading.Condition()
        self.thread = threading.Thread(target=self._run, name='pool_sim_odometry',
                                       daemon=True)
        self.thread.start()

    def send(self, messages):
        with self.ready:
            if self.waiting is not None:
                self.dropped += 1
            self.waiting = messages
            self.ready.notify()

    def _run(self):
        while True:
            with self.ready:
                while self.running and self.waiting is None:
                    self.ready.wait()
                if not self.running:
                    return
                messages, self.waiting = self.waiting, None
            for first in range(0, len(messages), ODOMETRY_CHUNK):
                started = time.perf_counter()
                for publisher, message in messages[first:first + ODOMETRY_CHUNK]:
                    try:
                        publisher.publish(message)
                    except Exception as error:  # its sphere removed meanwhile, or stopping
                        if self.running:
                            self.logger.warning(f'odometry not sent: {error}',
                                                throttle_duration_sec=THROTTLE_S)
                # rclpy holds the interpreter while it publishes: rest in proportion, so
                # the clock thread always has the interpreter when it needs it.
                busy = time.perf_counter() - started
                time.sleep(busy * (1.0 - ODOMETRY_SHARE) / ODOMETRY_SHARE)

    def stop(self):
        with self.ready:
            self.running = False
            self.ready.notify()
        self.thread.join(timeout=5.0)
