"""The recording and live-view keys (record, foxglove_port, foxglove_host) against every kind
of value: accepted exactly when in range and of their type, else refused naming the key."""
import math

from hypothesis import given, settings, strategies as st
import pytest

from pool_sim.physics import InvalidInput, Scene
from pool_sim.ros.node_keys import NODE_SCENE

ANY_VALUE = st.one_of(
    st.none(), st.booleans(), st.integers(min_value=-2**70, max_value=2**70),
    st.floats(allow_nan=True, allow_infinity=True), st.text(max_size=50),
    st.lists(st.integers(), max_size=3), st.sampled_from(
        [math.nan, math.inf, -math.inf, 5e-324, 1e308, -1e308, 0.0, -0.0, 8765.0, '', [],
         2**63, -1, 0, 65535, 65536, '8765']))


def outcome(key, value):
    try:
        return Scene({key: value}, extension=NODE_SCENE)[key]
    except InvalidInput as error:
        assert str(error).startswith(f'{key}: ')
        return InvalidInput


@given(value=ANY_VALUE)
@settings(deadline=None)
def test_foxglove_port_takes_whole_numbers_from_minus_1_to_65535_only(value):
    good = type(value) is int and -1 <= value <= 65535
    assert outcome('foxglove_port', value) == (value if good else InvalidInput)


@given(value=ANY_VALUE)
@settings(deadline=None)
def test_foxglove_host_and_record_take_strings_only(value):
    host, record = outcome('foxglove_host', value), outcome('record', value)
    if not isinstance(value, str):
        assert host is InvalidInput and record is InvalidInput
    else:
        assert host == (value if value and '\0' not in value else InvalidInput)
        assert record == (value if '\0' not in value else InvalidInput)


@pytest.mark.parametrize('key', ['foxglove_port', 'foxglove_host', 'record'])
def test_many_values_at_once_each_refused_alone(key):
    """A scene of the node's keys checks each; a bad one names itself, whatever else is set."""
    with pytest.raises(InvalidInput, match=f'^{key}: '):
        Scene({'foxglove_port': 8765, 'foxglove_host': '127.0.0.1', 'record': 'a.mcap',
               key: math.nan}, extension=NODE_SCENE)
