"""set_mass, set_radius, `ros2 param set`, reset and pause, through real services."""
import math

from geometry_msgs.msg import PoseArray, Wrench
from rcl_interfaces.msg import Parameter as ParameterMessage, ParameterType, ParameterValue
from rcl_interfaces.srv import SetParameters
import pytest
from std_srvs.srv import SetBool, Trigger
from visualization_msgs.msg import MarkerArray

from pool_sim.ros import clock
from ros_harness import Harness, stamp_seconds

FAST = {'real_time_factor': 0.0}


def entry(name, value):
    """A SetParameters entry with a value of the Python value's ROS type."""
    message = ParameterValue()
    if isinstance(value, bool):
        message.type, message.bool_value = ParameterType.PARAMETER_BOOL, value
    elif isinstance(value, int):
        message.type, message.integer_value = ParameterType.PARAMETER_INTEGER, value
    elif isinstance(value, float):
        message.type, message.double_value = ParameterType.PARAMETER_DOUBLE, value
    elif isinstance(value, str):
        message.type, message.string_value = ParameterType.PARAMETER_STRING, value
    elif value is None:
        message.type = ParameterType.PARAMETER_NOT_SET
    return ParameterMessage(name=name, value=message)


def set_request(*entries):
    return SetParameters.Request(parameters=[entry(n, v) for n, v in entries])


def settled_height(ros, sphere, seconds=20.0):
    """The sphere's height `seconds` of simulated time from now. From now: at
    real_time_factor 0 the node runs hundreds of times faster than the wall, and a service
    call alone took it past 20 s at times (the cork had no time left to sink)."""
    with ros.sim.lock():
        until = ros.sim.simulation.time + seconds
    ros.spin_until(lambda: ros.sim.simulation.time > until, timeout_s=30.0)
    return ros.state(sphere)[0][2]


def test_a_heavier_sphere_sinks():
    with Harness(FAST) as ros:
        results = ros.call(SetParameters, 'set_mass', set_request(('cork', 40.0))).results
        assert [r.successful for r in results] == [True]
        assert ros.sim.get_parameter('cork.mass').value == 40.0
        assert settled_height(ros, 'cork') == pytest.approx(-4.0 + 0.2)


def test_a_larger_sphere_floats_higher_and_its_marker_grows():
    with Harness(FAST) as ros:
        before = settled_height(ros, 'ice', 15.0)
        results = ros.call(SetParameters, 'set_radius', set_request(('ice', 0.3))).results
        assert [r.successful for r in results] == [True]
        assert ros.sim.get_parameter('ice.radius').value == 0.3
        after = settled_height(ros, 'ice', 40.0)
        # Same mass, eight times the volume: far less of it under water.
        assert after > before + 0.1
        markers = ros.collect(MarkerArray, 'markers')
        assert ros.spin_until(lambda: markers)
        assert markers[-1].markers[2].scale.x == pytest.approx(0.6)


def test_ros2_param_set_takes_the_same_path_and_stays_in_step():
    with Harness(FAST) as ros:
        ros.sim.set_parameters([])  # no-op: a call with nothing is fine
        client = ros.client.create_client(SetParameters, ros.topic('set_parameters'))
        assert client.wait_for_service(timeout_sec=5.0)
        future = client.call_async(set_request(('steel.mass', 50), ('steel.radius', 0.12)))
        ros.executor.spin_until_future_complete(future, timeout_sec=5.0)
        assert [r.successful for r in future.result().results] == [True, True]
        spheres = ros.sim.simulation.spheres
        assert spheres.mass[1] == 50.0 and spheres.radius[1] == 0.12
        refused = ros.call(SetParameters, 'set_parameters', set_request(('steel.mass', -1.0)))
        assert not refused.results[0].successful
        assert 'steel.mass' in refused.results[0].reason
        assert spheres.mass[1] == 50.0 and ros.sim.get_parameter('steel.mass').value == 50


BAD_VALUES = [
    ('moon', 1.0, "unknown sphere 'moon'"),
    ('cork', 0.0, 'must be within'),
    ('cork', -2.0, 'must be within'),
    ('cork', math.nan, 'must be finite'),
    ('cork', math.inf, 'must be finite'),
    ('cork', 'heavy', 'expected a number'),
    ('cork', True, 'expected a number'),
    ('cork', None, 'expected a number'),
]


