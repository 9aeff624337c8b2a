"""Lockstep: closed loops as fast as the nodes answer, with bitwise the same numbers every run
(in-process, across processes, under load, on 1 or 2 numba threads); ~/step; bad input."""
import hashlib
import math
import time

from geometry_msgs.msg import Wrench, WrenchStamped
import numpy as np
import pytest
from rcl_interfaces.srv import SetParameters
from rclpy.parameter import Parameter
from std_srvs.srv import SetBool, Trigger

from lockstep_nodes import (ArrayKeeper, first_difference, LOCKSTEP_PARAMS,
                            record_across_processes, record_in_process)
from pool_sim.physics import InvalidInput, Scene, stepper
from pool_sim.ros.depth_keeper import DepthKeeper
from pool_sim.ros.node_keys import NODE_SCENE
from pool_sim.testing import PoolSim

KEEPER_SCENE = {'lockstep_inputs': ['ice'], 'wrench_timeout': 0.0, 'real_time_factor': 0.0}


def digests(sim, seconds, every_s=1.0):
    """sha256 of every sphere's state after each `every_s` simulated seconds."""
    found = []
    for _ in range(round(seconds / every_s)):
        sim.advance(every_s)
        found.append(hashlib.sha256(sim.states().tobytes()).hexdigest())
    return found


def keeper_run(pool_sim, executor='events'):
    sim = pool_sim(KEEPER_SCENE, executor=executor)
    sim.add(DepthKeeper)
    return sim, digests(sim, 20.0)


def test_the_depth_keeper_loop_is_bitwise_the_same_every_run_and_holds_ice(pool_sim):
    sim, first = keeper_run(pool_sim)
    position, _ = sim.state('ice')
    assert abs(position[2] + 1.0) < 0.05  # PD alone: net buoyancy / kp = 1.9 cm
    assert sim.time == pytest.approx(20.0, abs=0.005)
    assert sim.node.lockstep.misses == 0
    for _ in range(3):
        assert keeper_run(pool_sim)[1] == first
    # The executor does not matter either: the loop is the same loop.
    assert keeper_run(pool_sim, executor='single')[1] == first


class TwiceKeeper(DepthKeeper):
    """depth_keeper answering every instant twice (the same stamped force)."""

    def _publish_force(self, sphere, force_z, stamp):
        super()._publish_force(sphere, force_z, stamp)
        super()._publish_force(sphere, force_z, stamp)


def test_each_period_steps_once_however_often_a_controller_answers(pool_sim):
    once = pool_sim(KEEPER_SCENE)
    once.add(DepthKeeper)
    twice = pool_sim(KEEPER_SCENE)
    twice.add(TwiceKeeper)
    assert digests(once, 5.0) == digests(twice, 5.0)
    assert once.node.clock.steps_taken == twice.node.clock.steps_taken == 5 * 200  # 200 Hz physics


def test_the_forces_array_answers_unstamped(pool_sim):
    sim = pool_sim({**KEEPER_SCENE, 'lockstep_inputs': ['forces'], 'per_sphere_topics': False})
    sim.add(ArrayKeeper)
    first = digests(sim, 5.0)
    assert sim.node.lockstep.misses == 0
    # Every sphere held where a PD law leaves it: (buoyancy - weight) / kp above -1 m.
    spheres = sim.node.simulation.spheres
    volume = 4.0 / 3.0 * math.pi * spheres.radius**3
    offset = (1000.0 * volume - spheres.mass) * 9.81 / 600.0
    assert np.all(np.abs(sim.states()[:, 2] - (-1.0 + offset)) < 0.01)
    again = pool_sim({**KEEPER_SCENE, 'lockstep_inputs': ['forces'],
                      'per_sphere_topics': False})
    again.add(ArrayKeeper)
    assert digests(again, 5.0) == first


def test_two_numba_threads_give_the_same_loop_as_one(pool_sim):
    count = 2 * stepper.parallel_from_spheres()  # the parallel build runs
    names = [f's{i}' for i in range(count)]
    scene = {**KEEPER_SCENE, 'lockstep_inputs': ['forces'], 'per_sphere_topics': False,
             'sphere_names': names,
             'spheres': {'mass': [1.0 + 0.01 * i for i in range(count)],
                         'position': {'x': [-3.0 + 6.0 * i / count for i in range(count)],
                                      'y': [0.0] * count, 'z': [1.0] * count}}}
    found = []
    for threads in (1, 2, 1):
        stepper.use_threads(threads)
        try:
            sim = pool_sim(scene)
            sim.add(ArrayKeeper)
            found.append(digests(sim, 3.0))
        finally:
            stepper.use_threads(1)
    assert found[0] == found[1] == found[2]


