"""The node under attack, through real services and topics: no request kills, wedges or
NaNs it; every refusal is short and changes nothing; the step guard has the last word."""
import math
import time

from geometry_msgs.msg import PoseArray, Wrench
from nav_msgs.msg import Odometry
from rcl_interfaces.msg import Parameter as ParameterMessage, ParameterValue
from rcl_interfaces.srv import (DescribeParameters, GetParameters, SetParameters,
                                SetParametersAtomically)
import numpy as np
import pytest
from std_srvs.srv import SetBool, Trigger

from pool_sim.ros import services
from pool_sim.ros.messages import LAST_STAMP_S
from pool_sim.ros.services import MAX_READ_NAMES, MAX_SET_ENTRIES
from ros_harness import Harness, stamp_seconds
from test_node_services import set_request

FAST = {'real_time_factor': 0.0}


def typed(name, type_code, **fields):
    return ParameterMessage(name=name, value=ParameterValue(type=type_code, **fields))


class LogRecorder:
    """Stands in for the node's logger: keeps (level, text) of every line."""

    def __init__(self):
        self.lines = []

    def __getattr__(self, level):
        return lambda text, **_: self.lines.append((level, text))

    def said(self, level, words):
        return [text for lvl, text in self.lines if lvl == level and words in text]


def record_logs(node):
    recorder = LogRecorder()
    node.get_logger = lambda: recorder
    return recorder


@pytest.mark.parametrize('type_code', [10, 11, 100, 255])
def test_unknown_parameter_type_codes_are_refused_on_every_set_service(type_code):
    with Harness(FAST) as ros:
        masses = ros.sim.simulation.spheres.mass.copy()
        result = ros.call(SetParameters, 'set_mass', SetParameters.Request(
            parameters=[typed('cork', type_code)])).results[0]
        assert not result.successful and f'unknown type code {type_code}' in result.reason
        # rclpy's own service: the bad entry refused, the good one beside it applied.
        results = ros.call(SetParameters, 'set_parameters', SetParameters.Request(parameters=[
            typed('cork.mass', type_code), typed('ice.mass', 3, double_value=20.0)])).results
        assert [r.successful for r in results] == [False, True]
        assert f'unknown type code {type_code}' in results[0].reason
        atomic = ros.call(SetParametersAtomically, 'set_parameters_atomically',
                          SetParametersAtomically.Request(parameters=[
                              typed('steel.mass', 3, double_value=50.0),
                              typed('cork.mass', type_code)])).result
        assert not atomic.successful and 'nothing was set' in atomic.reason
        assert ros.sim.simulation.spheres.mass.tolist() == [masses[0], masses[1], 20.0]
        # Still alive and answering.
        assert ros.call(SetBool, 'pause', SetBool.Request(data=False)).success


@pytest.mark.parametrize('service', ['set_mass', 'set_radius'])
@pytest.mark.parametrize('value', [1e160, 1e308, -1e308, 1e-310, 5e-324, -0.0, math.nan,
                                   math.inf, 2**62])
def test_values_outside_the_range_are_refused_naming_the_range(service, value):
    key = service.split('_')[1]
    with Harness(FAST) as ros:
        before = getattr(ros.sim.simulation.spheres, key).copy()
        result = ros.call(SetParameters, service, set_request(('steel', value))).results[0]
        assert not result.successful
        assert f'steel.{key}: must be' in result.reason
        assert (getattr(ros.sim.simulation.spheres, key) == before).all()