@pytest.mark.parametrize('service', ['set_mass', 'set_radius'])
def test_each_bad_entry_is_refused_with_a_reason_and_changes_nothing(service):
    key = service.split('_')[1]
    with Harness(FAST) as ros:
        spheres = ros.sim.simulation.spheres
        before = (spheres.mass.copy(), spheres.radius.copy())
        request = set_request(*[(name, value) for name, value, _ in BAD_VALUES])
        results = ros.call(SetParameters, service, request).results
        assert len(results) == len(BAD_VALUES)
        for result, (_, _, reason) in zip(results, BAD_VALUES):
            assert not result.successful
            assert reason in result.reason
        assert (spheres.mass == before[0]).all() and (spheres.radius == before[1]).all()
        assert ros.sim.get_parameter(f'cork.{key}').value == ros.sim.scene[f'cork.{key}']


def test_a_request_mixing_good_and_bad_entries_applies_only_the_good_ones():
    with Harness(FAST) as ros:
        request = set_request(('cork', 5.0), ('moon', 1.0), ('ice', math.nan), ('steel', 40))
        results = ros.call(SetParameters, 'set_mass', request).results
        assert [r.successful for r in results] == [True, False, False, True]
        assert list(ros.sim.simulation.spheres.mass) == [5.0, 40.0, 12.964]
        assert ros.sim.get_parameter('ice.mass').value == 12.964


def test_a_radius_that_does_not_fit_the_pool_is_refused():
    with Harness(FAST) as ros:
        results = ros.call(SetParameters, 'set_radius', set_request(('cork', 4.5))).results
        assert not results[0].successful and 'does not fit' in results[0].reason


def test_parameters_that_cannot_change_live_are_refused_with_a_reason():
    with Harness(FAST) as ros:
        result = ros.call(SetParameters, 'set_parameters',
                          set_request(('gravity', 1.0))).results[0]
        # read_only in its descriptor: rclpy refuses it with its standard reason.
        assert not result.successful and 'read-only parameter: gravity' in result.reason


def test_reset_restores_the_initial_scene_and_time_zero():
    # Not as fast as possible: there, thousands of poses a second overrun any queue.
    with Harness({'real_time_factor': 4.0}) as ros:
        ros.call(SetParameters, 'set_mass', set_request(('cork', 40.0)))
        assert ros.spin_until(lambda: ros.sim.simulation.time > 1.0)
        poses = ros.collect(PoseArray, 'poses')
        answer = ros.call(Trigger, 'reset', Trigger.Request())
        assert answer.success
        assert ros.sim.get_parameter('cork.mass').value == 8.3776
        assert ros.sim.simulation.spheres.mass[0] == 8.3776
        # The node's own account (its status line) still counts the steps before the reset.
        # Read both clocks together, between two ticks: at 4x the simulation passes 1 s
        # again within a quarter second of wall time.
        with ros.sim.lock():
            simulated, since_reset = ros.sim.clock.simulated_s, ros.sim.simulation.time
            assert ros.sim.time_report().startswith(f'{simulated:.2f} s simulated')
        assert since_reset < 1.0 < simulated - since_reset
        assert ros.spin_until(lambda: any(stamp_seconds(p.header) == 0.0 for p in poses))
        first = next(p for p in poses if stamp_seconds(p.header) == 0.0)
        assert first.poses[0].position.z == 3.7


def test_pause_freezes_stamps_and_positions_and_services_still_answer():
    with Harness({'real_time_factor': 4.0}) as ros:
        poses = ros.collect(PoseArray, 'poses')
        assert ros.spin_until(lambda: len(poses) >= 5)
        assert ros.call(SetBool, 'pause', SetBool.Request(data=True)).success
        ros.spin_for(0.2)
        frozen_time = ros.sim.simulation.time
        frozen_position = ros.sim.simulation.spheres.position.copy()
        count = len(poses)
        ros.spin_for(0.5)
        assert ros.sim.simulation.time == frozen_time
        assert (ros.sim.simulation.spheres.position == frozen_position).all()
        assert len(poses) == count
        results = ros.call(SetParameters, 'set_mass', set_request(('cork', 9.0))).results
        assert results[0].successful
        assert ros.call(SetBool, 'pause', SetBool.Request(data=False)).message == 'running'
        assert ros.spin_until(lambda: len(poses) > count + 3)
        assert stamp_seconds(poses[-1].header) > frozen_time


