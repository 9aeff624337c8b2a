"""depth_keeper against a hostile user: integer gains, refused values at start-up and at run
time, a change of sphere while running, no odometry, odometry that is not finite, signals."""
import functools
import gc
import math
import os
import re
from pathlib import Path
import signal
import subprocess
import sys
import threading
import time

from geometry_msgs.msg import WrenchStamped
from hypothesis import given, settings, strategies as st
from nav_msgs.msg import Odometry
from rcl_interfaces.msg import ParameterType
from rcl_interfaces.srv import SetParameters
import pytest
import rclpy
from rclpy.context import Context
from rclpy.parameter import Parameter

from pool_sim.ros import executables
from pool_sim.ros.depth_keeper import DepthKeeper, InvalidParameter, PARAMETERS
from ros_harness import Harness, overrides

REPO = Path(__file__).resolve().parents[1]
NUMBERS = [name for name in PARAMETERS if name != 'sphere']


class Keeper(Harness):
    """A private context with a DepthKeeper and a client node in a fresh namespace (no
    simulator: the test plays pool_sim by publishing odometry itself)."""

    def __init__(self, params=None, **keeper_kwargs):
        super().__init__(params)
        self.keeper_kwargs = keeper_kwargs

    def make_nodes(self):
        self.keeper = DepthKeeper(context=self.context, namespace=self.namespace,
                                  parameter_overrides=overrides(self.params),
                                  **self.keeper_kwargs)
        self.client = self.make_client()
        return [self.keeper, self.client]

    def __enter__(self):
        super().__enter__()
        self.parameter_client = self.client.create_client(
            SetParameters, f'{self.namespace}/depth_keeper/set_parameters')
        return self

    def collect(self, sphere):
        """The forces (Wrench) the keeper sends for `sphere`, on ~/wrench (WrenchStamped)."""
        received = []
        self.client.create_subscription(
            WrenchStamped, self.topic('wrench'),
            lambda m: received.append(m.wrench) if m.header.frame_id == sphere else None, 10)
        return received

    def set_remotely(self, **values):
        """As `ros2 param set` does: through the node's SetParameters service."""
        return set_remotely(self, self.parameter_client, values)


def set_remotely(ros, client, values):
    assert client.wait_for_service(timeout_sec=5.0)
    request = SetParameters.Request(parameters=[
        Parameter(name, value=value).to_parameter_msg() for name, value in values.items()])
    future = client.call_async(request)
    ros.executor.spin_until_future_complete(future, timeout_sec=5.0)
    assert future.done()
    return future.result().results


def odometry(z, vz=0.0, t=0.0, **fields):
    message = Odometry()
    message.header.stamp.sec, message.header.stamp.nanosec = int(t), int(t % 1 * 1e9)
    message.pose.pose.position.z, message.twist.twist.linear.z = z, vz
    for name, value in fields.items():  # e.g. position_x=nan
        part, axis = name.split('_')
        vector = (message.pose.pose if part in ('position', 'orientation')
                  else message.twist.twist)
        setattr(getattr(vector, part), axis, value)
    return message


def publish_until(ros, publisher, message, received, timeout_s=5.0):
    """Publish every 50 ms until something arrives (discovery takes a moment)."""
    deadline = time.monotonic() + timeout_s
    while time.monotonic() < deadline and not received:
        publisher.publish(message)
        ros.spin_until(lambda: received, timeout_s=0.05)
    return received


# Start-up.

def test_integers_are_taken_as_floats_for_every_number():
    params = {'kp': 600, 'kd': 150, 'ki': 2, 'max_force': 2000, 'target_depth': 1,
              'surface_z': 0}
    with Keeper(params) as ros:
        for name, value in params.items():
            parameter = ros.keeper.get_parameter(name)
            assert parameter.type_ == Parameter.Type.DOUBLE and parameter.value == value
            assert type(ros.keeper.settings[name]) is float
        # At run time too, through the service as `ros2 param set /depth_keeper kp 700` does.
        assert [r.successful for r in ros.set_remotely(kp=700, max_force=1500)] == [True] * 2
        assert ros.keeper.get_parameter('kp').value == 700.0
        assert ros.keeper.get_parameter('kp').type_ == Parameter.Type.DOUBLE
        assert ros.keeper.settings['max_force'] == 1500.0


