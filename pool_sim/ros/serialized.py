"""Messages serialized once, then patched in place: the bulk way to fill N poses.

rclpy spends ~10 us per pose turning a Python PoseArray into its C form, ~30 us per marker
and ~7 us refilling plus ~17 us converting one Odometry. Here rclpy serializes small messages
only; every field that changes (stamps, positions, scales) is a fixed-size number at a fixed
offset, so each publish writes the new numbers into the bytes through numpy views and
publishes the bytes (rclpy's publish takes serialized messages). Offsets are not
hand-computed from the CDR layout: they are found by serializing the message with sentinel
values and searching for them, so rclpy's own serializer decides the layout.

PatchedMessage: one message of N like elements (PoseArray, MarkerArray), assembled with numpy
from the message serialized with 0 to 3 elements. PatchedMessages: N small messages differing
in a name (one Odometry per sphere), in one buffer. PatchedDoubleBlock: one message whose
float64 sequence is an (N, columns) block.
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


def _float_sentinel(k: int) -> float:
    """Distinct float32 values no real field holds (in [2**-100, 2**-99)), exact in float32.
    The mantissa is k scrambled (times an odd number, mod 2**23): a plain count gives byte
    patterns such as 80 0d 80 0d that overlap themselves and the bytes beside them."""
    mantissa = k * 2654435761 % 2**23
    return float(np.uint32((127 - 100) << 23 | mantissa).view(np.float32))


def _stamp_sentinel(k: int) -> int:
    """Distinct int32 (so also uint32) numbers no template field holds, e.g. a stamp's
    seconds (the modulus keeps them int32)."""
    return 0x5A5A0000 + k % (2**31 - 0x5A5A0000)


def _sentinel(k: int, dtype: str):
    """Sentinel k of a field of numpy dtype '<f8', '<f4', '<i4' or '<u4'."""
    return {'<f8': _double_sentinel, '<f4': _float_sentinel, '<i4': _stamp_sentinel,
            '<u4': _stamp_sentinel}[dtype](k)


def _offset_of(data: bytes, value, dtype) -> int:
    needle = np.array([value], dtype=dtype).tobytes()
    first = data.find(needle)
    if first < 0 or data.find(needle, first + 1) >= 0:
        raise RuntimeError(f'sentinel {value!r} not found exactly once')
    return first


# Elements in the largest message serialized: two give the stride, the third checks it.
TEMPLATE_ELEMENTS = 3


def _length_field_offset(serialized_by_count) -> int:
    """Offset of the sequence's uint32 element count: the one place where the message
    serialized with k elements (serialized_by_count[k]) reads k, for every k."""
    empty = serialized_by_count[0]
    places = [offset for offset in range(len(empty) - 3)
              if all(int.from_bytes(data[offset:offset + 4], 'little') == k
                     for k, data in enumerate(serialized_by_count))]
    if len(places) != 1:
        raise RuntimeError(f'the sequence length was found {len(places)} times, not once')
    # Nothing after an empty sequence: it is the message's last field, so the n elements
    # can simply be appended.
    if places[0] + 4 != len(empty):
        raise RuntimeError('the sequence is not the last field of the message')
    return places[0]


class PatchedMessage:
    """One message whose last field is a sequence of `count` elements alike but for
    fixed-size numbers (PoseArray, MarkerArray, a float64 array), patched in place.

    `build(k)` makes the message with k elements. `header_fields` maps a name to
    (dtype, setter(message, value)) of one number outside the sequence; `element_fields`
    to (dtype, setter(message, index, value)) of one number of element index. dtype is
    numpy's: '<f8', '<f4', '<i4' or '<u4'. `views[name]` is a field's numpy view into the
    bytes: shape () for a header field, (count,) strided for an element field.

    rclpy serializes the message with 0, 1, 2 and 3 elements as built (the bytes copied)
    and once more with 3 elements and a sentinel in every patched field. From them: the
    sequence's length field, the element stride (how much one more element adds; it must
    not change from element to element) and every field's offset. The count-element message
    is then the 1-element message's bytes followed by count - 1 copies of the second
    element's, with the length set to count: O(count) numpy copying, not rclpy's ~30 us
    per marker. Before any write, patched fields hold what build gave them (elements 1 on:
    what it gave element 1).
    """

    def __init__(self, build, count, header_fields=None, element_fields=None):
        header_fields, element_fields = header_fields or {}, element_fields or {}
        built = [bytes(serialize_message(build(k))) for k in range(TEMPLATE_ELEMENTS + 1)]
        lengths = [len(data) for data in built]
        marked = build(TEMPLATE_ELEMENTS)
        base = _fresh_sentinel_base()
        sentinel_ks = itertools.count(base)
        header_marks = {}
        for name, (dtype, setter) in header_fields.items():
            header_marks[name] = _sentinel(next(sentinel_ks), dtype)
            setter(marked, header_marks[name])
        element_marks = {}
        for name, (dtype, setter) in element_fields.items():
            element_marks[name] = [_sentinel(next(sentinel_ks), dtype)
                                   for _ in range(TEMPLATE_ELEMENTS)]
            for index, value in enumerate(element_marks[name]):
                setter(marked, index, value)
        if next(sentinel_ks) > base + SENTINELS_PER_MESSAGE:
            raise ValueError(f'more than {SENTINELS_PER_MESSAGE} sentinels for one message')
        marked_data = bytes(serialize_message(marked))
        if len(marked_data) != lengths[TEMPLATE_ELEMENTS]:
            raise RuntimeError('the marked message serialized to a different length')

        length_offset = _length_field_offset(built)
        stride = lengths[2] - lengths[1]
        # A stride of whole 8-byte words starts every element at the alignment of the one
        # before, so they all share one layout; element 0 may be padded differently after
        # the header, so the per-element growth is measured from element 1 on.
        if any(after - before != stride for before, after in zip(lengths[1:], lengths[2:])) \
                or stride % 8:
            raise RuntimeError(f'elements grow the message by {np.diff(lengths).tolist()} '
                               'bytes: not one fixed stride of whole 8-byte words')
        element_offsets = {}
        for name, (dtype, _) in element_fields.items():
            offsets = [_offset_of(marked_data, value, dtype) for value in element_marks[name]]
            if np.any(np.diff(offsets) != stride):
                raise RuntimeError(f'{name} of elements 0..2 at offsets {offsets}, not '
                                   f'{stride} bytes apart')
            element_offsets[name] = offsets[0]

        head = lengths[1]  # header and element 0
        self.buffer = bytearray(head + stride * (count - 1) if count else lengths[0])
        memory = np.frombuffer(self.buffer, np.uint8)
        template = np.frombuffer(built[TEMPLATE_ELEMENTS], np.uint8)
        if count:
            memory[:head] = template[:head]
            memory[head:].reshape(count - 1, stride)[:] = template[head:head + stride]
        else:
            memory[:] = template[:lengths[0]]
        np.ndarray((), '<u4', buffer=self.buffer, offset=length_offset)[...] = count

        self.views = {}
        for name, (dtype, _) in header_fields.items():
            offset = _offset_of(marked_data, header_marks[name], dtype)
            if offset >= length_offset:
                raise RuntimeError(f'header field {name} found in the sequence')
            self.views[name] = np.ndarray((), dtype, buffer=self.buffer, offset=offset)
        for name, (dtype, _) in element_fields.items():
            self.views[name] = np.ndarray(
                (count,), dtype, buffer=self.buffer, offset=element_offsets[name],
                strides=(stride,)) if count else np.zeros(0, dtype)

    def write(self, **columns):
        """Write each named field: a number, or (count,) numbers for an element field."""
        for name, values in columns.items():
            self.views[name][...] = values

    def patch(self, stamp_seconds: int, stamp_nanoseconds: int, **columns):
        """Write the stamp (fields stamp_sec, stamp_nanosec) and each named (n,) column."""
        self.write(stamp_sec=stamp_seconds, stamp_nanosec=stamp_nanoseconds, **columns)

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
    """A message whose last field, a float64 sequence, holds a (rows, columns) row-major
    block, patched in place through `block`, a (rows, columns) view. `build(k)` makes the
    message with k doubles in the sequence (a PatchedMessage of rows × columns elements)."""

    def __init__(self, build, rows, columns):
        def set_double(message, index, value):
            message.data[index] = value
        self.message = PatchedMessage(build, rows * columns,
                                      element_fields={'value': ('<f8', set_double)})
        # A view of the doubles, never a copy (as reshape could make); they need not be
        # 8-byte aligned in the bytearray: numpy views them unaligned.
        doubles = self.message.views['value']
        stride = doubles.strides[0]
        self.block = np.lib.stride_tricks.as_strided(doubles, (rows, columns),
                                                     (stride * columns, stride))

    def to_bytes(self) -> bytes:
        return self.message.to_bytes()
