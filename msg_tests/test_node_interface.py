"""The interface at scale, through real topics and services: one node, the array inputs and
outputs, per_sphere_topics, a paused state that joining subscribers see, parameters by the
book (types, ranges, read_only, lift_area following the radius), spawn and remove."""
import math
import time

from geometry_msgs.msg import PoseArray, Wrench, WrenchStamped
from nav_msgs.msg import Odometry
import numpy as np
import pytest
from rcl_interfaces.msg import Parameter as ParameterMessage, ParameterType, ParameterValue
from rcl_interfaces.srv import (DescribeParameters, GetParameters, ListParameters,
                                SetParameters, SetParametersAtomically)
import rclpy
from rclpy.context import Context
from rclpy.executors import SingleThreadedExecutor
from rclpy.parameter import Parameter
from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy
from std_msgs.msg import Float64MultiArray, MultiArrayDimension
from std_srvs.srv import SetBool, Trigger

from pool_sim.physics import Scene
from pool_sim.ros.node_keys import NODE_SCENE
from pool_sim.ros.simulator_node import PoolSimNode
from ros_harness import Harness, stamp_seconds

FAST = {'real_time_factor': 4.0}
NO_GRAVITY = {'effects': [], 'wrench_timeout': 0.0}


def value_of(python):
    return Parameter('x', value=python).get_parameter_value()


def atomically(ros, **values):
    request = SetParametersAtomically.Request(parameters=[
        ParameterMessage(name=name.replace('__', '.'), value=value_of(value))
        for name, value in values.items()])
    return ros.call(SetParametersAtomically, 'set_parameters_atomically', request).result


def set_one(ros, name, value):
    request = SetParameters.Request(parameters=[ParameterMessage(name=name, value=value)])
    return ros.call(SetParameters, 'set_parameters', request).results[0]


def describe(ros, *names):
    return ros.call(DescribeParameters, 'describe_parameters',
                    DescribeParameters.Request(names=list(names))).descriptors


# -- one node ------------------------------------------------------------------------------

def test_a_renamed_node_is_exactly_one_node_and_every_node_answers_list_parameters():
    context = Context()
    rclpy.init(args=['--ros-args', '-r', '__node:=other', '-r', '__ns:=/renamed'],
               context=context)
    try:
        sim = PoolSimNode(context=context)
        # The remapping is the process's: a client in it must opt out of it.
        client = rclpy.create_node('graph_client', context=context,
                                   use_global_arguments=False)
        executor = SingleThreadedExecutor(context=context)
        for node in (sim, client):
            executor.add_node(node)
        deadline = time.monotonic() + 5.0
        while time.monotonic() < deadline and ('other', '/renamed') not in \
                client.get_node_names_and_namespaces():
            executor.spin_once(timeout_sec=0.05)
        nodes = client.get_node_names_and_namespaces()
        assert [n for n in nodes if n[1] == '/renamed'] == [('other', '/renamed')]
        # `ros2 param list` asks every node in the graph: each one answers at once.
        for name, namespace in nodes:
            full = f'{namespace.rstrip("/")}/{name}'
            service = client.create_client(ListParameters, f'{full}/list_parameters')
            assert service.wait_for_service(timeout_sec=2.0), full
            started = time.monotonic()
            future = service.call_async(ListParameters.Request())
            executor.spin_until_future_complete(future, timeout_sec=2.0)
            assert future.done() and time.monotonic() - started < 1.0, full
        topics = dict(client.get_topic_names_and_types())
        assert '/renamed/other/poses' in topics and '/renamed/other/cork/wrench' in topics
        executor.shutdown()
        sim.destroy_node()
        client.destroy_node()
    finally:
        rclpy.shutdown(context=context)


# -- inputs and outputs that scale -------------------------------------------------------

def stamped(frame, x=0.0, y=0.0, z=0.0):
    message = WrenchStamped()
    message.header.frame_id = frame
    message.wrench.force.x, message.wrench.force.y, message.wrench.force.z = x, y, z
    return message


