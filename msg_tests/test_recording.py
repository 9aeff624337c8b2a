"""Recording (node parameter `record`, headless --record), read back by independent readers:
mcap_ros2's decoder (its own CDR decoder, from the schema in the file) and rosbags (rosbag2's
conventions: types, QoS, counts). Decoded messages are compared, never bytes (rclpy leaves
CDR padding uninitialised)."""
from collections import Counter, defaultdict
import os
from pathlib import Path
import signal
import subprocess
import sys
import time

from mcap.reader import make_reader
from mcap.stream_reader import StreamReader
from mcap.records import Message
from mcap_ros2.decoder import DecoderFactory
import numpy as np
from hypothesis import given, settings, strategies as st
import pytest
from rclpy.parameter import Parameter

from pool_sim.ros.depth_keeper import DepthKeeper
from pool_sim.testing import PoolSim

REPO = Path(__file__).resolve().parents[1]
ENV = {**os.environ, 'PYTHONPATH': str(REPO)}
STATE_TOPICS = ('poses', 'markers', 'states')


def decoded(path):
    """{topic: [(log time ns, message)]} through mcap_ros2, with the namespace cut off."""
    found = defaultdict(list)
    with open(path, 'rb') as file:
        reader = make_reader(file, decoder_factories=[DecoderFactory()])
        for _, channel, message, ros_message in reader.iter_decoded_messages():
            found[channel.topic].append((message.log_time, ros_message))
    return found


def without_namespace(found, namespace):
    return {topic[len(namespace):] if topic.startswith(namespace + '/') else topic: messages
            for topic, messages in found.items()}


class Heard:
    """What the node published and applied, heard beside the recorder (not from it)."""

    def __init__(self, node):
        self.instants, self.inputs = [], []
        node.publishing.listen(self.published)
        node.inputs.listen(lambda applied: self.inputs.append(applied))

    def published(self, published):
        if published.spheres is not None and not published.again:
            self.instants.append((published.stamp_ns, published.spheres.position.copy(),
                                  published.spheres.velocity.copy()))


def keeper_run(path, seconds=3.0):
    """A lockstep closed loop (the depth keeper on the ice) recorded into `path`."""
    with PoolSim({'record': str(path), 'lockstep_inputs': ['ice'], 'wrench_timeout': 0.0,
                  'publish_clock': True}) as sim:
        heard = Heard(sim.node)
        sim.add(DepthKeeper, parameter_overrides=[Parameter('target_depth', value=1.0)])
        sim.advance(seconds)
        namespace = sim.namespace
    return heard, namespace


def test_a_lockstep_run_holds_every_instant_and_every_input_as_the_node_had_them(tmp_path):
    path = tmp_path / 'keeper.mcap'
    heard, namespace = keeper_run(path)
    found = without_namespace(decoded(path), namespace)
    node = '/pool_sim'
    # Every instant once (the republishes lockstep sends while it waits are not kept): the
    # first, at 0 s, published as the node started, before Heard listened.
    stamps = [stamp for stamp, _, _ in heard.instants]
    assert len(stamps) == len(set(stamps)) >= 90
    for topic in STATE_TOPICS + ('cork/odom', 'steel/odom', 'ice/odom'):
        assert [t for t, _ in found[f'{node}/{topic}']] == [0] + stamps, topic
        del found[f'{node}/{topic}'][0]
    assert len(found[f'{node}/scene_markers']) == 1
    assert len(found['/clock']) >= len(stamps) - 1
    for (stamp, position, velocity), (_, poses), (_, states), (_, odometry) in zip(
            heard.instants, found[f'{node}/poses'], found[f'{node}/states'],
            found[f'{node}/ice/odom']):
        assert poses.header.stamp.sec * 10**9 + poses.header.stamp.nanosec == stamp
        xyz = np.array([[p.position.x, p.position.y, p.position.z] for p in poses.poses]).T
        assert np.array_equal(xyz, position)
        block = np.array(states.data).reshape(-1, 6)
        assert np.array_equal(block, np.concatenate((position, velocity)).T)
        ice = odometry.pose.pose.position, odometry.twist.twist.linear
        assert [ice[0].x, ice[0].y, ice[0].z, ice[1].x, ice[1].y, ice[1].z] == \
            block[2].tolist()
        assert odometry.child_frame_id == 'ice' and odometry.header.frame_id == 'world'
    # The keeper's answers, each at the instant it came, with the force the node applied.
    wrenches = found[f'{node}/wrench']
    assert len(wrenches) == len(heard.inputs) >= len(stamps) - 2
    for (time_ns, message), applied in zip(wrenches, heard.inputs):
        assert time_ns == applied.received_ns
        assert message.header.frame_id == 'ice'
        assert message.wrench.force.z == applied.message.wrench.force.z != 0.0


