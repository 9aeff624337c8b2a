"""External forces into the simulation: every input topic, one way in.

- `~/wrench` (WrenchStamped): the sphere named by header.frame_id, any number of publishers;
- `~/forces` (Float64MultiArray): every sphere at once, n x 3 N in sphere_names order;
- `~/<sphere>/wrench` (Wrench): one sphere, while per_sphere_topics is on.

Callbacks run on the executor's thread and only record the message (the latest per sphere,
the latest array); the clock thread applies them, in the order they came, at the start of
its next tick. Every input is checked alike (finite, within the force range) and refreshes
the sphere's wrench timeout alike.

For lockstep each input also records the newest publish instant it answered: a
WrenchStamped its header's stamp, when that is no later than the instant published last (a
later stamp answers nothing: a wall-clock stamp, or an answer from before a reset, in
flight); an unstamped message (Wrench, the ~/forces array) the instant published last
before it arrived. Only the inputs lockstep can wait for (the spheres, and ~/forces) are
recorded, whatever frame_ids a client sends.
"""
from functools import partial
import math
import threading
from typing import NamedTuple

import numpy as np
from geometry_msgs.msg import Wrench, WrenchStamped
from rclpy.event_handler import SubscriptionEventCallbacks
from std_msgs.msg import Float64MultiArray

from pool_sim.physics import InvalidInput
from pool_sim.physics.spheres import shortened
from pool_sim.ros.messages import stamp_nanoseconds
from pool_sim.ros.node_keys import FORCES_INPUT
from pool_sim.ros.services import THROTTLE_S
ALL_SPHERES = object()  # the pending key of a ~/forces array


class Applied(NamedTuple):
    """An input the node applied, as its listeners hear it."""
    received_ns: int  # when it came, in ns of simulated time (the simulation's time then)
    topic: str  # the fully qualified topic it came on
    message_type: type
    message: object  # the message as received (read it, never change it)


class Pending(NamedTuple):
    """An input waiting for the next tick."""
    value: object  # what is applied: a Wrench, or the ~/forces Float64MultiArray
    received: Applied  # None when nothing listened as it came