def test_wrench_stamped_pushes_the_sphere_its_frame_names_and_refuses_the_rest():
    with Harness({**FAST, **NO_GRAVITY}) as ros:
        publisher = ros.client.create_publisher(WrenchStamped, ros.topic('wrench'), 10)
        assert ros.spin_until(lambda: publisher.get_subscription_count() > 0)
        for message in (stamped('steel', x=3.0), stamped('ice', z=-2.0),
                        stamped('nobody', x=1.0), stamped('cork', y=math.nan)):
            publisher.publish(message)
        spheres = ros.sim.simulation.spheres
        assert ros.spin_until(lambda: spheres.external_force[0, 1] == 3.0
                              and spheres.external_force[2, 2] == -2.0)
        ros.spin_for(0.2)
        assert not spheres.external_force[:, 0].any()  # the NaN was refused, cork untouched


def forces_message(rows, dims=None):
    message = Float64MultiArray(data=[float(v) for v in np.ravel(rows)])
    if dims is not None:
        message.layout.dim = [MultiArrayDimension(label=label, size=size, stride=stride)
                              for label, size, stride in dims]
    return message


def test_forces_sets_every_sphere_at_once_and_a_wrong_shape_or_nan_changes_nothing():
    with Harness({**FAST, **NO_GRAVITY}) as ros:
        publisher = ros.client.create_publisher(Float64MultiArray, ros.topic('forces'), 10)
        assert ros.spin_until(lambda: publisher.get_subscription_count() > 0)
        rows = [[1.0, 2.0, 3.0], [-4.0, 0.0, 0.5], [0.0, 0.0, 9.0]]
        publisher.publish(forces_message(rows, [('spheres', 3, 9), ('xyz', 3, 3)]))
        spheres = ros.sim.simulation.spheres
        assert ros.spin_until(lambda: (spheres.external_force.T == rows).all())
        for bad in (forces_message(rows[:2]), forces_message(rows, [('s', 9, 9)]),
                    forces_message([[math.nan, 0, 0]] + rows[1:]),
                    forces_message([[2e9, 0, 0]] + rows[1:])):
            publisher.publish(bad)
        ros.spin_for(0.3)
        assert (spheres.external_force.T == rows).all()


def test_every_input_holds_for_the_wrench_timeout_alike():
    with Harness({**FAST, 'effects': [], 'wrench_timeout': 0.2}) as ros:
        publisher = ros.client.create_publisher(Float64MultiArray, ros.topic('forces'), 10)
        assert ros.spin_until(lambda: publisher.get_subscription_count() > 0)
        publisher.publish(forces_message(np.ones((3, 3))))
        spheres = ros.sim.simulation.spheres
        assert ros.spin_until(lambda: spheres.external_force.all())
        assert ros.spin_until(lambda: not spheres.external_force.any(), timeout_s=3.0)


def test_states_carry_every_sphere_position_and_velocity_with_the_poses():
    with Harness(FAST) as ros:
        states = ros.collect(Float64MultiArray, 'states')
        poses = ros.collect(PoseArray, 'poses')
        assert ros.spin_until(lambda: len(states) >= 5 and len(poses) >= 5)
        state = states[-1]
        assert [(d.label, d.size, d.stride) for d in state.layout.dim] == [
            ('spheres', 3, 18), ('position_velocity', 6, 6)]
        rows = np.array(state.data).reshape(3, 6)
        positions = [[[p.position.x, p.position.y, p.position.z] for p in m.poses]
                     for m in poses]
        assert any(np.array_equal(rows[:, :3], p) for p in positions)
        assert rows[1, 5] < 0.0  # steel is falling


# -- per_sphere_topics ----------------------------------------------------------------------

