"""The live view in Foxglove, through a real WebSocket client (subprotocol foxglove.sdk.v1):
the 3D scene's spheres where the simulation has them, the raw topics as ROS 2 messages, a
client that never reads costs the node nothing, and every way of starting it wrongly is
refused naming what to change."""
import json
import os
from pathlib import Path
import queue
import re
import signal
import socket
import struct
import subprocess
import sys
import threading
import time

from geometry_msgs.msg import PoseArray
import numpy as np
import pytest
import rclpy
from rclpy.context import Context
from rclpy.serialization import deserialize_message
from websockets.sync.client import connect

from pool_sim.physics import InvalidInput
from pool_sim.ros.foxglove_scene import SphereScene
from pool_sim.ros.foxglove_view import FoxgloveView, INSTALL_COMMAND, PoolGeometry
from pool_sim.ros.messages import sphere_colours, stamp_nanoseconds
from pool_sim.ros.simulator_node import PoolSimNode
from pool_sim.testing import PoolSim
from ros_harness import Harness, overrides

REPO = Path(__file__).resolve().parents[1]
ENV = {**os.environ, 'PYTHONPATH': str(REPO)}
MESSAGE_DATA = 0x01  # the binary opcode of a message


# -- a Foxglove client, as the app speaks to the server ------------------------------------

class FoxgloveClient:
    """Connects to ws://127.0.0.1:port; subscribe(topics) once they are advertised;
    received(topic) -> [(log time ns, payload bytes)] read so far."""

    def __init__(self, port):
        self.socket = connect(f'ws://127.0.0.1:{port}', subprotocols=['foxglove.sdk.v1'],
                              max_size=None, open_timeout=5, close_timeout=1)
        self.channels = {}  # topic -> its advertised channel (dict)
        self.topic_of_subscription = {}
        self.messages = {}  # topic -> [(log time ns, payload)]

    def __enter__(self):
        self.socket.__enter__()
        return self

    def __exit__(self, *exc):
        self.socket.__exit__(*exc)

    def read(self, until, timeout_s=5.0):
        """Read frames until until() holds; False if it did not in time."""
        deadline = time.monotonic() + timeout_s
        while not until():
            left = deadline - time.monotonic()
            if left <= 0:
                return False
            try:
                frame = self.socket.recv(timeout=left)
            except TimeoutError:
                return False
            if isinstance(frame, str):
                message = json.loads(frame)
                if message['op'] == 'advertise':
                    self.channels.update({channel['topic']: channel
                                          for channel in message['channels']})
            elif frame[0] == MESSAGE_DATA:
                subscription, log_time = struct.unpack_from('<IQ', frame, 1)
                topic = self.topic_of_subscription[subscription]
                self.messages.setdefault(topic, []).append((log_time, frame[13:]))
        return True

    def subscribe(self, topics):
        assert self.read(lambda: all(topic in self.channels for topic in topics)), \
            (topics, list(self.channels))
        subscriptions = []
        for topic in topics:
            subscription = len(self.topic_of_subscription) + 1
            self.topic_of_subscription[subscription] = topic
            subscriptions.append({'id': subscription, 'channelId': self.channels[topic]['id']})
        self.socket.send(json.dumps({'op': 'subscribe', 'subscriptions': subscriptions}))

    def received(self, topic):
        return self.messages.get(topic, [])


# -- protobuf, read by hand (no protobuf package in the venv) ------------------------------

def _varint(data, at):
    value = shift = 0
    while True:
        byte = data[at]
        at += 1
        value |= (byte & 0x7F) << shift
        shift += 7
        if byte < 0x80:
            return value, at


def protobuf_fields(data):
    """field number -> [values]: ints (varint), floats (fixed64 as double), bytes (length
    delimited)."""
    fields, at = {}, 0
    while at < len(data):
        key, at = _varint(data, at)
        wire_type = key & 7
        if wire_type == 0:
            value, at = _varint(data, at)
        elif wire_type == 1:
            value, at = struct.unpack_from('<d', data, at)[0], at + 8
        elif wire_type == 2:
            length, at = _varint(data, at)
            value, at = bytes(data[at:at + length]), at + length
        else:
            raise ValueError(f'wire type {wire_type}')
        fields.setdefault(key >> 3, []).append(value)
    return fields


def _numbers(message, count):
    """Fields 1 .. count of a Vector3, Quaternion or Color (an absent one is 0)."""
    fields = protobuf_fields(message)
    return [fields.get(field, [0.0])[0] for field in range(1, count + 1)]


def scene_entities(payload):
    """A SceneUpdate's entities: id -> {field number: [values]}."""
    entities = [protobuf_fields(entity) for entity in protobuf_fields(payload).get(2, [])]
    return {entity[3][0].decode(): entity for entity in entities}