def test_every_parameter_shows_its_range():
    with Keeper() as ros:
        for name in NUMBERS:
            descriptor = ros.keeper.describe_parameter(name)
            assert descriptor.dynamic_typing and descriptor.type == ParameterType.PARAMETER_DOUBLE
            [allowed] = descriptor.floating_point_range
            assert math.isfinite(allowed.from_value) and math.isfinite(allowed.to_value)
            assert allowed.from_value < allowed.to_value <= 1e9
        assert ros.keeper.describe_parameter('kp').floating_point_range[0].from_value == 0.0
        assert 'at most 64 characters' in (
            ros.keeper.describe_parameter('sphere').additional_constraints)


BAD_VALUES = [
    ('kp', 'abc', "kp: expected a number from 0 to 1e9 N/m, got 'abc' \\(a string\\)"),
    ('kd', True, 'kd: expected a number .*, got true \\(a bool\\)'),
    ('ki', [1.0, 2.0], 'ki: expected a number .*, got \\[1.0, 2.0\\] \\(an array\\)'),
    ('kp', -1.0, 'kp: must be a number from 0 to 1e9 N/m, got -1.0'),
    ('kp', -1, 'kp: must be .*, got -1'),
    ('kd', math.nan, 'kd: must be .*, got nan'),
    ('kp', math.inf, 'kp: must be .*, got inf'),
    ('ki', 1e308, 'ki: must be .*, got 1e\\+308'),
    ('max_force', 0.0, 'max_force: must be a number > 0 and <= 1e9 N, got 0.0'),
    ('max_force', -5, 'max_force: must be a number > 0'),
    ('max_force', 2e9, 'max_force: must be'),
    ('target_depth', 20000, 'target_depth: must be a number from -10000 to 10000 m'),
    ('surface_z', -math.inf, 'surface_z: must be'),
    ('sphere', 'a-b', "sphere: must be a ROS name token.*, got 'a-b'"),
    ('sphere', '9ab', 'sphere: must be a ROS name token'),
    ('sphere', 'a__b', 'sphere: must be a ROS name token'),
    ('sphere', 'ice/cork', 'sphere: must be a ROS name token'),
    ('sphere', '', 'sphere: must be a ROS name token'),
    ('sphere', 'x' * 101, "sphere: must be .*, got 'x{40}\\.\\.\\. \\(101 characters\\)'"),
    ('sphere', 5, 'sphere: expected a ROS name token.*, got 5'),
    # A huge value is quoted cut short: the refusal stays one short line.
    ('kp', '9' * 100_000, "kp: expected a number .*, got '9{50,60}\\.\\.\\. \\(a string\\)$"),
    ('ki', [1.0] * 100_000,
     'ki: expected a number .*, got \\[1.0, .{40,60}\\.\\.\\. \\(an array\\)$'),
]


@pytest.mark.parametrize('name, value, message', BAD_VALUES)
def test_a_bad_value_stops_the_keeper_naming_the_key_and_what_is_allowed(name, value, message):
    context = Context()
    rclpy.init(context=context)
    try:
        with pytest.raises(InvalidParameter, match=f'^{message}'):
            DepthKeeper(context=context, parameter_overrides=overrides({name: value}))
    finally:
        rclpy.shutdown(context=context)


def test_edge_values_are_accepted():
    params = {'kp': 0, 'kd': 1e9, 'ki': 5e-324, 'max_force': 5e-324, 'target_depth': -1e4,
              'surface_z': 1e4, 'sphere': '_' + 'a' * 63}
    with Keeper(params) as ros:
        assert ros.keeper.settings == {name: value for name, value in params.items()}


# Run time.