def test_without_per_sphere_topics_the_graph_and_parameters_do_not_grow_with_spheres():
    names = [f's{i}' for i in range(50)]
    params = {**FAST, 'per_sphere_topics': False, 'sphere_names': names,
              'spheres.position.x': [0.0] * 50, 'spheres.position.y': [0.0] * 50,
              'spheres.position.z': [0.0] * 50, 'spheres.mass': [2.0] * 50}
    with Harness(params) as ros:
        ros.spin_for(0.5)
        topics = [t for t, _ in ros.client.get_topic_names_and_types()
                  if t.startswith(ros.topic(''))]
        assert sorted(t.rsplit('/', 1)[1] for t in topics) == [
            'forces', 'markers', 'poses', 'scene_markers', 'states', 'wrench']
        names_listed = ros.call(ListParameters, 'list_parameters',
                                ListParameters.Request()).result.names
        assert 'spheres.mass' in names_listed
        # No key belongs to one sphere: the list is the global keys and the array keys,
        # the same for 3 spheres or 300.
        assert not any(n.split('.')[0] in names for n in names_listed)
        assert len(names_listed) < len(names) + 10
        # set_mass by sphere name, ros2 param set of the array: one path, in step.
        result = ros.call(SetParameters, 'set_mass', SetParameters.Request(parameters=[
            ParameterMessage(name='s7', value=value_of(5.0))])).results[0]
        assert result.successful, result.reason
        assert ros.sim.simulation.spheres.mass[7] == 5.0
        assert ros.sim.get_parameter('spheres.mass').value[7] == 5.0
        masses = [3.0] * 50
        assert set_one(ros, 'spheres.mass', value_of(masses)).successful
        assert (ros.sim.simulation.spheres.mass == 3.0).all()
        refused = set_one(ros, 'spheres.mass', value_of([3.0] * 49))
        assert not refused.successful and 'expected 50 values' in refused.reason
        refused = set_one(ros, 'spheres.position.x', value_of([1.0] * 50))
        assert not refused.successful and 'cannot change while running' in refused.reason


# -- paused is visible ----------------------------------------------------------------------

def test_a_subscriber_joining_while_paused_gets_the_state_and_paused_time_is_not_counted():
    with Harness(FAST) as ros:
        assert ros.spin_until(lambda: ros.sim.simulation.time > 0.5)
        assert ros.call(SetBool, 'pause', SetBool.Request(data=True)).success
        frozen = ros.sim.simulation.time
        ros.spin_for(1.0)
        latched = QoSProfile(depth=1, durability=DurabilityPolicy.TRANSIENT_LOCAL,
                             reliability=ReliabilityPolicy.RELIABLE)
        late_latched = ros.collect(PoseArray, 'poses', latched)
        late_volatile = ros.collect(Float64MultiArray, 'states')
        assert ros.spin_until(lambda: late_latched and late_volatile, timeout_s=3.0)
        assert stamp_seconds(late_latched[-1].header) == pytest.approx(frozen, abs=1e-9)
        report = ros.sim.time_report()
        factor = float(report.split('real-time factor ')[1].split(')')[0])
        assert factor > 0.9 * FAST['real_time_factor']


# -- parameters by the book -----------------------------------------------------------------

def test_an_integer_for_a_double_is_stored_as_a_double_on_every_path():
    with Harness(FAST) as ros:
        integer = ParameterValue(type=ParameterType.PARAMETER_INTEGER, integer_value=9)
        assert set_one(ros, 'cork.mass', integer).successful
        stored = ros.call(GetParameters, 'get_parameters',
                          GetParameters.Request(names=['cork.mass'])).values[0]
        assert stored.type == ParameterType.PARAMETER_DOUBLE and stored.double_value == 9.0
        assert atomically(ros, steel__mass=40).successful
        assert ros.sim.get_parameter('steel.mass').type_ == Parameter.Type.DOUBLE
        # A refused string leaves the type as it was.
        text = ParameterValue(type=ParameterType.PARAMETER_STRING, string_value='heavy')
        assert not set_one(ros, 'steel.mass', text).successful
        [descriptor] = describe(ros, 'steel.mass')
        assert descriptor.type == ParameterType.PARAMETER_DOUBLE
        assert not descriptor.dynamic_typing


