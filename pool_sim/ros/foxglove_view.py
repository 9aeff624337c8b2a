"""A live view of the pool in Foxglove: a foxglove-sdk WebSocket server (subprotocol
foxglove.sdk.v1) with the 3D scene (spheres, pool edges, water) and the node's topics as
raw ROS 2 channels (cdr messages, ros2msg schemas) for the Plot and Raw Messages panels.

The node's clock thread only copies the spheres' positions and radii and hands them over
(published(), under the node's lock); a thread of the view's own encodes and logs. A busy
view thread, a slow client or one that never reads never holds the clock: an instant still
waiting when the next comes is replaced by it and counted as dropped, the 3D scene goes out
at most max_rate_hz (wall), and the SDK keeps at most MESSAGE_BACKLOG messages per client,
dropping the oldest data messages when a client does not read (it does not say how many;
a client whose control messages back up is disconnected).
"""
import sys
import threading
import time
from typing import NamedTuple

import numpy as np

from pool_sim.physics import InvalidInput
from pool_sim.ros.foxglove_scene import SphereScene
from pool_sim.ros.headless_topics import node_topic
from pool_sim.ros.message_definitions import definition_of
from pool_sim.ros.messages import (pool_edges, POOL_EDGE_RGBA, POOL_EDGE_WIDTH_M, water_box,
                                   water_top, WATER_RGBA)

INSTALL_COMMAND = 'pip install foxglove-sdk==0.30.3'
DEFAULT_MAX_RATE_HZ = 30.0  # wall Hz of the 3D scene
# Messages the SDK queues per client before it drops the oldest: a client that stops reading
# holds at most this many (a 10 000-sphere scene frame is 1.1 MB; the SDK's default, 1 024,
# would let one stalled client hold more than a gigabyte).
MESSAGE_BACKLOG = 32
SCENE_TOPIC = 'scene'  # the node's private name of the SceneUpdate channel


class PoolGeometry(NamedTuple):
    """What the pool and water entity is drawn from (fixed while the node runs)."""
    corner_min: tuple  # (x, y, z) m
    corner_max: tuple  # (x, y, z) m
    water_top_m: float  # the surface, clipped to the pool
    frame_id: str

    @classmethod
    def of(cls, simulation, scene):
        pool = simulation.environment.pool
        low, high = pool.corner_min.tolist(), pool.corner_max.tolist()
        return cls(tuple(low), tuple(high), water_top(low, high, scene['water.surface_z']),
                   scene['frame_id'])


def import_foxglove():
    """foxglove-sdk, imported only when a view starts; refused naming the install command
    without it."""
    try:
        import foxglove
        import foxglove.messages  # noqa: F401 (the schemas' module)
    except ImportError as error:
        raise InvalidInput(f'the Foxglove view needs foxglove-sdk ({error}); install it with '
                           f'`{INSTALL_COMMAND}`') from None
    return foxglove


def pool_update(foxglove, geometry: PoolGeometry) -> bytes:
    """A SceneUpdate of the pool's twelve edges and the translucent water (entities 'pool'
    and 'water', lifetime 0: they stay until replaced)."""
    messages = foxglove.messages
    low, high = geometry.corner_min, geometry.corner_max
    points = [messages.Point3(x=x, y=y, z=z) for x, y, z in pool_edges(low, high)]
    edges = messages.LinePrimitive(type=messages.LinePrimitiveLineType.LineList,
                                   thickness=POOL_EDGE_WIDTH_M, scale_invariant=False,
                                   points=points, color=_colour(messages, POOL_EDGE_RGBA))
    (x, y, z), (width, depth, height) = water_box(low, high, geometry.water_top_m)
    centre = messages.Vector3(x=x, y=y, z=z)
    water = messages.CubePrimitive(
        pose=messages.Pose(position=centre, orientation=messages.Quaternion(w=1.0)),
        size=messages.Vector3(x=width, y=depth, z=height),
        color=_colour(messages, WATER_RGBA))
    return messages.SceneUpdate(entities=[
        messages.SceneEntity(id='pool', frame_id=geometry.frame_id, lines=[edges]),
        messages.SceneEntity(id='water', frame_id=geometry.frame_id, cubes=[water]),
    ]).encode()


