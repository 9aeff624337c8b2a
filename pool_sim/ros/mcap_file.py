"""One MCAP file in rosbag2's conventions, written through the `mcap` library.

What rosbag2's MCAP storage plugin writes, so `ros2 bag info/play`, Foxglove, Lichtblick and
`rosbags` read it as one of theirs: profile `ros2`; one schema per message type, named
`package/msg/Type`, encoding `ros2msg`, holding the type's full definition; one channel per
topic, message encoding `cdr`, with the metadata `offered_qos_profiles` (the publisher's QoS
as rosbag2's version-9 YAML) and `topic_type_hash` (RIHS01); messages as serialized CDR,
log and publish time in ns; chunks of CHUNK_BYTES compressed with zstd; and at the end a
metadata record `rosbag2` whose `serialized_metadata` is the bag's metadata (version 9,
rosbag2_bagfile_information), without which rosbag2 reads the QoS as version 8.

The writer keeps each chunk's index in memory until the file is finished, an entry per
channel in the chunk (with each sphere's odometry a channel of its own, ~70 kB a chunk at
1 000 spheres): chunks are large (CHUNK_BYTES) and close at least every flush, so a long
recording of many per-sphere channels grows by about that much a second. Message indexes
stay: rosbags, among others, finds messages only through them.
"""
from functools import lru_cache
import os

import yaml

from pool_sim.physics import InvalidInput
from pool_sim.ros.message_definitions import definition_of

# A chunk is compressed and written once it holds this many bytes, or at a flush (the
# recorder's, every wall second): a kill -9 loses at most the chunk in progress.
CHUNK_BYTES = 16 * 1024 * 1024
BAG_VERSION = 9  # rosbag2's metadata version of Jazzy (QoS as words, not integers)
INSTALL = 'pip install mcap==1.6.0'
# An unset QoS duration, as rmw reports one (RMW_DURATION_INFINITE).
INFINITE = {'sec': 9223372036, 'nsec': 854775807}


# libyaml's emitter where PyYAML has it: the bag's metadata names every topic (thousands with
# per-sphere odometry), and the pure-Python one takes ~2 ms a topic.
DUMPER = getattr(yaml, 'CSafeDumper', yaml.SafeDumper)


