"""A message type's full definition and type hash, as rosbag2 writes them into MCAP schemas
and channels (and as Foxglove's ros2msg channels take them).

Both come from the files each message package installs (share/<package>/msg/<Type>.msg and
<Type>.json, found through the ament index): the definition is the type's .msg text, then
each type it refers to, at any depth, after a line of 80 '=' and `MSG: package/Type`
(the ros2msg convention of rosbag2's LocalMessageDefinitionSource); the hash is the RIHS01
hash rosidl computed for the type, which rosbag2 keeps in the channel's `topic_type_hash`.
"""
from functools import lru_cache
import json
import os
from typing import NamedTuple

from ament_index_python.packages import get_package_share_directory

SEPARATOR = '=' * 80


class MessageDefinition(NamedTuple):
    name: str  # 'geometry_msgs/msg/PoseArray'
    text: str  # the full ros2msg definition
    type_hash: str  # 'RIHS01_...'


def type_name(message_type) -> str:
    """'geometry_msgs/msg/PoseArray' of the class geometry_msgs.msg.PoseArray."""
    package = message_type.__module__.split('.')[0]
    return f'{package}/msg/{message_type.__name__}'


def _installed(name: str, suffix: str) -> str:
    package, _, short = name.split('/')
    return os.path.join(get_package_share_directory(package), 'msg', short + suffix)


@lru_cache(maxsize=None)
def definition_of(message_type) -> MessageDefinition:
    """The full definition and hash of a message class (geometry_msgs.msg.PoseArray)."""
    name = type_name(message_type)
    with open(_installed(name, '.json'), encoding='utf-8') as file:
        description = json.load(file)
    hashes = {entry['type_name']: entry['hash_string'] for entry in description['type_hashes']}
    referenced = [entry['type_name'] for entry in
                  description['type_description_msg']['referenced_type_descriptions']]
    parts = [_read(name)]
    for other in referenced:
        package, _, short = other.split('/')
        parts.append(f'{SEPARATOR}\nMSG: {package}/{short}\n{_read(other)}')
    return MessageDefinition(name, '\n'.join(parts), hashes[name])


def _read(name: str) -> str:
    with open(_installed(name, '.msg'), encoding='utf-8') as file:
        return file.read().rstrip('\n') + '\n'