def _colour(messages, rgba):
    red, green, blue, alpha = rgba
    return messages.Color(r=red, g=green, b=blue, a=alpha)


class _Instant(NamedTuple):
    stamp_ns: int  # simulated ns
    position: np.ndarray  # (3, n) m, a copy
    radius: np.ndarray  # (n,) m, a copy


class FoxgloveView:
    """The Foxglove WebSocket server on host:port (0: any free one; `port` is the one in
    use), showing `geometry` (PoolGeometry) and whatever published() hears. log(line):
    where the start line goes. scene_topic: the SceneUpdate channel's name."""

    def __init__(self, port, host, geometry, scene_topic, log=print,
                 max_rate_hz=DEFAULT_MAX_RATE_HZ):
        foxglove = import_foxglove()
        self.host, self.min_scene_period_s = host, 1.0 / max_rate_hz
        self.context = foxglove.Context()
        self._foxglove = foxglove
        self.subscriptions = set()  # (client id, channel id), as the server tells them
        self.frames_sent = self.dropped = self.bytes_sent = 0
        self._ready = threading.Condition()
        self._waiting_messages = {}  # topic -> (message type, CDR bytes, stamp ns)
        self._waiting_instant = None  # _Instant
        self._pool_wanted = True
        self._last_stamp_ns = 0  # the newest instant heard, simulated ns
        self._running, self._closed = True, False
        try:
            self.server = foxglove.start_server(
                name='pool_sim', host=host, port=port, context=self.context,
                server_listener=_Subscriptions(self), message_backlog_size=MESSAGE_BACKLOG)
        except (RuntimeError, OverflowError, ValueError, TypeError) as error:
            raise InvalidInput(f'foxglove_host {host!r}, foxglove_port {port}: cannot serve '
                               f'the Foxglove view there ({error})') from None
        self.port = self.server.port
        # An IPv6 address goes in brackets in a URL (ws://[::1]:8765).
        self.url = f'ws://{f"[{host}]" if ":" in host else host}:{self.port}'
        self.scene_channel = foxglove.Channel(
            scene_topic, message_encoding='protobuf',
            schema=foxglove.messages.SceneUpdate.get_schema(), context=self.context)
        self.raw_channels = {}  # topic -> foxglove.Channel, made on first sight
        self.pool_update = pool_update(foxglove, geometry)
        self.spheres = SphereScene(geometry.frame_id)
        self.thread = threading.Thread(target=self._run, name='pool_sim_foxglove',
                                       daemon=True)
        self.thread.start()
        log(f'foxglove: serving the pool on {self.url} (open it in Foxglove: '
            'Open connection -> Foxglove WebSocket)')

    # -- factories ---------------------------------------------------------------------------

    @classmethod
    def for_node(cls, node, **kwargs):
        """A view of `node` (a PoolSimNode, its simulation built) on its foxglove_host and
        foxglove_port, hearing every instant it publishes, its counts on the status line."""
        scene = node.scene
        logger = node.get_logger()
        view = cls(scene['foxglove_port'], scene['foxglove_host'],
                   PoolGeometry.of(node.simulation, scene),
                   f'{node.get_fully_qualified_name()}/{SCENE_TOPIC}', log=logger.info,
                   **kwargs)
        node.publishing.listen(view.published)
        node.clock.reports.append(view.report)
        return view

    @classmethod
    def for_headless(cls, topics, simulation, port, host='127.0.0.1', **kwargs):
        """A view of a HeadlessTopics (topics) running `simulation`; logs to stderr."""
        view = cls(port, host, PoolGeometry.of(simulation, topics.scene),
                   node_topic('pool_sim', SCENE_TOPIC),
                   log=lambda line: print(line, file=sys.stderr, flush=True), **kwargs)
        topics.listen(view.published)
        return view

    # -- the clock thread's side -------------------------------------------------------------

    def published(self, published):
        """A publishing listener (node's lock held, clock thread): copy, hand over, return."""
        instant = None
        if published.spheres is not None:  # the core's live arrays: copy now
            spheres = published.spheres
            instant = _Instant(published.stamp_ns, spheres.position.copy(),
                               spheres.radius.copy())
        with self._ready:
            if published.stamp_ns < self._last_stamp_ns:
                # Time went back (a reset): Foxglove clears its scene, so draw the pool anew.
                self._pool_wanted = True
            self._last_stamp_ns = published.stamp_ns
            if instant is not None:
                if self._waiting_instant is not None:
                    self.dropped += 1
                self._waiting_instant = instant
            for topic, message_type, data in published.messages:
                self._waiting_messages[topic] = (message_type, data, published.stamp_ns)
            self._ready.notify()

    # -- the view's thread -------------------------------------------------------------------

    def _run(self):
        unshown = None  # the newest instant not drawn yet (the scene's rate held it)
        next_scene_wall = 0.0
        while True:
            with self._ready:
                while self._running and not (self._waiting_messages or self._pool_wanted
                                             or self._waiting_instant is not None):
                    wait_s = None if unshown is None else next_scene_wall - time.monotonic()
                    if wait_s is not None and wait_s <= 0:
                        break
                    self._ready.wait(wait_s)
                if not self._running:
                    return
                messages, self._waiting_messages = self._waiting_messages, {}
                instant, self._waiting_instant = self._waiting_instant, None
                pool_wanted, self._pool_wanted = self._pool_wanted, False
            self._log_raw(messages)
            if pool_wanted:
                self._log(self.scene_channel, self.pool_update, self._last_stamp_ns)
            unshown = instant or unshown
            if unshown is not None and time.monotonic() >= next_scene_wall:
                if self.scene_channel.has_sinks():
                    self._log(self.scene_channel, self.spheres.encode(*unshown),
                              unshown.stamp_ns)
                    self.frames_sent += 1
                unshown, next_scene_wall = None, time.monotonic() + self.min_scene_period_s

    def _log_raw(self, messages):
        for topic, (message_type, data, stamp_ns) in messages.items():
            channel = self.raw_channels.get(topic)
            if channel is None:
                definition = definition_of(message_type)
                channel = self.raw_channels[topic] = self._foxglove.Channel(
                    topic, message_encoding='cdr', context=self.context,
                    schema=self._foxglove.Schema(name=definition.name, encoding='ros2msg',
                                                 data=definition.text.encode()))
            if channel.has_sinks():
                self._log(channel, data, stamp_ns)

    def _log(self, channel, data, stamp_ns):
        # Log time: the instant's simulated ns, as the messages' stamps (None: now).
        channel.log(data, log_time=stamp_ns)
        self.bytes_sent += len(data)

    # -- the server's side (its own threads) -------------------------------------------------

    def subscribed(self, client_id, channel_id):
        with self._ready:
            self.subscriptions.add((client_id, channel_id))
            if channel_id == self.scene_channel.id():
                self._pool_wanted = True  # a new scene client has no pool yet
                self._ready.notify()

    def unsubscribed(self, client_id, channel_id):
        with self._ready:
            self.subscriptions.discard((client_id, channel_id))

    # -- status and end ----------------------------------------------------------------------

    def report(self) -> str:
        """The status line's words: clients subscribed, scene frames sent, instants dropped."""
        with self._ready:
            clients = len({client for client, _ in self.subscriptions})
        return (f'foxglove {self.url}: {clients} '
                f'client{"" if clients == 1 else "s"}, {self.frames_sent} frames sent, '
                f'{self.dropped} dropped, {self.bytes_sent / 1e6:.1f} MB out')

    def close(self):
        """Stop the thread and the server (again: nothing)."""
        with self._ready:
            if self._closed:
                return
            self._closed, self._running = True, False
            self._ready.notify()
        self.thread.join(timeout=5.0)
        self.server.stop()


class _Subscriptions:
    """The server's listener (foxglove.websocket.ServerListener): who is subscribed to what,
    and a new scene subscriber gets the pool."""

    def __init__(self, view):
        self.view = view

    def on_subscribe(self, client, channel):
        self.view.subscribed(client.id, channel.id)

    def on_unsubscribe(self, client, channel):
        self.view.unsubscribed(client.id, channel.id)