def qos_yaml(qos) -> str:
    """An rclpy QoSProfile as rosbag2 writes `offered_qos_profiles` (version 9)."""
    def duration(value):
        nanoseconds = value.nanoseconds
        if nanoseconds == 0:
            return dict(INFINITE)
        return {'sec': nanoseconds // 1_000_000_000, 'nsec': nanoseconds % 1_000_000_000}
    return yaml.dump([{
        'history': qos.history.short_key, 'depth': qos.depth,
        'reliability': qos.reliability.short_key, 'durability': qos.durability.short_key,
        'deadline': duration(qos.deadline), 'lifespan': duration(qos.lifespan),
        'liveliness': qos.liveliness.short_key,
        'liveliness_lease_duration': duration(qos.liveliness_lease_duration),
        'avoid_ros_namespace_conventions': qos.avoid_ros_namespace_conventions,
    }], Dumper=DUMPER, sort_keys=False).rstrip('\n')


@lru_cache(maxsize=None)
def qos_list(profile: str) -> list:
    return yaml.safe_load(profile)


def open_for_writing(path: str):
    """The file at `path`, created or truncated; InvalidInput naming it if it cannot be."""
    if not path or '\0' in path:
        raise InvalidInput(f'record: not a file path: {path!r}')
    path = os.path.expanduser(path)  # '~/runs/a.mcap', as a shell would have it
    try:
        if os.path.isdir(path):
            raise IsADirectoryError(21, 'Is a directory')
        return open(path, 'wb')
    except OSError as error:
        raise InvalidInput(f'record: cannot write {path!r}: {error.strerror or error}') \
            from None


class McapFile:
    """Messages into one MCAP file at `path`: InvalidInput naming it when it cannot be
    written, or when the mcap library is missing (with the command that installs it)."""

    def __init__(self, path: str):
        try:
            from mcap.writer import CompressionType, Writer
        except ImportError:
            raise InvalidInput(f'record: recording needs the mcap library: {INSTALL}') \
                from None
        self.path = path
        self.schemas = {}  # message type -> schema id
        self.channels = {}  # topic -> (channel id, message type)
        self.topics = []  # [name, type, qos YAML, hash, count] in first-seen order
        self.profiles = {}  # id of a QoSProfile -> (it, its YAML): the few, made once
        self.first_ns, self.last_ns, self.count, self.closed = None, None, 0, False
        self.stream = open_for_writing(path)
        try:
            self.writer = Writer(self.stream, chunk_size=CHUNK_BYTES,
                                 compression=CompressionType.ZSTD)
            self.writer.start(profile='ros2', library='pool_sim (mcap python)')
            self.stream.flush()  # a full disk or a read-only place refuses here, at start
        except BaseException as error:  # a refusal, or a signal half-way: no open file left
            try:
                self.stream.close()
            except OSError:
                pass  # the same full disk, flushing what the header left
            if not isinstance(error, OSError):
                raise
            raise InvalidInput(f'record: cannot write {path!r}: '
                               f'{error.strerror or error}') from None

    def _channel(self, topic: str, message_type, qos) -> int:
        known = self.channels.get(topic)
        if known is not None and known[1] is message_type:
            return known[0]
        definition = definition_of(message_type)
        schema = self.schemas.get(message_type)
        if schema is None:
            schema = self.writer.register_schema(definition.name, 'ros2msg',
                                                 definition.text.encode())
            self.schemas[message_type] = schema
        known_profile = self.profiles.get(id(qos))
        if known_profile is None:  # the profile kept with it, so its id stays its own
            known_profile = self.profiles[id(qos)] = (qos, qos_yaml(qos))
        profile = known_profile[1]
        channel = self.writer.register_channel(topic, 'cdr', schema, {
            'offered_qos_profiles': profile, 'topic_type_hash': definition.type_hash})
        self.channels[topic] = (channel, message_type)
        self.topics.append([topic, definition.name, profile, definition.type_hash, 0])
        return channel

    def write(self, topic: str, message_type, data: bytes, time_ns: int, qos):
        """One serialized message on `topic`, logged and published at time_ns."""
        channel = self._channel(topic, message_type, qos)
        self.writer.add_message(channel, log_time=time_ns, data=data, publish_time=time_ns)
        self.topics[channel - 1][4] += 1
        self.count += 1
        self.first_ns = time_ns if self.first_ns is None else min(self.first_ns, time_ns)
        self.last_ns = time_ns if self.last_ns is None else max(self.last_ns, time_ns)

    def flush(self):
        """The chunk in progress written out (a kill -9 after this loses nothing of it)."""
        self.writer.flush()

    def close(self):
        """The rosbag2 metadata, the summary and the footer; the file is complete."""
        if self.closed:
            return
        self.closed = True
        try:
            self.writer.add_metadata('rosbag2', {'serialized_metadata': self._bag_metadata()})
            self.writer.finish()
        finally:
            self.stream.close()

    def _bag_metadata(self) -> str:
        start = self.first_ns or 0
        duration = (self.last_ns or 0) - start
        name = os.path.basename(self.path)
        return yaml.dump({
            'version': BAG_VERSION, 'storage_identifier': 'mcap',
            'duration': {'nanoseconds': duration},
            'starting_time': {'nanoseconds_since_epoch': start},
            'message_count': self.count,
            'topics_with_message_count': [{
                'topic_metadata': {'name': topic, 'type': type_name,
                                   'serialization_format': 'cdr',
                                   'offered_qos_profiles': qos_list(profile),
                                   'type_description_hash': type_hash},
                'message_count': count} for topic, type_name, profile, type_hash, count
                in self.topics],
            'compression_format': '', 'compression_mode': '',
            'relative_file_paths': [name],
            'files': [{'path': name, 'starting_time': {'nanoseconds_since_epoch': start},
                       'duration': {'nanoseconds': duration}, 'message_count': self.count}],
            'custom_data': {'recorded_by': 'pool_sim'}, 'ros_distro': 'jazzy',
        }, Dumper=DUMPER, sort_keys=False)