def test_a_refusal_of_ten_thousand_unknown_names_stays_short(monkeypatch):
    # The bound as it was (256): the same code path, at a size DDS carries in a moment.
    monkeypatch.setattr(services, 'MAX_SET_ENTRIES', 256)
    names = [f's{i}' for i in range(200)]
    with Harness({**FAST, 'sphere_names': names, 'effects': [],
                  **{f'{n}.position': [0.0, 0.0, 0.0] for n in names}}) as ros:
        request = SetParameters.Request(parameters=[
            typed(f'unknown_{i}' * 20, 3, double_value=1.0) for i in range(256)])
        results = ros.call(SetParameters, 'set_mass', request).results
        assert len(results) == 256 and not any(r.successful for r in results)
        assert max(len(r.reason) for r in results) < 200
        assert results[0].reason.endswith('known spheres: s0, s1, s2, s3 and 196 more')
        # More than one callback may take is refused as a whole, each entry told why.
        request.parameters = request.parameters * 40
        results = ros.call(SetParameters, 'set_mass', request, timeout_s=30.0).results
        assert len(results) == 10_240 and not any(r.successful for r in results)
        assert 'at most 256' in results[0].reason and len(results[0].reason) < 200


@pytest.mark.parametrize('service_type, name, request_of', [
    (SetParameters, 'set_parameters', lambda n: SetParameters.Request(
        parameters=[typed('cork.mass', 3, double_value=2.0)] * n)),
    (SetParametersAtomically, 'set_parameters_atomically', lambda n:
     SetParametersAtomically.Request(parameters=[typed('cork.mass', 3, double_value=2.0)] * n)),
    (GetParameters, 'get_parameters', lambda n: GetParameters.Request(names=['cork.mass'] * n)),
    (DescribeParameters, 'describe_parameters',
     lambda n: DescribeParameters.Request(names=['cork.mass'] * n)),
])
def test_a_huge_request_to_rclpys_services_is_refused_before_it_stops_the_clock(
        service_type, name, request_of):
    with Harness(FAST) as ros:
        masses = ros.sim.simulation.spheres.mass.copy()
        [service] = [s for s in ros.sim.services if s.srv_name.endswith(f'/{name}')]
        reads = 'names' in service_type.Request.get_fields_and_field_types()
        huge = request_of(MAX_READ_NAMES + 1 if reads else MAX_SET_ENTRIES + 1)
        # The node's own work on it (DDS and rclpy's conversion of the message come apart).
        started = time.monotonic()
        response = service.callback(huge, service_type.Response())
        assert time.monotonic() - started < 0.1
        assert (ros.sim.simulation.spheres.mass == masses).all()
        if service_type is SetParameters:
            assert len(response.results) == MAX_SET_ENTRIES + 1
            assert f'at most {MAX_SET_ENTRIES}' in response.results[-1].reason
        # A request of a usual size goes through, over DDS.
        assert ros.call(service_type, name, request_of(3)) is not None


def test_reset_sets_back_only_what_changed_and_answers_fast_with_an_explicit_integrator():
    with Harness({**FAST, 'integrator': 'rk4'}) as ros:
        logs = record_logs(ros.sim)
        assert ros.call(SetParameters, 'set_mass', set_request(('ice', 13.0))).results[
            0].successful
        started = time.monotonic()
        assert ros.call(Trigger, 'reset', Trigger.Request()).success
        assert time.monotonic() - started < 0.1
        assert ros.sim.get_parameter('ice.mass').value == 12.964
        assert not logs.said('warning', 'is unstable')  # the pool is stable under rk4


def test_a_set_mass_with_an_explicit_integrator_answers_within_a_tenth_of_a_second():
    with Harness({**FAST, 'integrator': 'semi_implicit_euler'}) as ros:
        for _ in range(3):
            started = time.monotonic()
            results = ros.call(SetParameters, 'set_mass', set_request(
                *[('cork', 9.0 + i) for i in range(20)])).results
            assert all(r.successful for r in results)
            assert time.monotonic() - started < 0.1


def test_many_simultaneous_requests_are_all_answered():
    with Harness(FAST) as ros:
        calls = []
        for service_type, name, request in (
                (SetParameters, 'set_mass', set_request(('cork', 9.0))),
                (SetParameters, 'set_radius', set_request(('ice', 0.16))),
                (Trigger, 'reset', Trigger.Request()),
                (SetBool, 'pause', SetBool.Request(data=False)),
                (SetBool, 'pause', SetBool.Request(data=True)),
                (Trigger, 'step', Trigger.Request())):
            client = ros.client.create_client(service_type, ros.topic(name))
            assert client.wait_for_service(timeout_sec=5.0)
            calls += [client.call_async(request) for _ in range(60)]
        assert ros.spin_until(lambda: all(call.done() for call in calls), timeout_s=30.0)
        assert sum(call.done() for call in calls) == 360
        # Each step answered: stepped while paused, or refused while running, with a reason.
        assert all(call.result().message for call in calls[-60:])


