"""Messages serialized once, then patched in place: the bulk way to fill N poses.

rclpy spends ~10 us per pose turning a Python PoseArray into its C form, ~30 us per marker
and ~7 us refilling plus ~17 us converting one Odometry. Here a message is built and
serialized once by rclpy; every field that changes (stamps, positions, scales) is a
fixed-size number at a fixed offset, so each publish writes the new numbers into the bytes
through numpy views and publishes the bytes (rclpy's publish takes serialized messages).
Offsets are not hand-computed from the CDR layout: they are found by serializing the message
with sentinel values and searching for them, so rclpy's own serializer decides the layout.

PatchedMessage: one message of N like elements (PoseArray, MarkerArray). PatchedMessages:
N small messages differing in a name (one Odometry per sphere), in one buffer.
PatchedDoubleBlock: one message whose float64 sequence is an (N, columns) block.
"""
import itertools

import numpy as np
from rclpy.serialization import serialize_message

# Sentinels per marked message: each one's are drawn afresh, because the serializer leaves
# padding bytes uninitialised and they can hold stale bytes of an earlier marked message
# (seen at 100 000 markers: an old stamp sentinel found twice).
SENTINELS_PER_MESSAGE = 64
_sentinel_bases = itertools.count(0, SENTINELS_PER_MESSAGE)


def _fresh_sentinel_base() -> int:
    """A base whose sentinels k (0 <= k < SENTINELS_PER_MESSAGE) no earlier call had."""
    return next(_sentinel_bases)


def _double_sentinel(k: int) -> float:
    """Distinct doubles no real field holds (around 1e-200)."""
    return (1.0 + k * 2.0**-40) * 1.2345678901234567e-200


def _stamp_sentinel(k: int) -> int:
    """Distinct int32 seconds no template stamp holds (the modulus keeps them int32)."""
    return 0x5A5A0000 + k % (2**31 - 0x5A5A0000)


def _offset_of(data: bytes, value, dtype) -> int:
    needle = np.array([value], dtype=dtype).tobytes()
    first = data.find(needle)
    if first < 0 or data.find(needle, first + 1) >= 0:
        raise RuntimeError(f'sentinel {value!r} not found exactly once')
    return first


class PatchedMessage:
    """`build()` makes the message with `count` elements; `doubles` maps a name to a setter
    `(message, index, value)` of one double of element index; `stamp(message, index)` is
    the builtin_interfaces/Time to stamp, of which there are `stamp_count`.

    The message is built twice: once as it is published, once with a distinct sentinel in
    every patched field of elements 0 and 1, whose offsets give each field's first offset
    and its stride from one element to the next.
    """

    def __init__(self, build, count, doubles, stamp, stamp_count):
        self.buffer = bytearray(serialize_message(build()))
        marked = build()
        base = _fresh_sentinel_base()
        elements = min(count, 2)
        for k, (name, setter) in enumerate(doubles.items()):
            for index in range(elements):
                setter(marked, index, _double_sentinel(base + 2 * k + index))
        for index in range(min(stamp_count, 2)):
            time = stamp(marked, index)
            time.sec, time.nanosec = _stamp_sentinel(base + index), 0
        data = bytes(serialize_message(marked))

        def placed(first_sentinel, second_sentinel, dtype, elements_of_field):
            """(offset of element 0, stride between elements) of one field."""
            first = _offset_of(data, first_sentinel, dtype)
            if elements_of_field < 2:
                return first, 8
            return first, _offset_of(data, second_sentinel, dtype) - first

        def view(offset, stride, dtype, elements_of_field):
            return np.ndarray((elements_of_field,), dtype, buffer=self.buffer, offset=offset,
                              strides=(stride,))
        self.views = {}
        for k, name in enumerate(doubles):
            offset, stride = placed(_double_sentinel(base + 2 * k),
                                    _double_sentinel(base + 2 * k + 1), '<f8', count)
            self.views[name] = view(offset, stride, '<f8', count)
        offset, stride = placed(_stamp_sentinel(base), _stamp_sentinel(base + 1), '<i4',
                                stamp_count)
        # builtin_interfaces/Time: int32 sec, then uint32 nanosec.
        self.seconds = view(offset, stride, '<i4', stamp_count)
        self.nanoseconds = view(offset + 4, stride, '<u4', stamp_count)

    def patch(self, stamp_seconds: int, stamp_nanoseconds: int, **columns):
        """Write the stamp into every element and each named (n,) column of doubles."""
        self.seconds[:] = stamp_seconds
        self.nanoseconds[:] = stamp_nanoseconds
        for name, values in columns.items():
            self.views[name][:] = values

    def to_bytes(self) -> bytes:
        return bytes(self.buffer)