def spheres_of(entity):
    """(position (3, n), diameter (n,), rgba (n, 4)) of a SceneEntity's spheres."""
    positions, diameters, colours = [], [], []
    for record in entity.get(9, []):
        sphere = protobuf_fields(record)
        pose = protobuf_fields(sphere[1][0])
        positions.append(_numbers(pose[1][0], 3))
        diameters.append(_numbers(sphere[2][0], 3))
        colours.append(_numbers(sphere[3][0], 4))
    return np.array(positions).T, np.array(diameters), np.array(colours)


# -- the scene's encoding ------------------------------------------------------------------

def test_the_spheres_are_the_bytes_the_sdks_own_encoder_writes():
    from foxglove.messages import (Color, Pose, Quaternion, SceneEntity, SceneUpdate,
                                   SpherePrimitive, Timestamp, Vector3)
    rng = np.random.default_rng(1)
    position, radius = rng.uniform(0.1, 3.0, (3, 5)), rng.uniform(0.05, 0.2, 5)
    colours = sphere_colours(5)
    spheres = [SpherePrimitive(
        pose=Pose(position=Vector3(x=x, y=y, z=z), orientation=Quaternion(w=1.0)),
        size=Vector3(x=2 * r, y=2 * r, z=2 * r),
        color=Color(r=rgba[0], g=rgba[1], b=rgba[2], a=rgba[3]))
        for x, y, z, r, rgba in zip(*position, radius, colours)]
    sdk = SceneUpdate(entities=[SceneEntity(
        id='spheres', frame_id='world', timestamp=Timestamp(sec=3, nsec=5),
        spheres=spheres)]).encode()
    assert SphereScene('world').encode(3_000_000_005, position, radius) == sdk


# -- through a real client -----------------------------------------------------------------

def test_a_client_sees_the_pool_and_every_sphere_where_the_simulation_has_it():
    with PoolSim({'foxglove_port': 0, 'per_sphere_topics': False}, lockstep=False) as ros:
        node = ros.node
        view = node.live_view
        prefix = node.get_fully_qualified_name()
        scene_topic, poses_topic = f'{prefix}/scene', f'{prefix}/poses'
        with FoxgloveClient(view.port) as client:
            client.subscribe([scene_topic, poses_topic])
            # A new subscriber gets the pool and the water first.
            def pool_updates():
                return [entities for entities in (scene_entities(payload) for _, payload
                                                  in client.received(scene_topic))
                        if 'pool' in entities]
            assert client.read(pool_updates)
            pool = pool_updates()[0]
            assert len(protobuf_fields(pool['pool'][11][0])[5]) == 24  # 12 edges' ends
            water = protobuf_fields(pool['water'][8][0])
            low, high = (node.simulation.environment.pool.corner_min,
                         node.simulation.environment.pool.corner_max)
            water_top = min(max(node.scene['water.surface_z'], low[2]), high[2])
            assert _numbers(water[2][0], 3) == pytest.approx(
                [high[0] - low[0], high[1] - low[1], water_top - low[2]])
            for _ in range(3):
                node.advance()
            with node.lock():
                position = node.simulation.spheres.position.copy()
                radius = node.simulation.spheres.radius.copy()
                stamp_ns = stamp_nanoseconds(node.simulation.time)

            def at_instant(topic):
                return [payload for log_time, payload in client.received(topic)
                        if log_time == stamp_ns]
            assert client.read(lambda: at_instant(scene_topic) and at_instant(poses_topic))
            entity = scene_entities(at_instant(scene_topic)[0])['spheres']
            assert entity[2][0].decode() == node.scene['frame_id']
            shown, diameter, colour = spheres_of(entity)
            assert shown == pytest.approx(position, abs=1e-12)
            assert diameter == pytest.approx(np.column_stack([2 * radius] * 3))
            assert colour == pytest.approx(sphere_colours(3))
            poses = deserialize_message(at_instant(poses_topic)[0], PoseArray)
            assert [[pose.position.x, pose.position.y, pose.position.z]
                    for pose in poses.poses] == position.T.tolist()
            channel = client.channels[poses_topic]
            assert (channel['encoding'], channel['schemaName'], channel['schemaEncoding']) \
                == ('cdr', 'geometry_msgs/msg/PoseArray', 'ros2msg')
            assert re.fullmatch(r'foxglove ws://127\.0\.0\.1:\d+: 1 client, \d+ frames sent, '
                                r'\d+ dropped, [\d.]+ MB out', view.report())
        view.close()
        view.close()  # again: nothing


def many_spheres(count):
    rng = np.random.default_rng(count)
    return {'sphere_names': [f's{i}' for i in range(count)], 'per_sphere_topics': False,
            'spheres.position': rng.uniform(-3.5, 3.5, (count, 3)).ravel().tolist(),
            'spheres.radius': [0.05] * count}