def test_descriptors_carry_ranges_units_and_read_only_and_rclpy_refuses_read_only_keys():
    with Harness(FAST) as ros:
        mass, gravity, position, names = describe(
            ros, 'cork.mass', 'gravity', 'cork.position', 'sphere_names')
        assert not mass.read_only and mass.floating_point_range[0].to_value == 1e9
        assert 'kg' in mass.additional_constraints
        assert gravity.read_only and position.read_only and not names.read_only
        refused = set_one(ros, 'gravity', value_of([0.0, 0.0, -1.0]))
        assert not refused.successful and 'read-only' in refused.reason
        assert ros.sim.simulation.environment.gravity[2] == -9.81


def test_the_lift_area_follows_the_radius_until_it_is_set():
    with Harness(FAST) as ros:
        result = ros.call(SetParameters, 'set_radius', SetParameters.Request(parameters=[
            ParameterMessage(name='ice', value=value_of(0.3))])).results[0]
        assert result.successful, result.reason
        assert ros.sim.get_parameter('ice.lift_area').value == pytest.approx(math.pi * 0.09)
        assert ros.sim.simulation.spheres.lift_area[2] == pytest.approx(math.pi * 0.09)
        assert set_one(ros, 'ice.radius', value_of(0.2)).successful  # still following
        assert ros.sim.simulation.spheres.lift_area[2] == pytest.approx(math.pi * 0.04)
        assert ros.sim.get_parameter('ice.lift_area').value == pytest.approx(math.pi * 0.04)
        # A reset sets the table back and the area follows on.
        assert ros.call(Trigger, 'reset', Trigger.Request()).success
        assert ros.sim.get_parameter('ice.lift_area').value == pytest.approx(math.pi * 0.0225)
        assert set_one(ros, 'ice.radius', value_of(0.3)).successful
        assert ros.sim.simulation.spheres.lift_area[2] == pytest.approx(math.pi * 0.09)
        assert set_one(ros, 'ice.lift_area', value_of(0.5)).successful
        assert set_one(ros, 'ice.radius', value_of(0.1)).successful
        assert ros.sim.simulation.spheres.lift_area[2] == 0.5


def dumped(ros):
    """What `ros2 param dump` gathers: every name, then every value."""
    names = ros.call(ListParameters, 'list_parameters', ListParameters.Request()).result.names
    values = ros.call(GetParameters, 'get_parameters',
                      GetParameters.Request(names=list(names))).values
    return [ParameterMessage(name=n, value=v) for n, v in zip(names, values)]


@pytest.mark.parametrize('per_sphere', [True, False])
def test_loading_the_nodes_own_dump_fails_only_for_read_only_keys_with_rclpys_reason(
        per_sphere):
    with Harness({**FAST, 'per_sphere_topics': per_sphere}) as ros:
        dump = dumped(ros)
        results = ros.call(SetParameters, 'set_parameters',
                           SetParameters.Request(parameters=dump)).results
        read_only = {d.name for d in describe(ros, *[p.name for p in dump]) if d.read_only}
        for parameter, result in zip(dump, results):
            if parameter.name in read_only:
                assert 'read-only' in result.reason, parameter.name
            else:
                assert result.successful, (parameter.name, result.reason)
        params = {p.name: rclpy.parameter.parameter_value_to_python(p.value) for p in dump
                  if not p.name.startswith(('qos_overrides', 'use_sim_time', 'start_type'))}
        again = Scene(params, extension=NODE_SCENE)
        assert again.sphere_names == ros.sim.scene.sphere_names
        assert (again.sphere_array('position') == ros.sim.scene.sphere_array('position')).all()


# -- spawn and remove -----------------------------------------------------------------------