def test_bad_values_set_at_run_time_are_refused_with_the_reason_and_change_nothing():
    runtime_bad = [(name, value) for name, value, _ in BAD_VALUES]
    runtime_bad.append(('kp', None))  # not set: would undeclare the parameter
    with Keeper({'sphere': 'ice', 'kp': 600}) as ros:
        before = {name: ros.keeper.get_parameter(name).value for name in PARAMETERS}
        settings_before = dict(ros.keeper.settings)
        topic_before = ros.keeper.subscription.topic_name
        for name, value in runtime_bad:
            [result] = ros.set_remotely(**{name: value})
            assert not result.successful, (name, value)
            assert name in result.reason, (name, value, result.reason)
        # SetParameters sets one by one: the good one is set, the bad one not.
        results = ros.set_remotely(kd=10.0, kp='abc')
        assert results[0].successful and not results[1].successful
        assert ros.keeper.get_parameter('kd').value == 10.0
        assert ros.keeper.set_parameters_atomically(
            [Parameter('kd', value=20.0), Parameter('kp', value='abc')]).successful is False
        assert ros.keeper.get_parameter('kd').value == 10.0
        before['kd'] = settings_before['kd'] = 10.0
        assert {name: ros.keeper.get_parameter(name).value for name in PARAMETERS} == before
        assert ros.keeper.settings == settings_before
        assert ros.keeper.subscription.topic_name == topic_before
        # A refused value of another type does not leave its type on the descriptor.
        assert ros.keeper.describe_parameter('kp').type == ParameterType.PARAMETER_DOUBLE
        assert ros.keeper.describe_parameter('sphere').type == ParameterType.PARAMETER_STRING


def test_setting_sphere_at_run_time_lets_go_of_the_old_one_and_holds_the_new_one(capfd):
    with Keeper({'sphere': 'ice', 'ki': 10.0}) as ros:
        ice_odometry = ros.client.create_publisher(Odometry, ros.topic('ice/odom'), 10)
        steel_odometry = ros.client.create_publisher(Odometry, ros.topic('steel/odom'), 10)
        ice_wrenches, steel_wrenches = ros.collect('ice'), ros.collect('steel')
        # Holding ice, 1 m too high for 2 s: the integral term has built up.
        assert publish_until(ros, ice_odometry, odometry(0.0, t=0.0), ice_wrenches)
        for t in (1.0, 2.0):
            ice_odometry.publish(odometry(0.0, t=t))
        assert ros.spin_until(lambda: math.isclose(ice_wrenches[-1].force.z, -600.0 - 20.0))

        [result] = ros.set_remotely(sphere='steel')
        assert result.successful
        assert ros.keeper.subscription.topic_name == ros.topic('steel/odom')
        assert ros.keeper.publisher.topic_name == ros.topic('wrench')
        # Let go of ice: a zero wrench, then nothing more however much ice odometry comes.
        assert ros.spin_until(lambda: ice_wrenches[-1].force.z == 0.0)
        released = len(ice_wrenches)
        ice_odometry.publish(odometry(0.0, t=3.0))
        # Holds steel, from a fresh integral: kp * error alone.
        assert publish_until(ros, steel_odometry, odometry(-0.5, vz=0.1, t=7.0),
                             steel_wrenches)
        assert steel_wrenches[0].force.z == pytest.approx(600.0 * -0.5 - 150.0 * 0.1)
        assert len(ice_wrenches) == released
        assert 'holding steel at 1 m depth' in capfd.readouterr().err


def test_a_change_of_sphere_moves_the_force_in_the_simulator():
    def keeper(**kwargs):
        return DepthKeeper(parameter_overrides=overrides({'sphere': 'ice'}), **kwargs)
    # Wrenches hold for ever: ice is free again only because the keeper lets go of it.
    with Harness({'real_time_factor': 1.0, 'wrench_timeout': 0.0}, extra_nodes=[keeper]) as ros:
        ice, steel = (ros.sim.simulation.spheres.lookup(name) for name in ('ice', 'steel'))

        def forces():
            return ros.sim.simulation.spheres.external_force  # [axis, sphere]
        assert ros.spin_until(lambda: forces()[2, ice] != 0.0)
        client = ros.client.create_client(SetParameters, f'{ros.namespace}/depth_keeper/'
                                          'set_parameters')
        [result] = set_remotely(ros, client, {'sphere': 'steel'})
        assert result.successful
        assert ros.spin_until(lambda: forces()[2, steel] != 0.0 and forces()[2, ice] == 0.0)


# Odometry that does not come, or is not finite.