def test_a_lockstep_run_recorded_twice_gives_the_same_messages(tmp_path):
    runs = []
    for name in ('first', 'second'):
        path = tmp_path / f'{name}.mcap'
        _, namespace = keeper_run(path, seconds=1.0)
        runs.append({topic: [(t, repr(m)) for t, m in messages] for topic, messages
                     in without_namespace(decoded(path), namespace).items()})
    assert runs[0] == runs[1]
    assert sum(map(len, runs[0].values())) > 200


def test_rosbag2_conventions_as_rosbags_reads_them(tmp_path):
    from rosbags.highlevel import AnyReader
    from rosbags.typesys import get_typestore, Stores
    path = tmp_path / 'keeper.mcap'
    heard, namespace = keeper_run(path, seconds=1.0)
    with open(path, 'rb') as file:
        reader = make_reader(file)
        header, summary = reader.get_header(), reader.get_summary()
        metadata = {record.name: record.metadata for record in reader.iter_metadata()}
    assert header.profile == 'ros2'
    assert {schema.encoding for schema in summary.schemas.values()} == {'ros2msg'}
    assert {channel.message_encoding for channel in summary.channels.values()} == {'cdr'}
    assert all(channel.metadata['topic_type_hash'].startswith('RIHS01_')
               for channel in summary.channels.values())
    assert 'version: 9' in metadata['rosbag2']['serialized_metadata']
    assert all(chunk.compression == 'zstd' for chunk in summary.chunk_indexes)
    with AnyReader([path], default_typestore=get_typestore(Stores.ROS2_JAZZY)) as bag:
        kinds = without_namespace({c.topic: (c.msgtype, c.msgcount) for c in bag.connections},
                                  namespace)
        poses = next(c for c in bag.connections if c.topic.endswith('/poses'))
        qos = poses.ext.offered_qos_profiles[0]
        assert (qos.durability.name, qos.reliability.name, qos.depth) == \
            ('TRANSIENT_LOCAL', 'RELIABLE', 1)
        first = bag.deserialize(next(bag.messages(connections=[poses]))[2], poses.msgtype)
        assert first.poses[0].position.z == 3.7  # the cork, where the default pool drops it
    count = len(heard.instants) + 1  # and the first, before Heard listened
    assert kinds['/pool_sim/poses'] == ('geometry_msgs/msg/PoseArray', count)
    assert kinds['/pool_sim/markers'] == ('visualization_msgs/msg/MarkerArray', count)
    assert kinds['/pool_sim/states'] == ('std_msgs/msg/Float64MultiArray', count)
    assert kinds['/pool_sim/ice/odom'] == ('nav_msgs/msg/Odometry', count)
    assert kinds['/pool_sim/wrench'][0] == 'geometry_msgs/msg/WrenchStamped'
    assert kinds['/clock'][0] == 'rosgraph_msgs/msg/Clock'


def test_headless_records_the_topics_and_messages_the_node_records(tmp_path):
    node_path, headless_path = tmp_path / 'node.mcap', tmp_path / 'headless.mcap'
    with PoolSim({'record': str(node_path)}, lockstep=False) as sim:
        sim.advance(2.0)
        namespace = sim.namespace
    done = subprocess.run([sys.executable, '-m', 'pool_sim.headless', '--seconds', '2',
                           '--record', str(headless_path)], env=ENV, capture_output=True,
                          text=True, timeout=120)
    assert done.returncode == 0, done.stderr
    from_node = without_namespace(decoded(node_path), namespace)
    from_headless = decoded(headless_path)
    assert '/clock' not in from_node and '/clock' not in from_headless  # publish_clock off
    assert sorted(from_node) == sorted(from_headless)
    for topic in from_node:
        assert [(t, repr(m)) for t, m in from_node[topic]] == \
            [(t, repr(m)) for t, m in from_headless[topic]], topic
    assert len(from_headless['/pool_sim/poses']) == 61  # 2 s at 30 Hz, and the start


def start_node(*ros_args):
    return subprocess.Popen([sys.executable, '-m', 'pool_sim', '--ros-args', *ros_args],
                            env=ENV, stdout=subprocess.PIPE, stderr=subprocess.STDOUT,
                            text=True)


