"""docs/parameters.md is what scripts/parameters_page.py makes from the code now, names every
key, and its defaults, types and live column are what a running node declares."""
import math

from rclpy.parameter import Parameter

from pool_sim.physics.schema import GLOBAL_KEYS, SPHERE_KEYS
from pool_sim.ros.node_keys import NODE_KEYS
from pool_sim.ros.parameters import plain
from ros_harness import Harness
from scripts import parameters_page

ROS_TYPE_NAMES = {Parameter.Type.DOUBLE: 'double', Parameter.Type.DOUBLE_ARRAY: 'double array',
                  Parameter.Type.STRING: 'string', Parameter.Type.STRING_ARRAY: 'string array',
                  Parameter.Type.BOOL: 'bool', Parameter.Type.INTEGER: 'integer'}
# A sphere the default pool lacks: it takes the schema's defaults.
NEW_SPHERE = 'newcomer'


def table_rows(text: str) -> dict:
    """{key: (type, default, live)} of every table row of the page (the Section decides
    nothing: scene, node and per-sphere keys have distinct names)."""
    rows = {}
    for line in text.splitlines():
        cells = [c.strip() for c in line.strip('|').split(' | ')]
        if len(cells) == 7 and cells[0].startswith('`'):
            rows[cells[0].strip('`')] = (cells[1], cells[2].strip('`'), cells[5])
    return rows


def test_the_page_is_not_stale():
    page = parameters_page.PAGE.read_text()
    assert page == parameters_page.page(), (
        f'docs/parameters.md is stale: run {parameters_page.COMMAND}')
    assert parameters_page.main(['--check']) == 0


def test_every_key_has_a_row_and_the_page_says_how_it_is_made():
    page = parameters_page.page()
    rows = table_rows(page)
    assert set(rows) == {*GLOBAL_KEYS, *NODE_KEYS, *SPHERE_KEYS}
    assert page.startswith('<!-- Generated') and parameters_page.COMMAND in page
    for key, spec in SPHERE_KEYS.items():
        named = f'`spheres.{key}.x`' if spec.kind == 'vector' else f'`spheres.{key}`'
        assert named in page


def test_defaults_types_and_live_are_what_the_node_declares():
    rows = table_rows(parameters_page.page())
    with Harness({'sphere_names': ['cork', 'steel', 'ice', NEW_SPHERE]}) as ros:
        for key in [*GLOBAL_KEYS, *NODE_KEYS]:
            ros_type, default, live = rows[key]
            parameter = ros.sim.get_parameter(key)
            descriptor = ros.sim.describe_parameter(key)
            assert (live == 'yes') == (not descriptor.read_only), key
            if key in ('sphere_names', 'lockstep'):
                continue  # the test set them
            value = plain(parameter.value)
            if parameter.type_ != Parameter.Type.NOT_SET:  # an empty list: untyped
                assert ROS_TYPE_NAMES[parameter.type_] == ros_type, key
            value = () if value is None else value
            assert parameters_page.shown_default(value) == default, key
        for key in SPHERE_KEYS:
            ros_type, default, live = rows[key]
            name = f'{NEW_SPHERE}.{key}'
            parameter = ros.sim.get_parameter(name)
            assert ROS_TYPE_NAMES[parameter.type_] == ros_type, name
            assert live.startswith('yes') == (not ros.sim.describe_parameter(name).read_only)
            if key == 'lift_area':
                radius = ros.sim.get_parameter(f'{NEW_SPHERE}.radius').value
                assert parameter.value == math.pi * radius ** 2
            else:
                assert parameters_page.shown_default(plain(parameter.value)) == default, name