def test_a_wrench_waiting_for_the_next_tick_does_not_outlive_a_reset():
    # One tick a second, so the reset is answered between two ticks.
    with Harness({'real_time_factor': 1.0, 'publish_rate_hz': 1.0}) as ros:
        message = Wrench()
        message.force.x = 5.0
        ros.sim.inputs._put_wrench('cork', '/pool_sim/cork/wrench', message)  # as cork/wrench does
        assert ros.call(Trigger, 'reset', Trigger.Request()).success
        ros.spin_for(1.5)
        assert ros.sim.simulation.time > 0.0
        assert not ros.sim.simulation.spheres.external_force.any()


def test_a_node_that_falls_behind_drops_the_backlog_and_says_how_much(monkeypatch):
    with Harness({'real_time_factor': 1.0}) as ros:
        assert ros.spin_until(lambda: ros.sim.simulation.time > 0.2)
        before, given_up_before = ros.sim.simulation.time, ros.sim.clock.given_up_s
        with ros.sim.lock():  # between two ticks of the clock thread
            # A second behind, on a machine with no time to catch up in this tick.
            ros.sim.clock.last_wall -= 1.0
            monkeypatch.setattr(clock, 'TICK_BUDGET_S', 0.0)
            ros.sim.clock.tick()
            monkeypatch.undo()
            assert ros.sim.simulation.time == before
            # The next tick makes up what the bound kept.
            ros.sim.clock.tick()
        caught_up = ros.sim.simulation.time - before
        assert caught_up == pytest.approx(0.1, abs=0.006)  # the bound, to a step
        # The second, plus the moments since the last tick, less what the bound kept.
        assert 0.89 <= ros.sim.clock.given_up_s - given_up_before <= 1.2
        assert f'{ros.sim.clock.given_up_s:.2f} s given up to the catch-up bound' in \
            ros.sim.time_report()


def test_a_node_behind_real_time_ticks_again_at_once_and_one_on_time_waits_its_period(
        monkeypatch):
    # Waiting a whole tick period after a tick that used its budget left a node that could
    # not keep up idle for most of its wall time.
    with Harness({'real_time_factor': 1.0}) as ros:
        assert ros.spin_until(lambda: ros.sim.simulation.time > 0.05)
        waits = []
        wait = ros.sim.clock.wake.wait
        monkeypatch.setattr(ros.sim.clock.wake, 'wait',
                            lambda timeout=None: (waits.append(timeout), wait(timeout))[1])
        with ros.sim.lock():  # between two ticks of the clock thread
            ros.sim.clock.last_wall -= 0.05
            assert ros.sim.clock.tick() is False  # three spheres catch up within the budget
            monkeypatch.setattr(clock, 'TICK_BUDGET_S', 0.0)  # no time to step
            ros.sim.clock.last_wall -= 0.05
            assert ros.sim.clock.tick() is True
            waits.clear()
        assert ros.spin_until(lambda: len(waits) >= 3)
        assert set(waits[:3]) == {clock.TICK_PERIOD_RANGE_S[0]}
        monkeypatch.setattr(clock, 'TICK_BUDGET_S', 0.02)
        assert ros.spin_until(lambda: ros.sim.clock.backlog_s < ros.sim.simulation.max_step)
        count = len(waits)
        assert ros.spin_until(lambda: len(waits) >= count + 3)
        assert waits[-1] == pytest.approx(ros.sim.clock.tick_period)
        assert ros.sim.clock.tick_period == pytest.approx(1 / 30)  # the default 30 Hz publishing
        with ros.sim.lock():
            ros.sim.clock.paused = True
            assert ros.sim.clock.tick() is False  # paused is not behind
            ros.sim.clock.paused = False