def _text_slot(plain: bytes, marked: bytes, length: int) -> int:
    """Offset of the `length`-byte text that reads 'a'*length in `plain` and 'b'*length in
    `marked` (two serializations of one message but for that text and the sentinels)."""
    if length == 0:
        return 0
    if len(plain) != len(marked):
        raise RuntimeError('the marked message serialized to a different length')
    plain_bytes, marked_bytes = np.frombuffer(plain, np.uint8), np.frombuffer(marked, np.uint8)
    differs = (plain_bytes == ord('a')) & (marked_bytes == ord('b'))
    # Padding bytes are uninitialised, so a stray byte may differ too: ask for one whole run.
    runs = [first for first in np.flatnonzero(differs).tolist()
            if differs[first:first + length].all() and (first == 0 or not differs[first - 1])
            and (first + length == len(differs) or not differs[first + length])]
    if len(runs) != 1:
        raise RuntimeError(f'text of {length} bytes not found exactly once')
    return runs[0]


class _Template:
    """One serialized message whose text has `length` bytes: its bytes, where the text goes
    and each patched field's offset from the message's first byte."""

    def __init__(self, build, length, doubles, stamp):
        self.data = bytes(serialize_message(build('a' * length)))
        marked = build('b' * length)
        base = _fresh_sentinel_base()
        for k, setter in enumerate(doubles.values()):
            setter(marked, _double_sentinel(base + k))
        time = stamp(marked)
        time.sec, time.nanosec = _stamp_sentinel(base), _stamp_sentinel(base + 1)
        marked_data = bytes(serialize_message(marked))
        self.text_offset = _text_slot(self.data, marked_data, length)
        self.double_offsets = np.array(
            [_offset_of(marked_data, _double_sentinel(base + k), '<f8')
             for k in range(len(doubles))], np.int64)
        self.seconds_offset = _offset_of(marked_data, _stamp_sentinel(base), '<i4')
        self.nanoseconds_offset = _offset_of(marked_data, _stamp_sentinel(base + 1), '<u4')