def test_spawn_and_remove_in_one_atomic_request_with_topics_that_come_and_go():
    with Harness(FAST) as ros:
        assert ros.spin_until(lambda: ros.sim.simulation.time > 0.3)
        assert ros.call(SetBool, 'pause', SetBool.Request(data=True)).success
        steel_before = ros.state('steel')
        result = atomically(ros, sphere_names=['steel', 'ice', 'buoy'], buoy__mass=1.0,
                            buoy__radius=0.25, buoy__position=[1.0, 1.0, 2.0])
        assert result.successful, result.reason
        spheres = ros.sim.simulation.spheres
        assert spheres.names == ('steel', 'ice', 'buoy')
        assert spheres.mass[2] == 1.0 and spheres.drag_coefficient[2] == 0.47
        assert ros.sim.get_parameter('buoy.drag_coefficient').value == 0.47
        assert not ros.sim.has_parameter('cork.mass')
        assert describe(ros, 'buoy.position')[0].read_only
        # steel goes on from where it was, not from its start.
        assert all((a == b).all() for a, b in zip(ros.state('steel'),
                                                  steel_before))
        assert ros.call(SetBool, 'pause', SetBool.Request(data=False)).success
        odometry = ros.collect(Odometry, 'buoy/odom')
        assert ros.spin_until(lambda: odometry)
        poses = ros.collect(PoseArray, 'poses')
        assert ros.spin_until(lambda: poses and len(poses[-1].poses) == 3)
        def topics():
            return [t for t, _ in ros.client.get_topic_names_and_types()]
        assert ros.spin_until(lambda: ros.topic('buoy/wrench') in topics()
                              and ros.topic('cork/odom') not in topics()
                              and ros.topic('cork/wrench') not in topics())
        publisher = ros.client.create_publisher(Wrench, ros.topic('buoy/wrench'), 10)
        assert ros.spin_until(lambda: publisher.get_subscription_count() > 0)


def test_a_refused_spawn_changes_nothing():
    with Harness(FAST) as ros:
        for bad in ({'sphere_names': ['cork', 'x'], 'x__mass': -1.0},
                    {'sphere_names': ['cork', 'x'], 'x__position': [99.0, 0.0, 0.0]},
                    {'sphere_names': ['cork', 'x'], 'y__mass': 1.0},
                    {'sphere_names': ['cork', 'bad-name']},
                    {'sphere_names': []},
                    {'sphere_names': ['cork', 'cork']}):
            result = atomically(ros, **bad)
            assert not result.successful, bad
            assert result.reason
            assert ros.sim.simulation.spheres.names == ('cork', 'steel', 'ice')
            assert ros.sim.has_parameter('steel.mass') and not ros.sim.has_parameter('x.mass')


def test_spawn_and_remove_with_arrays_when_per_sphere_topics_are_off():
    with Harness({**FAST, 'per_sphere_topics': False}) as ros:
        assert ros.spin_until(lambda: ros.sim.simulation.time > 0.3)
        assert ros.call(SetBool, 'pause', SetBool.Request(data=True)).success
        ice_before = ros.state('ice')
        result = atomically(ros, sphere_names=['ice', 'a', 'b'],
                            spheres__mass=[12.964, 1.0, 2.0], spheres__position__x=[2.0, 0.0, 0.0],
                            spheres__position__y=[0.0, 1.0, -1.0],
                            spheres__position__z=[3.75, 1.0, 1.0])
        assert result.successful, result.reason
        spheres = ros.sim.simulation.spheres
        assert spheres.names == ('ice', 'a', 'b') and list(spheres.mass[1:]) == [1.0, 2.0]
        assert all((a == b).all() for a, b in zip(ros.state('ice'),
                                                  ice_before))
        assert list(ros.sim.get_parameter('spheres.position.y').value) == [0.0, 1.0, -1.0]
        assert list(ros.sim.get_parameter('spheres.radius').value)[1:] == [0.1, 0.1]
        # A kept sphere's start cannot move; a wrong length is refused; nothing changes.
        for bad in ({'sphere_names': ['ice', 'c'],
                     'spheres__position__x': [0.0, 0.0], 'spheres__position__y': [0.0, 0.0],
                     'spheres__position__z': [0.0, 0.0]},
                    {'sphere_names': ['ice', 'c'], 'spheres__mass': [1.0]}):
            assert not atomically(ros, **bad).successful
            assert ros.sim.simulation.spheres.names == ('ice', 'a', 'b')