@pytest.mark.parametrize('params', [
    {'real_time_factor': 1e4},
    {'real_time_factor': 1e4, 'physics_rate_hz': 1e5},
    {'real_time_factor': 0.0, 'physics_rate_hz': 1e5, 'publish_rate_hz': 1e4},
    {'real_time_factor': 0.001, 'publish_rate_hz': 0.01},
])
def test_services_answer_within_a_tenth_of_a_second_whatever_the_rates(params):
    with Harness(params) as ros:
        client = ros.client.create_client(DescribeParameters, ros.topic('describe_parameters'))
        assert client.wait_for_service(timeout_sec=5.0)
        ros.spin_for(0.3)
        latencies = []
        for _ in range(7):
            started = time.monotonic()
            result = ros.call(SetParameters, 'set_mass', set_request(('cork', 9.0)))
            latencies.append(time.monotonic() - started)
            assert result.results[0].successful
        assert max(latencies) < 0.1, latencies


def test_slow_publishing_does_not_give_up_simulated_time():
    # A 100 s publish period once meant one tick per 100 s owing 100 s at once, of which
    # the catch-up bound kept 0.1 s.
    with Harness({'real_time_factor': 1.0, 'publish_rate_hz': 0.01}) as ros:
        ros.spin_for(1.0)
        assert 0.8 < ros.sim.simulation.time < 1.2
        assert ros.sim.clock.given_up_s < 0.05


@pytest.mark.parametrize('real_time_factor', [1e-12, 1e-6])
def test_at_a_pace_too_slow_to_reach_the_next_instant_late_subscribers_get_the_state(
        real_time_factor):
    # The state at t = 0 goes out as the node starts, before anyone subscribed; at
    # real_time_factor 1e-12 the next instant is 10^10 s away, and a volatile subscriber
    # (the default QoS) once got nothing at all.
    with Harness({'real_time_factor': real_time_factor}) as ros:
        poses = ros.collect(PoseArray, 'poses')
        odometry = ros.collect(Odometry, 'cork/odom')
        assert ros.spin_until(lambda: poses and odometry, timeout_s=3.0)
        assert stamp_seconds(poses[0].header) < 1e-3
        assert stamp_seconds(odometry[0].header) < 1e-3


def test_a_tick_held_up_past_the_catch_up_bound_makes_it_up_within_its_budget():
    # The test above gave up 0.19 s once in a fresh-clone run: its clock thread was held up
    # ~0.3 s (the machine's load; here, the node's lock), and the 0.1 s catch-up bound cut
    # what the late tick owed before it stepped, though its 20 ms budget makes up seconds of
    # this pool. The bound is for a machine that cannot keep up, not for a late tick.
    with Harness({'real_time_factor': 1.0, 'publish_rate_hz': 0.01}) as ros:
        ros.spin_for(0.3)
        with ros.sim.lock():
            time.sleep(0.3)
        ros.spin_for(0.3)
        with ros.sim.lock():
            behind_s = time.monotonic() - ros.sim.clock.started_wall - ros.sim.simulation.time
            assert ros.sim.clock.given_up_s < 0.05 and abs(behind_s) < 0.15, behind_s