class PatchedMessages:
    """n small messages of one type that differ in one text field (a name) and in the
    numbers patched each publish, serialized into one contiguous buffer.

    `build(text)` makes the message with that text; `doubles` maps a name to a setter
    `(message, value)` of one double; `stamp(message)` is the builtin_interfaces/Time to
    stamp. rclpy serializes the message twice per distinct text length (UTF-8 bytes), not
    per message: where the fields fall depends on the text's length only, so the messages
    of one length are copies of one template with their text written in. Messages of one
    length sit at a fixed stride in the buffer, placed so that every double starts at a
    multiple of 8 bytes: one float64 view of the buffer reaches them all, and each publish
    writes the doubles of all chosen messages with one fancy-indexed assignment.
    """

    def __init__(self, build, texts, doubles, stamp):
        encoded = [text.encode() for text in texts]
        lengths = np.fromiter(map(len, encoded), np.int64, len(encoded))
        count = len(encoded)
        self.starts = np.zeros(count, np.int64)
        sizes = np.zeros(count, np.int64)
        double_offsets = np.zeros((count, len(doubles)), np.int64)
        seconds_offsets = np.zeros(count, np.int64)
        nanoseconds_offsets = np.zeros(count, np.int64)
        groups, end = [], 0
        for length in np.unique(lengths).tolist():
            template = _Template(build, length, doubles, stamp)
            members = np.flatnonzero(lengths == length)
            stride = -(-len(template.data) // 8) * 8  # a multiple of 8 keeps alignment
            first_double = template.double_offsets[0] if len(doubles) else 0
            block_start = end + (-(end + first_double)) % 8
            starts = block_start + stride * np.arange(len(members))
            self.starts[members] = starts
            sizes[members] = len(template.data)
            double_offsets[members] = starts[:, None] + template.double_offsets
            seconds_offsets[members] = starts + template.seconds_offset
            nanoseconds_offsets[members] = starts + template.nanoseconds_offset
            groups.append((template, members, block_start, stride))
            end = block_start + stride * len(members)
        if ((double_offsets % 8).any() or (seconds_offsets % 4).any()
                or (nanoseconds_offsets % 4).any()):
            raise RuntimeError('patched fields are not naturally aligned in the serialized '
                               'message: one float64 view cannot reach them all')
        self.buffer = bytearray(-(-end // 8) * 8)
        memory = np.frombuffer(self.buffer, np.uint8)
        for template, members, block_start, stride in groups:
            block = memory[block_start:block_start + stride * len(members)].reshape(-1, stride)
            block[:, :len(template.data)] = np.frombuffer(template.data, np.uint8)
            length = int(lengths[members[0]])
            if length:
                block[:, template.text_offset:template.text_offset + length] = np.frombuffer(
                    b''.join(encoded[i] for i in members.tolist()), np.uint8).reshape(-1, length)
        self._doubles = np.frombuffer(self.buffer, '<f8')
        self._seconds = np.frombuffer(self.buffer, '<i4')
        self._nanoseconds = np.frombuffer(self.buffer, '<u4')
        # Element indices into the views above: (n, doubles) and (n,).
        self.double_index = double_offsets // 8
        self.seconds_index = seconds_offsets // 4
        self.nanoseconds_index = nanoseconds_offsets // 4
        self._spans = list(zip(self.starts.tolist(), (self.starts + sizes).tolist()))
        self._memory = memoryview(self.buffer)

    def __len__(self):
        return len(self._spans)

    def __getitem__(self, index: int) -> bytes:
        return self.message_bytes(index)

    def patch(self, indices, stamp_seconds: int, stamp_nanoseconds: int, doubles):
        """Write the stamp and `doubles` ((k, doubles) in the order given at construction)
        into the messages at `indices` ((k,) ints); the others keep what they held."""
        self._seconds[self.seconds_index[indices]] = stamp_seconds
        self._nanoseconds[self.nanoseconds_index[indices]] = stamp_nanoseconds
        self._doubles[self.double_index[indices]] = doubles

    def message_bytes(self, index: int) -> bytes:
        """Message `index`, serialized: rclpy's Publisher.publish takes exactly `bytes`."""
        start, end = self._spans[index]
        return self._memory[start:end].tobytes()


class PatchedDoubleBlock:
    """A message whose one float64 sequence holds a (rows, columns) row-major block,
    patched in place through `block`, a (rows, columns) view. `build()` makes the message
    with rows × columns doubles; `mark(message, first, last)` sets the sequence's first and
    last double, whose sentinel offsets place the block and prove it contiguous."""

    def __init__(self, build, mark, rows, columns):
        self.buffer = bytearray(serialize_message(build()))
        marked = build()
        base = _fresh_sentinel_base()
        mark(marked, _double_sentinel(base), _double_sentinel(base + 1))
        data = bytes(serialize_message(marked))
        first = _offset_of(data, _double_sentinel(base), '<f8')
        if rows * columns > 1:
            last = _offset_of(data, _double_sentinel(base + 1), '<f8')
            if last - first != 8 * (rows * columns - 1):
                raise RuntimeError('the float64 sequence is not one contiguous block')
        # `first` need not be 8-byte aligned in the bytearray: numpy views it unaligned.
        self.block = np.ndarray((rows, columns), '<f8', buffer=self.buffer, offset=first)

    def to_bytes(self) -> bytes:
        return bytes(self.buffer)