class ForceInputs:
    """The input subscriptions of `node` and the forces waiting for the next tick."""

    def __init__(self, node, names, per_sphere_topics, on_answer=None):
        """on_answer: called on the executor's thread after each message (lockstep wakes
        the clock with it)."""
        self.node = node
        self.lock = threading.Lock()
        self.pending = {}  # sphere name or ALL_SPHERES -> the latest message, arrival order
        # Input name (a sphere's, or FORCES_INPUT) -> the newest publish instant it answered,
        # in ns of simulated time; instant_ns: the instant published last (the node sets it).
        self.answered_ns = {}
        self.instant_ns = 0
        self.on_answer = on_answer
        self.spheres = set()  # the sphere names whose answers are recorded
        self.unstamped = {FORCES_INPUT}  # inputs whose last answer came unstamped
        self.warn_future = False  # in lockstep: say when a stamp answers nothing
        self.torque_warned = set()
        # Per-sphere topics without rclpy's default QoS-event handlers: each would be one
        # more waitable the executor walks on every wake-up.
        self.no_default_events = SubscriptionEventCallbacks(use_default_callbacks=False)
        self.listeners = []
        self.wrench_topic = node.create_subscription(
            WrenchStamped, '~/wrench', self._put_stamped, 100,
            event_callbacks=self.no_default_events).topic_name
        self.forces_topic = node.create_subscription(
            Float64MultiArray, '~/forces', self._put_forces, 10,
            event_callbacks=self.no_default_events).topic_name
        self.per_sphere_topics = per_sphere_topics
        self.per_sphere = {}
        # The wrench clock: when each sphere's force was last set (simulated s), in sphere
        # order; -inf for never, +inf once released by the timeout.
        self.set_at = np.full(len(names), -math.inf)
        self.add_spheres(names)

    # -- subscriptions -----------------------------------------------------------------------

    def add_spheres(self, names):
        with self.lock:
            self.spheres.update(names)
        if not self.per_sphere_topics:
            return
        for name in names:
            self.per_sphere[name] = self.node.create_subscription(
                Wrench, f'~/{name}/wrench',
                partial(self._put_wrench, name, self.node.resolve_topic_name(f'~/{name}/wrench')),
                10,
                event_callbacks=self.no_default_events)

    def remove_spheres(self, names):
        with self.lock:
            for name in names:
                self.pending.pop(name, None)
                self.answered_ns.pop(name, None)
                self.spheres.discard(name)
                self.unstamped.discard(name)
            self.pending.pop(ALL_SPHERES, None)  # sized for the old spheres
        for name in names:
            subscription = self.per_sphere.pop(name, None)
            if subscription is not None:
                self.node.destroy_subscription(subscription)

    def listen(self, listener):
        """Call listener(Applied) for each input applied, on the clock's thread at the tick
        that applies it, under the node's lock: keep it short. A message replaced by a newer
        one before the tick was never applied and is not heard; a refused one neither."""
        self.listeners.append(listener)

    def _put(self, key, value, received, stamp_ns=None):
        answering = FORCES_INPUT if key is ALL_SPHERES else key
        with self.lock:
            known = key is ALL_SPHERES or key in self.spheres
            self.pending.pop(key, None)  # re-inserted last: applied in arrival order
            self.pending[key] = Pending(value, received)
            future = stamp_ns is not None and stamp_ns > self.instant_ns
            if known and not future:
                if stamp_ns is None:
                    self.unstamped.add(answering)
                else:
                    self.unstamped.discard(answering)
                instant = self.instant_ns if stamp_ns is None else stamp_ns
                if instant > self.answered_ns.get(answering, -1):
                    self.answered_ns[answering] = instant
        if future and known and self.warn_future:
            self._warn(f'wrench for {answering}: stamped {stamp_ns * 1e-9:.9f} s, after the '
                       f'newest instant published ({self.instant_ns * 1e-9:.9f} s): no '
                       'answer to any instant (stamp an answer with the stamp of the state '
                       'it answers); its force applies')
        if self.on_answer is not None:
            self.on_answer()

    def _received(self, topic, message_type, message):
        """The Applied its listeners will hear, or None when none listens (no work on the
        executor's thread for a recording that is off)."""
        if not self.listeners:
            return None
        # Read without the node's lock: a float read whole, at most one tick stale.
        return Applied(stamp_nanoseconds(self.node.simulation.time), topic, message_type,
                       message)

    def _put_stamped(self, message):
        stamp = message.header.stamp
        self._put(message.header.frame_id, message.wrench,
                  self._received(self.wrench_topic, WrenchStamped, message),
                  stamp.sec * 1_000_000_000 + stamp.nanosec)

    def _put_wrench(self, name, topic, message):
        self._put(name, message, self._received(topic, Wrench, message))

    def _put_forces(self, message):
        self._put(ALL_SPHERES, message,
                  self._received(self.forces_topic, Float64MultiArray, message))

    def clear(self):
        """Forget what waits, what was answered and when forces were set (a reset: time
        starts again at 0)."""
        with self.lock:
            self.pending = {}
            self.answered_ns = {}
            self.instant_ns = 0
        self.set_at = np.full(self.set_at.size, -math.inf)

    def publishing(self, instant_ns):
        """The instant instant_ns (ns of simulated time) goes out now: an unstamped answer
        from here on answers it."""
        with self.lock:
            self.instant_ns = instant_ns

    def any_unstamped(self, names) -> bool:
        """True when one of `names` answers unstamped (~/forces, or its last answer)."""
        with self.lock:
            return not self.unstamped.isdisjoint(names)

    def unanswered(self, names, instant_ns):
        """The names of `names` that have not answered the instant instant_ns."""
        with self.lock:
            answered = self.answered_ns
            return [name for name in names if answered.get(name, -1) < instant_ns]

    def answered(self, name) -> int:
        """The newest instant (ns) input `name` answered; -1 for none."""
        with self.lock:
            return self.answered_ns.get(name, -1)

    # -- on the clock thread -----------------------------------------------------------------

    def apply(self, simulation):
        """Apply what came since the last tick, through the core's setters, and restart
        the wrench clock of each sphere it set."""
        with self.lock:
            pending, self.pending = self.pending, {}
        for key, (value, received) in pending.items():
            if key is ALL_SPHERES:
                applied = self._apply_forces(simulation, value)
            else:
                applied = self._apply_wrench(simulation, key, value)
            if applied and received is not None:
                for listener in self.listeners:
                    listener(received)

    def set_force(self, simulation, sphere, force):
        """Push a sphere (N, world axes) as an input message does: InvalidInput if the core
        refuses it; holds until replaced or until the wrench timeout."""
        index = simulation.spheres.lookup(sphere)
        simulation.set_external_force(sphere, force)
        self.set_at[index] = simulation.time

    def release_expired(self, simulation, timeout_s):
        """No force from now on on spheres whose last input is older than timeout_s."""
        if timeout_s > 0.0:
            expired = simulation.time - self.set_at > timeout_s
            if expired.any():
                simulation.release_external_forces(expired)
                self.set_at[expired] = math.inf

    def first_expiry(self, timeout_s) -> float:
        """Simulated s at which the next force times out (inf: none will)."""
        if timeout_s <= 0.0 or not self.set_at.size:
            return math.inf
        return float(np.min(self.set_at)) + timeout_s

    def follow_spheres(self, before, after):
        """After a spawn or remove: the clock of each kept sphere follows it from the names
        `before` to the names `after`."""
        set_at = dict(zip(before, self.set_at.tolist()))
        self.set_at = np.array([set_at.get(name, -math.inf) for name in after])

    def _warn(self, text):
        self.node.get_logger().warning(text, throttle_duration_sec=THROTTLE_S)

    def _apply_wrench(self, simulation, name, message):
        force = (message.force.x, message.force.y, message.force.z)
        try:
            self.set_force(simulation, name, force)
        except InvalidInput as error:
            self._warn(f'{shortened(name)}/wrench: refused: {error}; keeping the last')
            return False
        torque = (message.torque.x, message.torque.y, message.torque.z)
        if any(torque) and name not in self.torque_warned:
            self.torque_warned.add(name)
            self.node.get_logger().warning(
                f'{name}/wrench: torque {torque} ignored: a point mass cannot turn')
        return True

    def _apply_forces(self, simulation, message):
        try:
            simulation.set_external_forces(forces_of(message, simulation.spheres.count))
        except InvalidInput as error:
            self._warn(f'forces: refused: {error}; keeping the last')
            return False
        self.set_at[:] = simulation.time
        return True


def forces_of(message, count) -> np.ndarray:
    """The (count, 3) forces in N of a Float64MultiArray, or InvalidInput: n x 3 values in
    sphere_names order; a layout, when given, must say the same. The values are the core's
    to check (Simulation.set_external_forces)."""
    data = np.asarray(message.data, dtype=float)
    dims = [(d.size, d.stride) for d in message.layout.dim]
    expected = f'{count} x 3 = {3 * count} values (x, y, z per sphere in sphere_names order)'
    if data.size != 3 * count:
        raise InvalidInput(f'expected {expected}, got {data.size}')
    if message.layout.data_offset != 0 or (dims and [size for size, _ in dims] != [count, 3]):
        raise InvalidInput(f'expected {expected} with layout dim sizes [{count}, 3] '
                           f'(or no layout) and data_offset 0, got sizes '
                           f'{[size for size, _ in dims]}, data_offset '
                           f'{message.layout.data_offset}')
    return data.reshape(count, 3)