@pytest.mark.parametrize('before_the_end', ['half a second', 'one step'])
def test_at_the_last_second_a_stamp_can_carry_the_node_pauses_and_reset_goes_on(
        before_the_end):
    with Harness({**FAST, 'physics_rate_hz': 100.0}) as ros:
        logs = record_logs(ros.sim)
        poses = ros.collect(PoseArray, 'poses')
        # One step before the end: the steps left, counted in a double, round to none.
        # Under the node's lock: a tick's batch must not end after it, on top of it.
        with ros.sim.lock():
            ros.sim.simulation.time = LAST_STAMP_S - (
                0.5 if before_the_end == 'half a second' else ros.sim.simulation.max_step)
            ros.sim.clock.next_publish_time = ros.sim.simulation.time
        assert ros.spin_until(lambda: ros.sim.clock.paused)
        assert ros.sim.simulation.time <= LAST_STAMP_S
        assert logs.said('error', 'the last a ROS time stamp can carry')
        assert not ros.call(SetBool, 'pause', SetBool.Request(data=False)).success
        assert ros.spin_until(lambda: poses)
        assert all(stamp_seconds(p.header) <= LAST_STAMP_S + 1 for p in poses)
        assert ros.call(Trigger, 'reset', Trigger.Request()).success
        assert ros.spin_until(lambda: 0.0 < ros.sim.simulation.time < 100.0)
        assert not ros.sim.clock.paused


@pytest.mark.parametrize('force', [1e160, -1e308, 1.5e9, math.nan, math.inf])
def test_a_wrench_beyond_the_limit_is_refused_and_the_state_stays_finite(force):
    with Harness(FAST) as ros:
        logs = record_logs(ros.sim)
        publisher = ros.client.create_publisher(Wrench, ros.topic('steel/wrench'), 10)
        message = Wrench()
        message.force.z = force
        for _ in range(20):
            publisher.publish(message)
            ros.spin_for(0.02)
        assert ros.sim.simulation.spheres.external_force[:, 1].tolist() == [0.0] * 3
        assert logs.said('warning', 'steel/wrench: refused')
        assert np.all(np.isfinite(ros.sim.simulation.spheres.position))


@pytest.mark.parametrize('integrator', ['explicit_euler', 'semi_implicit_euler',
                                        'velocity_verlet', 'rk4'])
def test_a_live_change_that_makes_the_integrator_unstable_warns_and_the_guard_holds(
        integrator):
    with Harness({**FAST, 'integrator': integrator}) as ros:
        logs = record_logs(ros.sim)
        poses = ros.collect(PoseArray, 'poses')
        assert ros.call(SetParameters, 'set_mass', set_request(('cork', 0.01))).results[
            0].successful
        assert logs.said('warning', f'{integrator} is unstable at 200 Hz for cork as changed')
        assert ros.spin_until(lambda: ros.sim.simulation.time > 20.0, timeout_s=30.0)
        assert ros.spin_until(lambda: len(poses) > 10)
        for message in poses:
            for pose in message.poses:
                assert all(math.isfinite(v) and abs(v) <= 4.0
                           for v in (pose.position.x, pose.position.y, pose.position.z))
        # Those not stable for the cork are caught by the step guard and said so.
        if ros.sim.simulation.recoveries:
            assert logs.said('error', 'cork')
            assert f'{ros.sim.simulation.recoveries} put-backs' in ros.sim.time_report()


def test_ros2_param_describe_shows_every_range():
    with Harness(FAST) as ros:
        names = ['cork.mass', 'cork.radius', 'gravity', 'physics_rate_hz', 'water.density',
                 'cork.velocity', 'real_time_factor']
        described = ros.call(DescribeParameters, 'describe_parameters',
                             DescribeParameters.Request(names=names)).descriptors
        ranges = {d.name: (d.floating_point_range[0].from_value,
                           d.floating_point_range[0].to_value) for d in described}
        assert ranges == {'cork.mass': (1e-6, 1e9), 'cork.radius': (1e-4, 1e3),
                          'gravity': (-1e3, 1e3), 'physics_rate_hz': (1.0, 1e5),
                          'water.density': (0.0, 1e5), 'cork.velocity': (-1e4, 1e4),
                          'real_time_factor': (0.0, 1e4)}
        assert described[2].additional_constraints == 'each component within [-1000, 1000] m/s^2'