def test_a_dead_controller_costs_one_timeout_then_a_late_one_joins(pool_sim, capfd):
    sim = pool_sim({**KEEPER_SCENE, 'lockstep_timeout': 0.3})
    started = time.monotonic()
    sim.advance(1.0)  # nobody answers ice
    assert 0.3 <= time.monotonic() - started < 2.0
    assert sim.node.lockstep.misses == 1
    assert 'lockstep: no answer from ice to t=0.000000 s within 0.3 s' in capfd.readouterr().err
    assert '1 instants went on without an answer' in sim.node.time_report()
    # A controller that comes later is waited for again from its first answer on.
    sim.add(DepthKeeper)
    sim.advance(2.0)
    assert sim.node.lockstep.misses == 1 and not sim.node.lockstep.absent
    z_before = sim.state('ice')[0][2]
    sim.advance(10.0)
    assert abs(sim.state('ice')[0][2] + 1.0) < abs(z_before + 1.0) + 0.05


def test_an_answer_stamped_before_the_instant_does_not_count(pool_sim):
    sim = pool_sim({**KEEPER_SCENE, 'lockstep_timeout': 0.2})
    stale = sim.node.create_publisher(WrenchStamped, 'pool_sim/wrench', 10)
    sim.advance(0.1)  # one miss at t=0: ice absent from then on; it answers again below
    misses = sim.node.lockstep.misses
    message = WrenchStamped()
    message.header.frame_id = 'ice'
    message.header.stamp.sec = 0
    message.header.stamp.nanosec = 1  # after 0, before every later instant
    stale.publish(message)
    sim.advance(0.1)
    sim.advance(0.1)  # back, and waited for: its stamp is older than this instant
    assert sim.node.lockstep.misses == misses + 1


def test_unstamped_wrench_answers_the_instant_published_before_it(pool_sim):
    sim = pool_sim({**KEEPER_SCENE, 'lockstep_timeout': 5.0})
    publisher = sim.node.create_publisher(Wrench, 'pool_sim/ice/wrench', 10)

    def answer(_):
        publisher.publish(Wrench())
    sim.node.create_subscription(WrenchStamped, 'unused', answer, 10)
    from nav_msgs.msg import Odometry
    sim.node.create_subscription(Odometry, 'pool_sim/ice/odom', answer, 10)
    sim.node.republish_state()
    started = time.monotonic()
    sim.advance(2.0)
    assert time.monotonic() - started < 2.0 and sim.node.lockstep.misses == 0


def test_lockstep_with_the_clock_thread_pause_reset_set_mass_and_spawn(pool_sim):
    sim = pool_sim({**KEEPER_SCENE, 'real_time_factor': 0.0}, run_clock=True,
                   executor='single')
    sim.add(DepthKeeper)
    assert sim.spin(lambda: sim.node.simulation.time > 2.0, 20.0)
    assert sim.call(SetBool, 'pause', SetBool.Request(data=True)).success
    paused_at = sim.time
    time.sleep(0.2)
    assert sim.time == paused_at
    stepped = sim.call(Trigger, 'step', Trigger.Request())
    assert stepped.success and f't={sim.time:.9f} s' in stepped.message
    assert sim.time == pytest.approx(paused_at + 1 / 30, abs=0.005)
    result = sim.call(SetParameters, 'set_mass', SetParameters.Request(
        parameters=[Parameter('steel', value=5.0).to_parameter_msg()])).results[0]
    assert result.successful
    assert sim.call(Trigger, 'reset', Trigger.Request()).success and sim.time == 0.0
    spawn = sim.node.set_parameters_atomically([
        Parameter('sphere_names', value=['cork', 'steel', 'ice', 'buoy']),
        Parameter('buoy.position', value=[1.0, 1.0, 2.0])])
    assert spawn.successful
    assert sim.call(SetBool, 'pause', SetBool.Request(data=False)).success
    assert sim.spin(lambda: sim.node.simulation.time > 3.0, 20.0)
    assert sim.node.lockstep.misses == 0  # the keeper answered every instant throughout