@pytest.mark.parametrize('path, words', [
    ('{tmp}/no/such/folder/run.mcap', 'No such file or directory'),
    ('{tmp}', 'Is a directory'),
    ('/dev/full', 'No space left on device'),
    ('/proc/run.mcap', ''),
])
def test_an_unwritable_path_is_refused_at_start_naming_it(tmp_path, path, words):
    path = path.format(tmp=tmp_path)
    process = start_node('-p', f'record:={path}')
    output, _ = process.communicate(timeout=60)
    assert process.returncode == 1, output
    refusal = [line for line in output.splitlines() if 'refus' in line.lower()]
    assert len(refusal) == 1 and repr(path) in refusal[0] and words in refusal[0], output
    assert 'Traceback' not in output


def read_complete(path):
    """Messages per topic of a complete file: its footer and summary are there."""
    with open(path, 'rb') as file:
        reader = make_reader(file)
        summary = reader.get_summary()
        assert summary is not None and 'rosbag2' in [m.name for m in reader.iter_metadata()]
        return Counter(channel.topic for _, channel, _ in reader.iter_messages())


@pytest.mark.parametrize('number, moment_s', [
    (signal.SIGINT, 0.0), (signal.SIGTERM, 0.0), (signal.SIGINT, 0.3),
    (signal.SIGTERM, 0.7), (signal.SIGINT, 1.5)])
def test_a_signal_while_recording_leaves_a_complete_file(tmp_path, number, moment_s):
    path = tmp_path / 'run.mcap'
    process = start_node('-p', f'record:={path}', '-p', 'real_time_factor:=5.0')
    for line in process.stdout:  # the recording has begun; at 0.3 s and on, publishing
        if ('recording every published instant' if moment_s == 0 else
                'first state published') in line:
            break
    time.sleep(moment_s)
    process.send_signal(number)
    output, _ = process.communicate(timeout=60)
    assert process.returncode == 0 and 'Traceback' not in output, output
    counts = read_complete(path)  # at 0 s, maybe before the first instant: none yet
    assert counts['/pool_sim/poses'] == counts['/pool_sim/ice/odom'] >= (moment_s > 0)


def test_after_a_kill_9_the_file_reads_up_to_its_last_chunk(tmp_path):
    path = tmp_path / 'killed.mcap'
    process = start_node('-p', f'record:={path}', '-p', 'real_time_factor:=20.0')
    for line in process.stdout:
        if 'first state published' in line:
            break
    time.sleep(2.5)  # more than a flush period: a chunk or more is on disk
    process.kill()
    process.communicate(timeout=30)
    log_times = []
    try:
        for record in StreamReader(str(path)).records:
            if isinstance(record, Message):
                log_times.append(record.log_time)
    except Exception:  # the end, cut mid-record by the kill
        pass
    assert len(log_times) > 30
    assert log_times == sorted(log_times)  # as written, in simulated time


class FillingDisk:
    """A file that takes `room` bytes, then fails as a full disk does."""

    def __init__(self, path, room):
        self.file, self.room = open(path, 'wb'), room

    def write(self, data):
        if self.room < len(data):
            raise OSError(28, 'No space left on device')
        self.room -= len(data)
        return self.file.write(data)

    def __getattr__(self, name):
        return getattr(self.file, name)


def test_a_disk_that_fills_while_running_stops_the_recording_and_not_the_simulation(
        tmp_path, monkeypatch):
    import pool_sim.ros.mcap_file as mcap_file
    monkeypatch.setattr(mcap_file, 'open_for_writing',
                        lambda path: FillingDisk(path, 30_000))
    monkeypatch.setattr(mcap_file, 'CHUNK_BYTES', 4096)
    with PoolSim({'record': str(tmp_path / 'full.mcap')}, lockstep=False) as sim:
        recorder = sim.node.recorder
        sim.advance(5.0)
        deadline = time.monotonic() + 10.0
        while recorder.failed is None and time.monotonic() < deadline:
            time.sleep(0.05)
        assert recorder.failed == 'No space left on device'
        assert 'recording stopped (No space left on device)' in recorder.report()
        reached = sim.advance(2.0)
        assert reached > 6.9
        assert np.isfinite(sim.states()[0]).all()