def test_it_warns_while_no_odometry_comes_naming_the_topic(capfd):
    with Keeper({'sphere': 'titanium'}, odometry_timeout_s=0.3) as ros:
        topic = ros.topic('titanium/odom')
        ros.spin_until(lambda: False, timeout_s=1.0)
        log = capfd.readouterr().err
        assert re.search(f"no odometry on {topic} after 0\\.[3-9] s: is 'titanium' one of "
                         "pool_sim's sphere_names\\?", log), log
        assert 2 <= log.count(f'no odometry on {topic}') <= 4, log  # throttled, keeps waiting
        # Once odometry has come, a later silence is told differently.
        publisher = ros.client.create_publisher(Odometry, topic, 10)
        wrenches = ros.collect('titanium')
        assert publish_until(ros, publisher, odometry(0.0), wrenches)
        capfd.readouterr()
        ros.spin_until(lambda: False, timeout_s=0.6)
        log = capfd.readouterr().err
        assert re.search(f'no odometry on {topic} for 0\\.[3-9] s: has pool_sim stopped\\?',
                         log), log


def test_odometry_that_is_not_finite_gets_no_force(capfd):
    with Keeper({'sphere': 'ice'}) as ros:
        publisher = ros.client.create_publisher(Odometry, ros.topic('ice/odom'), 10)
        wrenches = ros.collect('ice')
        assert publish_until(ros, publisher, odometry(-1.0), wrenches)
        for bad in (odometry(math.nan), odometry(0.0, vz=math.inf),
                    odometry(0.0, position_x=-math.inf), odometry(0.0, orientation_w=math.nan)):
            publisher.publish(bad)
        publisher.publish(odometry(-0.5))
        assert ros.spin_until(lambda: wrenches[-1].force.z == -300.0)
        ros.spin_until(lambda: False, timeout_s=0.2)
        assert [w.force.z for w in wrenches[-2:]] == [0.0, -300.0]
        assert 'not finite; no force published' in capfd.readouterr().err


@pytest.fixture(scope='module')
def lone_keeper():
    context = Context()
    rclpy.init(context=context)
    try:
        keeper = DepthKeeper(context=context, namespace='/lone_keeper')
        yield keeper
        keeper.destroy_node()
    finally:
        rclpy.shutdown(context=context)


finite = st.floats(allow_nan=False, allow_infinity=False)


@settings(deadline=None)
@given(gains=st.tuples(*[st.sampled_from([0.0, 5e-324, 1e-3, 1.0, 600.0, 1e9])] * 3),
       max_force=st.sampled_from([5e-324, 1.0, 2000.0, 1e9]),
       depth=st.floats(-1e4, 1e4), states=st.lists(st.tuples(finite, finite,
                                                             st.integers(-2**31, 2**31 - 1)),
                                                   min_size=1, max_size=4))
def test_any_finite_odometry_gives_a_finite_force_within_the_limit(lone_keeper, gains,
                                                                   max_force, depth, states):
    kp, kd, ki = gains
    assert all(r.successful for r in lone_keeper.set_parameters([
        Parameter('kp', value=kp), Parameter('kd', value=kd), Parameter('ki', value=ki),
        Parameter('max_force', value=max_force), Parameter('target_depth', value=depth)]))
    lone_keeper.last_stamp, lone_keeper.integral_force = None, 0.0
    for z, vz, sec in states:
        force = lone_keeper.force_for(odometry(z, vz=vz, t=sec))
        assert math.isfinite(force) and abs(force) <= max_force


def test_extreme_odometry_saturates_instead_of_giving_nan(lone_keeper):
    lone_keeper.set_parameters([Parameter(name, value=1e9) for name in ('kp', 'kd', 'ki')] +
                               [Parameter('max_force', value=2000.0)])
    lone_keeper.last_stamp, lone_keeper.integral_force = None, 0.0
    # kp * error = +inf and kd * vz = +inf: their difference would be NaN unclipped.
    force = lone_keeper.force_for(odometry(-1.7e308, vz=1.7e308, t=0))
    assert math.isfinite(force) and abs(force) <= 2000.0
    assert lone_keeper.force_for(odometry(-1.7e308, vz=0.0, t=2**31 - 1)) == 2000.0
    assert abs(lone_keeper.integral_force) <= 2000.0


# The executable, out of process.

def start(*ros_args):
    env = dict(os.environ, PYTHONPATH=str(REPO))
    return subprocess.Popen(
        [sys.executable, '-m', 'pool_sim.ros.depth_keeper', '--ros-args', *ros_args],
        env=env, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True,
        # A shell without job control starts background jobs with SIGINT ignored.
        preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL))