def test_step_is_refused_while_running_and_steps_one_period_while_paused(pool_sim):
    sim = pool_sim({'real_time_factor': 1.0}, lockstep=False, run_clock=True)
    refused = sim.call(Trigger, 'step', Trigger.Request())
    assert not refused.success and 'not paused' in refused.message
    assert sim.call(SetBool, 'pause', SetBool.Request(data=True)).success
    times, publishes = [sim.time], sim.node.publishing.publishes
    for k in range(1, 4):
        answer = sim.call(Trigger, 'step', Trigger.Request())
        assert answer.success and answer.message.endswith(f't={sim.time:.9f} s')
        assert sim.node.publishing.publishes == publishes + k  # that instant's state is out
        times.append(sim.time)
    # To the next publish instant (paused between two), then a period each (1/30 s on the
    # 200 Hz grid: 30 or 35 ms).
    steps = np.diff(times)
    assert 0.0 < steps[0] <= 0.035 + 1e-9
    assert all(s == pytest.approx(0.03) or s == pytest.approx(0.035) for s in steps[1:])
    time.sleep(0.1)
    assert sim.node.clock.paused and sim.time == times[-1]


@pytest.mark.parametrize('key, value, words', [
    ('lockstep_inputs', ['ice', 'titanium'], 'lockstep_inputs: titanium not in sphere_names'),
    ('lockstep_inputs', ['ice', 'ice'], 'lockstep_inputs: must be names without repeats'),
    ('lockstep_inputs', 'ice', 'lockstep_inputs: expected a list of strings'),
    ('lockstep_timeout', -1.0, 'lockstep_timeout'),
    ('lockstep_timeout', 0.0, 'lockstep_timeout'),
    ('lockstep_timeout', math.nan, 'lockstep_timeout'),
    ('lockstep_timeout', math.inf, 'lockstep_timeout'),
    ('lockstep_timeout', 1e300, 'lockstep_timeout'),
    ('lockstep', 'yes', 'lockstep: expected true or false'),
])
def test_bad_lockstep_settings_are_refused_naming_the_key(pool_sim, key, value, words):
    # In a scene (a params file) ...
    with pytest.raises(InvalidInput, match=words):
        Scene.default(NODE_SCENE).with_values(**{key: value})
    # ... and live, as `ros2 param set` sends it: refused, nothing changed.
    sim = pool_sim({'lockstep_inputs': ['ice']})
    before = {name: sim.node.get_parameter(name).value
              for name in ('lockstep', 'lockstep_inputs', 'lockstep_timeout')}
    [result] = sim.node.set_parameters([Parameter(key, value=value)])
    # A value of another type rclpy refuses itself, with its reason.
    assert not result.successful
    assert key in result.reason or 'Wrong parameter type' in result.reason
    assert {name: sim.node.get_parameter(name).value for name in before} == before
    assert sim.node.lockstep.inputs == ('ice',)


def test_forces_is_no_sphere_name_and_a_listed_sphere_stays(pool_sim):
    with pytest.raises(InvalidInput, match="sphere_names: 'forces' is taken"):
        Scene.default(NODE_SCENE).with_values(sphere_names=['forces'])
    sim = pool_sim({'lockstep_inputs': ['ice', 'forces']})
    removal = sim.node.set_parameters_atomically([
        Parameter('sphere_names', value=['cork', 'steel'])])
    assert not removal.successful and 'lockstep_inputs: ice not in sphere_names' in \
        removal.reason
    assert sim.node.simulation.spheres.names == ('cork', 'steel', 'ice')
    # Removed together with its entry: fine.
    removal = sim.node.set_parameters_atomically([
        Parameter('sphere_names', value=['cork', 'steel']),
        Parameter('lockstep_inputs', value=['forces'])])
    assert removal.successful, removal.reason
    assert sim.node.lockstep.inputs == ('forces',)
    # Live settings take effect at once.
    assert sim.node.set_parameters([Parameter('lockstep', value=False)])[0].successful
    assert not sim.node.lockstep.enabled and sim.node.lockstep.awaited_ns is None
    assert sim.node.set_parameters([Parameter('lockstep_timeout', value=2)])[0].successful
    assert sim.node.lockstep.timeout_s == 2.0


# Across processes, as users start them: `ros2 run pool_sim pool_sim` with lockstep and
# depth_keeper as a second process; the test process records every instant (answering for
# cork, so it misses none). Compared with the same loop in-process.