def test_without_the_mcap_library_a_recording_is_refused_naming_the_command(
        tmp_path, monkeypatch, capsys):
    from pool_sim import headless
    monkeypatch.setitem(sys.modules, 'mcap', None)  # as if it were not installed
    monkeypatch.setitem(sys.modules, 'mcap.writer', None)
    assert headless.main(['--seconds', '1', '--record', str(tmp_path / 'r.mcap')]) == 1
    refusal = capsys.readouterr().err.strip().splitlines()
    assert len(refusal) == 1 and 'pip install mcap==1.6.0' in refusal[0]
    assert not (tmp_path / 'r.mcap').exists()


def test_the_node_imports_no_recording_or_viewing_library_unless_asked():
    done = subprocess.run([sys.executable, '-c', (
        'import sys, pool_sim.ros.simulator_node, pool_sim.headless; '
        'print(sorted(m for m in sys.modules if m.split(".")[0] in '
        '("mcap", "mcap_ros2", "rosbags", "foxglove", "matplotlib", "websockets")))')],
        env=ENV, capture_output=True, text=True, timeout=60)
    assert done.returncode == 0, done.stderr
    assert done.stdout.strip() == '[]'


@pytest.mark.parametrize('name', ['with space é 水.mcap', 'no_suffix', '.hidden.mcap'])
def test_odd_but_writable_paths_record(tmp_path, name):
    from pool_sim import headless
    path = tmp_path / name
    assert headless.main(['--seconds', '0.2', '--record', str(path)]) == 0
    assert read_complete(path)['/pool_sim/poses'] == 7  # 0.2 s at 30 Hz, and the start


@pytest.mark.parametrize('path, words', [
    ('x' * 300 + '.mcap', 'File name too long'), ('', "not a file path: ''"),
    ('/etc/hostname/run.mcap', 'Not a directory')])
def test_bad_paths_are_refused_by_headless_too(path, words, capsys):
    from pool_sim import headless
    assert headless.main(['--seconds', '0.2', '--record', path]) == 1
    refusal = capsys.readouterr().err.strip().splitlines()
    assert len(refusal) == 1 and words in refusal[0], refusal


def test_record_is_read_only_while_running_and_its_value_is_checked(tmp_path):
    from pool_sim.physics import InvalidInput, Scene
    from pool_sim.ros.node_keys import NODE_SCENE
    for value in (3, 1.5, True, ['a'], 'a\0b', 'x' * 5000):
        with pytest.raises(InvalidInput, match='record'):
            Scene({'record': value}, extension=NODE_SCENE)
    with PoolSim({'record': str(tmp_path / 'a.mcap')}, lockstep=False) as sim:
        result = sim.node.set_parameters([Parameter('record', value=str(tmp_path / 'b.mcap'))])
        assert not result[0].successful
        sim.advance(0.1)
    assert not (tmp_path / 'b.mcap').exists() and read_complete(tmp_path / 'a.mcap')


@given(name=st.text(min_size=1, max_size=300))
@settings(deadline=None)
def test_any_file_name_records_or_is_refused_in_one_line(tmp_path_factory, name):
    from pool_sim.physics import InvalidInput
    from pool_sim.ros.mcap_file import McapFile
    folder = tmp_path_factory.mktemp('names')
    path = str(folder / name)
    try:
        recording = McapFile(path)
    except InvalidInput as error:
        assert '\n' not in str(error).strip('\n') or '\n' in name
        return
    recording.close()
    with open(recording.stream.name, 'rb') as file:
        assert make_reader(file).get_summary() is not None


def test_spheres_spawned_and_removed_while_recording_keep_their_own_odometry(tmp_path):
    path = tmp_path / 'spawned.mcap'
    with PoolSim({'record': str(path)}, lockstep=False) as sim:
        sim.advance(0.5)
        assert sim.node.set_parameters_atomically([
            Parameter('sphere_names', value=['cork', 'ice', 'buoy']),
            Parameter('buoy.position', value=[1.0, 1.0, 2.0])]).successful
        sim.advance(0.5)
        namespace = sim.namespace
    found = without_namespace(decoded(path), namespace)
    poses = found['/pool_sim/poses']
    buoy, steel = found['/pool_sim/buoy/odom'], found['/pool_sim/steel/odom']
    # At 0.5 s two instants: the last with steel, and the spawn's, published with the buoy.
    assert len(steel) + len(buoy) == len(poses)
    assert steel[-1][0] == buoy[0][0] == 500_000_000
    newest = dict(poses)  # at 0.5 s, the spawn's instant
    for (time_ns, odometry) in buoy:
        pose = newest[time_ns]
        assert odometry.pose.pose.position.z == pose.poses[2].position.z
    assert [len(message.poses) for _, message in poses[-len(buoy):]] == [3] * len(buoy)