def test_replacing_every_sphere_with_arrays_keeps_none_and_starts_the_new_ones():
    with Harness({**FAST, 'per_sphere_topics': False}) as ros:
        result = atomically(ros, sphere_names=['n0', 'n1'], spheres__position__x=[0.0] * 2,
                            spheres__position__y=[0.0] * 2, spheres__position__z=[0.0] * 2)
        assert result.successful, result.reason
        with ros.sim.lock():
            assert ros.sim.simulation.spheres.names == ('n0', 'n1')
            assert list(ros.sim.simulation.spheres.mass) == [1.0, 1.0]


def test_a_spawn_by_set_parameters_as_ros2_param_load_sends_it_is_applied_together():
    with Harness(FAST) as ros:
        request = SetParameters.Request(parameters=[
            ParameterMessage(name='buoy.position', value=value_of([1.0, 1.0, 2.0])),
            ParameterMessage(name='cork.mass', value=value_of(9.0)),
            ParameterMessage(name='sphere_names', value=value_of(['cork', 'buoy'])),
            ParameterMessage(name='buoy.mass', value=value_of(2.0))])
        results = ros.call(SetParameters, 'set_parameters', request).results
        assert [r.successful for r in results] == [True] * 4, [r.reason for r in results]
        with ros.sim.lock():
            spheres = ros.sim.simulation.spheres
            assert spheres.names == ('cork', 'buoy') and list(spheres.mass) == [9.0, 2.0]
            assert ros.sim.scene['buoy.position'] == (1.0, 1.0, 2.0)
        # A refused spawn: its entries all refused, the others set.
        request = SetParameters.Request(parameters=[
            ParameterMessage(name='sphere_names', value=value_of(['cork', 'buoy', 'x'])),
            ParameterMessage(name='x.mass', value=value_of(-1.0)),
            ParameterMessage(name='cork.mass', value=value_of(7.0))])
        results = ros.call(SetParameters, 'set_parameters', request).results
        assert [r.successful for r in results] == [False, False, True]
        assert ros.sim.simulation.spheres.names == ('cork', 'buoy')


def test_a_radius_of_the_wrong_type_or_beyond_range_is_refused_not_raised():
    with Harness(FAST) as ros:
        for name, value in (('cork.radius', [0.1, 0.2]), ('cork.radius', 1e200),
                            ('cork.radius', -1.0)):
            results = ros.call(SetParameters, 'set_parameters', SetParameters.Request(
                parameters=[ParameterMessage(name='cork.mass', value=value_of(2.5)),
                            ParameterMessage(name=name, value=value_of(value))])).results
            assert results[0].successful and not results[1].successful
            assert 'raised' not in results[1].reason, results[1].reason
        assert ros.sim.simulation.spheres.radius[0] == 0.2
    with Harness({**FAST, 'per_sphere_topics': False}) as ros:
        refused = set_one(ros, 'spheres.radius', value_of(0.3))
        assert not refused.successful and 'raised' not in refused.reason


def test_array_lift_areas_given_with_new_radii_are_applied_as_given():
    with Harness({**FAST, 'per_sphere_topics': False}) as ros:
        with ros.sim.lock():
            radius = ros.sim.simulation.spheres.radius.tolist()
            areas = ros.sim.simulation.spheres.lift_area.tolist()
        assert atomically(ros, spheres__radius=[r * 1.5 for r in radius],
                          spheres__lift_area=areas).successful
        with ros.sim.lock():
            assert ros.sim.simulation.spheres.lift_area.tolist() == areas
            assert list(ros.sim.get_parameter('spheres.lift_area').value) == areas
        # A radius alone: the areas follow, in the table too.
        assert atomically(ros, spheres__radius=radius).successful
        with ros.sim.lock():
            assert ros.sim.simulation.spheres.lift_area.tolist() == areas