def test_across_processes_and_under_load_the_loop_is_the_in_process_one(pool_sim, tmp_path):
    params_file = tmp_path / 'lockstep.yaml'
    params_file.write_text(LOCKSTEP_PARAMS)
    with PoolSim(params_file=params_file) as sim:
        expected, count, instants = record_in_process(sim)
    assert count == 601  # t = 0 and 30 instants a simulated second (on the 200 Hz grid)
    for hogs in (0, 2):
        _, digest, _, found = record_across_processes(params_file, hogs=hogs)
        assert digest == expected, f'{hogs} hogs: {first_difference(instants, found)}'



# Found by review: what is in flight across a reset, copies and unstamped answers, stamps
# from another clock, odd frame_ids, a spawn request through ~/set_parameters.

def test_a_reset_starts_the_turns_again_whatever_answer_is_in_flight(pool_sim):
    fresh = pool_sim(KEEPER_SCENE)
    fresh.add(DepthKeeper)
    expected = digests(fresh, 2.0)
    sim = pool_sim(KEEPER_SCENE)
    sim.add(DepthKeeper)
    sim.advance(3.0)  # the keeper's answer to t = 3 s is on its way
    assert sim.call(Trigger, 'reset', Trigger.Request()).success
    assert digests(sim, 2.0) == expected
    assert sim.node.lockstep.misses == 0


class SlowFirstArrayKeeper(ArrayKeeper):
    """Takes 0.8 s over its first answer (a controller warming up)."""

    def _on_states(self, message):
        if not getattr(self, 'warmed', False):
            self.warmed = True
            time.sleep(0.8)
        super()._on_states(message)


def test_an_unstamped_controller_is_never_sent_a_copy_it_would_answer_twice(pool_sim):
    scene = {**KEEPER_SCENE, 'lockstep_inputs': ['forces'], 'per_sphere_topics': False}
    quick = pool_sim(scene)
    quick.add(ArrayKeeper)
    expected = digests(quick, 3.0)
    slow = pool_sim(scene)
    slow.add(SlowFirstArrayKeeper)
    assert digests(slow, 3.0) == expected
    assert slow.node.publishing.publishes == quick.node.publishing.publishes  # no copies sent


def test_a_stamp_after_the_newest_instant_answers_nothing(pool_sim, capfd):
    sim = pool_sim({**KEEPER_SCENE, 'lockstep_timeout': 0.2})
    wall_clock = sim.node.create_publisher(WrenchStamped, 'pool_sim/wrench', 10)
    message = WrenchStamped()
    message.header.frame_id = 'ice'
    message.header.stamp.sec = 1_800_000_000  # as get_clock().now() stamps it
    for _ in range(3):
        sim.advance(0.1)
        wall_clock.publish(message)
    assert sim.node.lockstep.misses == 1  # never counted: missed once, then not waited for
    assert 'after the newest instant published' in capfd.readouterr().err
    assert 'ice' not in sim.node.inputs.answered_ns


def test_frame_ids_of_no_input_are_not_recorded(pool_sim):
    sim = pool_sim({**KEEPER_SCENE, 'lockstep_inputs': ['ice'], 'lockstep_timeout': 0.2})
    stranger = sim.node.create_publisher(WrenchStamped, 'pool_sim/wrench', 10)
    for frame in ('zzz', 'forces', '', 'a' * 1000):
        message = WrenchStamped()
        message.header.frame_id = frame
        stranger.publish(message)
    sim.advance(0.1)
    assert set(sim.node.inputs.answered_ns) <= {'ice'}


def test_a_spawn_request_carries_the_lockstep_keys_through_set_parameters(pool_sim):
    sim = pool_sim({'lockstep_inputs': ['ice', 'forces']})
    request = SetParameters.Request(parameters=[
        Parameter('lockstep_inputs', value=['forces']).to_parameter_msg(),
        Parameter('sphere_names', value=['cork', 'steel']).to_parameter_msg()])
    results = sim.call(SetParameters, 'set_parameters', request).results
    assert [r.successful for r in results] == [True, True], results
    assert sim.node.simulation.spheres.names == ('cork', 'steel')
    assert sim.node.lockstep.inputs == ('forces',)


def test_advance_refuses_a_node_with_its_own_clock(pool_sim):
    sim = pool_sim(run_clock=True)
    with pytest.raises(RuntimeError, match='clock thread'):
        sim.advance(1.0)