def test_a_client_that_never_reads_does_not_slow_the_node():
    with Harness({**many_spheres(1000), 'foxglove_port': 0}) as ros:
        prefix = ros.sim.get_fully_qualified_name()
        with FoxgloveClient(ros.sim.live_view.port) as client:
            topics = [f'{prefix}/{name}' for name in ('scene', 'poses', 'markers', 'states')]
            client.subscribe(topics)  # and from now on reads nothing
            ros.spin_for(0.5)  # the socket's buffers fill
            with ros.sim.lock():
                started_wall, started_s = time.monotonic(), ros.sim.simulation.time
            ros.spin_for(3.0)
            with ros.sim.lock():
                simulated_s = ros.sim.simulation.time - started_s
                wall_s = time.monotonic() - started_wall
            assert simulated_s / wall_s >= 0.95, (simulated_s, wall_s,
                                                  ros.sim.live_view.report())
            assert ros.sim.live_view.report().split(': ')[1].startswith('1 client')


# -- refusals ------------------------------------------------------------------------------

def test_without_foxglove_sdk_the_view_is_refused_naming_the_install_command(monkeypatch):
    monkeypatch.setitem(sys.modules, 'foxglove', None)
    geometry = PoolGeometry((-1.0, -1.0, -1.0), (1.0, 1.0, 1.0), 0.0, 'world')
    with pytest.raises(InvalidInput, match=re.escape(INSTALL_COMMAND)):
        FoxgloveView(0, '127.0.0.1', geometry, '/pool_sim/scene')


@pytest.mark.parametrize('key, value', [
    ('foxglove_port', -2), ('foxglove_port', 70000), ('foxglove_port', 8765.0),
    ('foxglove_port', 'abc'), ('foxglove_port', ''), ('foxglove_port', True),
    ('foxglove_host', ''),
])
def test_a_bad_foxglove_parameter_stops_the_node_naming_it(key, value):
    context = Context()
    rclpy.init(context=context)
    try:
        with pytest.raises(InvalidInput, match=key):
            PoolSimNode(context=context, parameter_overrides=overrides({key: value}),
                        node_name=f'bad_foxglove_{abs(hash((key, repr(value))))}')
    finally:
        rclpy.shutdown(context=context)


class Process:
    """A `python -m ...` process; its output lines read by a thread of their own."""

    def __init__(self, *arguments):
        self.process = subprocess.Popen([sys.executable, '-m', *arguments], env=ENV,
                                        stdout=subprocess.PIPE, stderr=subprocess.STDOUT,
                                        text=True)
        self.lines, self.output = queue.Queue(), []
        threading.Thread(target=self._read, daemon=True).start()

    def _read(self):
        for line in self.process.stdout:
            self.lines.put(line)

    def wait_for(self, pattern, timeout_s=30.0):
        """The first match of pattern in a line to come; None if none came in time."""
        deadline = time.monotonic() + timeout_s
        while time.monotonic() < deadline:
            try:
                line = self.lines.get(timeout=max(deadline - time.monotonic(), 0.01))
            except queue.Empty:
                break
            self.output.append(line)
            match = re.search(pattern, line)
            if match:
                return match
        return None

    def finish(self, timeout_s=30.0):
        try:
            self.process.wait(timeout=timeout_s)
        except subprocess.TimeoutExpired:
            self.process.kill()
            self.process.wait()
        time.sleep(0.1)  # the reader's last lines
        while not self.lines.empty():
            self.output.append(self.lines.get())
        return self.process.returncode, ''.join(self.output)


SERVING = r'foxglove: serving the pool on ws://127\.0\.0\.1:(\d+) '


def test_the_node_on_port_0_serves_on_a_free_port_it_logs_and_a_port_in_use_exits_1():
    with socket.socket() as taken:
        taken.bind(('127.0.0.1', 0))
        taken.listen()
        busy_port = taken.getsockname()[1]
        refused = Process('pool_sim', '--ros-args', '-p', f'foxglove_port:={busy_port}')
        served = Process('pool_sim', '--ros-args', '-p', 'foxglove_port:=0')
        code, output = refused.finish()
    refusals = [line for line in output.splitlines() if 'refusing to start' in line]
    assert code == 1 and len(refusals) == 1 and 'Traceback' not in output, output
    assert f'foxglove_port {busy_port}' in refusals[0] and '127.0.0.1' in refusals[0]
    serving = served.wait_for(SERVING)
    assert serving, ''.join(served.output)
    with connect(f'ws://127.0.0.1:{serving.group(1)}', subprotocols=['foxglove.sdk.v1'],
                 open_timeout=5) as client:
        assert json.loads(client.recv(timeout=5))['op'] == 'serverInfo'
    served.process.send_signal(signal.SIGINT)
    code, output = served.finish()
    assert code == 0 and 'Traceback' not in output, output


def test_headless_serves_the_view_in_real_time():
    started = time.monotonic()
    headless = Process('pool_sim.headless', '--foxglove', '0', '--seconds', '1.0')
    assert headless.wait_for(SERVING), ''.join(headless.output)
    code, output = headless.finish()
    assert code == 0, output
    assert time.monotonic() - started >= 1.0  # paced to the wall clock