def test_what_a_signal_leaves_half_built_prints_no_traceback_but_a_live_fault_does(
        monkeypatch):
    shown = []
    monkeypatch.setattr(executables, '_stopping', False)
    monkeypatch.setattr(sys, 'unraisablehook', functools.partial(
        executables._quiet_once_stopping, previous_hook=shown.append))

    class Faulty:
        def __del__(self):
            raise AttributeError('half built')
    Faulty()
    gc.collect()
    assert len(shown) == 1  # while the node runs: shown as ever
    monkeypatch.setattr(executables, '_stopping', True)  # as the first signal sets it
    Faulty()
    gc.collect()
    assert len(shown) == 1


def test_ctrl_c_while_spin_builds_its_executor_exits_0_without_a_traceback():
    # The race, made certain: the signal lands as the executor is made, once rclpy's C++
    # part has built it and before it is the executable's.
    script = '\n'.join([
        'import signal, sys', 'import rclpy.experimental', 'from pool_sim.ros import executables',
        'make = rclpy.experimental.EventsExecutor',
        'def interrupted(*args, **kwargs):', '    make(*args, **kwargs)',
        '    executables._raise_stop(signal.SIGINT, None)',
        'rclpy.experimental.EventsExecutor = interrupted',
        'from pool_sim.ros.depth_keeper import main',
        "sys.exit(main(['depth_keeper', '--ros-args', '-p', 'sphere:=titanium']))"])
    done = subprocess.run([sys.executable, '-c', script], capture_output=True, text=True,
                          env=dict(os.environ, PYTHONPATH=str(REPO)), timeout=30)
    assert done.returncode == 0, done.stderr
    assert 'holding titanium' in done.stderr and 'Traceback' not in done.stderr, done.stderr


@pytest.mark.parametrize('stop', [signal.SIGINT, signal.SIGTERM])
def test_the_executable_takes_an_integer_gain_and_stops_cleanly(stop):
    process = start('-p', 'kp:=600', '-p', 'sphere:=titanium')
    watchdog = threading.Timer(20.0, process.kill)  # so that readline cannot wait for ever
    watchdog.start()
    try:
        line = process.stdout.readline()  # the first log line
        assert 'holding titanium at 1 m depth' in line, line
        process.send_signal(stop)
        output, _ = process.communicate(timeout=10)
    finally:
        watchdog.cancel()
        process.kill()
    assert process.returncode == 0, line + output
    assert 'Traceback' not in output, output


def test_the_executable_exits_1_naming_a_bad_parameter_without_a_traceback():
    cases = {'kp:=abc': 'kp: expected a number', 'kp:=-1.0': 'kp: must be a number',
             'sphere:=a-b': 'sphere: must be a ROS name token'}
    processes = {arg: start('-p', arg) for arg in cases}  # side by side: each starts rclpy
    for arg, process in processes.items():
        try:
            output, _ = process.communicate(timeout=20)
        finally:
            process.kill()
        assert process.returncode == 1, output
        assert 'Traceback' not in output, output
        [line] = output.strip().splitlines()
        assert 'refusing to start: ' + cases[arg] in line, output


def test_a_clean_up_that_hangs_still_ends_the_process():
    # As a DDS participant waiting for ever on a listener did once: the process ends anyway,
    # from faulthandler's thread, after CLEANUP_LIMIT_S (here 1 s), with exit code 1.
    script = '\n'.join([
        'import sys, time', 'from pool_sim.ros import executables',
        'executables.CLEANUP_LIMIT_S = 1.0',
        'from pool_sim.ros import depth_keeper',
        'depth_keeper.DepthKeeper.destroy_node = lambda self: time.sleep(1000)',
        "sys.exit(depth_keeper.main(['depth_keeper', '--ros-args', '-p', 'sphere:=titanium']))"])
    process = subprocess.Popen([sys.executable, '-c', script], stderr=subprocess.PIPE,
                               text=True, env=dict(os.environ, PYTHONPATH=str(REPO)))
    try:
        assert 'holding titanium' in process.stderr.readline()  # logged in __init__
        time.sleep(1.0)  # spinning by now
        process.send_signal(signal.SIGTERM)
        started = time.monotonic()
        process.wait(timeout=20)
        assert time.monotonic() - started < 10.0
        assert process.returncode == 1
    finally:
        process.kill()
