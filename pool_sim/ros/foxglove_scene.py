"""The pool in Foxglove's 3D panel: foxglove.SceneUpdate messages (protobuf) of the spheres,
encoded straight from the (3, n) arrays.

Building one foxglove.messages.SpherePrimitive per sphere costs ~2.8 us each (28 ms a frame
at 10 000 spheres, 84 % of a core at 30 Hz, all of it holding the interpreter the clock
thread needs). Here every sphere is a fixed-size protobuf record, laid out once per sphere
count with its colour, and each frame only writes the positions and sizes into a copy with
numpy: the same bytes as the SDK's encoder writes (it omits a number that is exactly 0,
which decodes to the same 0), in about a millisecond at 10 000 spheres. This module needs
numpy only; foxglove-sdk is imported by foxglove_view.py alone.
"""
import struct

import numpy as np

from pool_sim.ros.messages import sphere_colours

# Protobuf wire types.
_FIXED64, _LENGTH_DELIMITED, _VARINT = 1, 2, 0
# Field numbers of foxglove's schemas (foxglove/SceneUpdate.proto and what it includes).
SCENE_UPDATE_ENTITIES = 2
ENTITY_TIMESTAMP, ENTITY_FRAME_ID, ENTITY_ID, ENTITY_SPHERES = 1, 2, 3, 9
# The entity every frame replaces (same id: the previous frame's spheres go).
SPHERES_ENTITY_ID = 'spheres'


def varint(value: int) -> bytes:
    out = bytearray()
    while True:
        low, value = value & 0x7F, value >> 7
        if value:
            out.append(low | 0x80)
        else:
            out.append(low)
            return bytes(out)


def _tag(field: int, wire_type: int) -> bytes:
    return varint(field << 3 | wire_type)


def length_delimited(field: int, payload: bytes) -> bytes:
    """A sub-message or a string as field `field`."""
    return _tag(field, _LENGTH_DELIMITED) + varint(len(payload)) + payload


def _doubles(*values) -> bytes:
    """Fields 1, 2, ... as doubles: Vector3 (x, y, z), Quaternion's, Color (r, g, b, a)."""
    return b''.join(_tag(field, _FIXED64) + struct.pack('<d', value)
                    for field, value in enumerate(values, start=1))


def _sphere_record(x, y, z, size, red, green, blue, alpha) -> bytes:
    """One SpherePrimitive as SceneEntity.spheres: pose {position, orientation w = 1 (the
    SDK leaves out the zero x, y, z)}, size (x, y, z: the diameter, m), color."""
    orientation_w = _tag(4, _FIXED64) + struct.pack('<d', 1.0)
    pose = length_delimited(1, _doubles(x, y, z)) + length_delimited(2, orientation_w)
    sphere = (length_delimited(1, pose) + length_delimited(2, _doubles(size, size, size))
              + length_delimited(3, _doubles(red, green, blue, alpha)))
    return length_delimited(ENTITY_SPHERES, sphere)


def _record_layout():
    """The record's length and the offset of each double in it, found by encoding one with
    distinct sentinel values."""
    names = ('x', 'y', 'z', 'size', 'r', 'g', 'b', 'a')
    sentinels = [1e300 + i * 1e285 for i in range(len(names))]
    record = _sphere_record(*sentinels)
    offsets = {name: record.index(struct.pack('<d', value))
               for name, value in zip(names, sentinels)}
    size = offsets.pop('size')
    # The size's three doubles follow one another, each after its one-byte tag.
    offsets.update(size_x=size, size_y=size + 9, size_z=size + 18)
    return len(record), offsets


RECORD_BYTES, _OFFSETS = _record_layout()
_RECORD_DTYPE = np.dtype({'names': list(_OFFSETS), 'formats': ['<f8'] * len(_OFFSETS),
                          'offsets': list(_OFFSETS.values()), 'itemsize': RECORD_BYTES})


class SphereScene:
    """Encodes the spheres of one instant as a SceneUpdate of one entity
    (SPHERES_ENTITY_ID) in frame `frame_id`: a SpherePrimitive per sphere, diameter wide,
    in sphere_colours' hue (as the markers on ~/markers)."""

    def __init__(self, frame_id: str):
        self.frame_id = frame_id.encode('utf-8')
        self.template = np.zeros(0, np.uint8)  # RECORD_BYTES per sphere, colours written

    def _template_for(self, count):
        if len(self.template) != count * RECORD_BYTES:
            template = np.frombuffer(_sphere_record(1, 1, 1, 1, 1, 1, 1, 1) * count,
                                     np.uint8).copy()
            fields = np.ndarray((count,), _RECORD_DTYPE, buffer=template)
            colours = sphere_colours(count)
            for column, channel in enumerate('rgba'):
                fields[channel] = colours[:, column]
            self.template = template
        return self.template

    def encode(self, stamp_ns: int, position, radius) -> bytes:
        """position: (3, n) m; radius: (n,) m; stamp_ns: the instant, ns of simulated time.
        The serialized foxglove.SceneUpdate."""
        count = len(radius)
        records = self._template_for(count).copy()
        fields = np.ndarray((count,), _RECORD_DTYPE, buffer=records)
        fields['x'], fields['y'], fields['z'] = position[0], position[1], position[2]
        diameter = 2.0 * np.asarray(radius)
        fields['size_x'] = fields['size_y'] = fields['size_z'] = diameter
        seconds, nanoseconds = divmod(int(stamp_ns), 1_000_000_000)
        timestamp = _tag(1, _VARINT) + varint(seconds) + _tag(2, _VARINT) + varint(nanoseconds)
        head = (length_delimited(ENTITY_TIMESTAMP, timestamp)
                + length_delimited(ENTITY_FRAME_ID, self.frame_id)
                + length_delimited(ENTITY_ID, SPHERES_ENTITY_ID.encode()))
        body = records.tobytes()
        entity_length = len(head) + len(body)
        return b''.join((_tag(SCENE_UPDATE_ENTITIES, _LENGTH_DELIMITED),
                         varint(entity_length), head, body))
