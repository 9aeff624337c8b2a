"""A live node driven by random sequences of hostile requests (hypothesis' stateful testing).

Rules: set_mass / set_radius with every ParameterValue type (unknown type codes too), the
whole double range (NaN, +-inf, subnormals, +-1e308) and unknown or repeated names;
`ros2 param set` through rclpy's parameter services; wrenches from the whole double range;
pause; reset; letting it run. After every rule: the node answers within a bound, every
published pose is finite and inside the pool, and the masses and radii are exactly what
the accepted requests made them (a refused entry changed nothing).
"""
import math
import os
import time

from geometry_msgs.msg import PoseArray, Wrench
from hypothesis import HealthCheck, settings, strategies as st
from hypothesis.stateful import initialize, invariant, rule, RuleBasedStateMachine
from rcl_interfaces.msg import Parameter as ParameterMessage, ParameterType, ParameterValue
from rcl_interfaces.srv import GetParameters, SetParameters
from std_srvs.srv import SetBool, Trigger

from ros_harness import Harness

SPHERES = ('cork', 'steel', 'ice')
NAMES = st.sampled_from(SPHERES + ('moon', '', 'cork.mass', 'Cork', 'x' * 500, 'ice '))
ANSWER_BOUND_S = 2.0  # in-process, client and node share one executor and the GIL
POOL_HALF_WIDTH_M = 4.0

ANY_DOUBLE = st.one_of(
    st.floats(allow_nan=True, allow_infinity=True, allow_subnormal=True),
    st.sampled_from([0.0, -0.0, 5e-324, -5e-324, 1e-310, 1e-6, 1e9, 1e160, 1e308, -1e308,
                     math.nan, math.inf, -math.inf]),
    st.floats(1e-3, 50.0))  # the values a user means: some are accepted
ANY_INTEGER = st.one_of(st.integers(-2**63, 2**63 - 1), st.integers(-3, 60))


@st.composite
def parameter_values(draw):
    """A ParameterValue of any type code, with a value of that type (or none)."""
    kind = draw(st.sampled_from(['double', 'integer', 'bool', 'string', 'not_set',
                                 'unknown', 'double_array', 'integer_array', 'string_array',
                                 'bool_array', 'byte_array']))
    value = ParameterValue()
    if kind == 'double':
        value.type, value.double_value = ParameterType.PARAMETER_DOUBLE, draw(ANY_DOUBLE)
    elif kind == 'integer':
        value.type, value.integer_value = ParameterType.PARAMETER_INTEGER, draw(ANY_INTEGER)
    elif kind == 'bool':
        value.type, value.bool_value = ParameterType.PARAMETER_BOOL, draw(st.booleans())
    elif kind == 'string':
        value.type = ParameterType.PARAMETER_STRING
        value.string_value = draw(st.one_of(st.text(max_size=20), st.just('9' * 10_000)))
    elif kind == 'not_set':
        value.type = ParameterType.PARAMETER_NOT_SET
    elif kind == 'unknown':
        value.type = draw(st.integers(10, 255))
    elif kind == 'double_array':
        value.type = ParameterType.PARAMETER_DOUBLE_ARRAY
        value.double_array_value = draw(st.lists(ANY_DOUBLE, max_size=4))
    elif kind == 'integer_array':
        value.type = ParameterType.PARAMETER_INTEGER_ARRAY
        value.integer_array_value = draw(st.lists(ANY_INTEGER, max_size=4))
    elif kind == 'string_array':
        value.type = ParameterType.PARAMETER_STRING_ARRAY
        value.string_array_value = draw(st.lists(st.text(max_size=5), max_size=3))
    elif kind == 'bool_array':
        value.type = ParameterType.PARAMETER_BOOL_ARRAY
        value.bool_array_value = draw(st.lists(st.booleans(), max_size=3))
    else:
        value.type = ParameterType.PARAMETER_BYTE_ARRAY
        value.byte_array_value = [bytes([b]) for b in draw(st.binary(max_size=3))]
    return value


PARAMETER_NAMES = st.one_of(
    st.builds(lambda s, k: f'{s}.{k}', st.sampled_from(SPHERES + ('moon',)),
              st.sampled_from(['mass', 'radius', 'position', 'drag_coefficient'])),
    st.sampled_from(['gravity', 'physics_rate_hz', 'effects', 'sphere_names', 'no_such_key',
                     'use_sim_time', '', 'qos_overrides./clock.publisher.depth']))


class LiveNode(RuleBasedStateMachine):

    @initialize()
    def start_the_node(self):
        self.harness = Harness({'real_time_factor': 0.0})
        self.ros = self.harness.__enter__()
        self.poses = self.ros.collect(PoseArray, 'poses')
        self.clients = {}
        for service_type, name in ((SetParameters, 'set_mass'), (SetParameters, 'set_radius'),
                                   (SetParameters, 'set_parameters'),
                                   (GetParameters, 'get_parameters'),
                                   (SetBool, 'pause'), (Trigger, 'reset')):
            self.clients[name] = self.ros.client.create_client(service_type,
                                                               self.ros.topic(name))
            assert self.clients[name].wait_for_service(timeout_sec=5.0)
        self.wrenches = {name: self.ros.client.create_publisher(
            Wrench, self.ros.topic(f'{name}/wrench'), 10) for name in SPHERES}
        spheres = self.ros.sim.simulation.spheres
        self.initial = {'mass': spheres.mass.copy(), 'radius': spheres.radius.copy()}
        self.expected = {key: values.copy() for key, values in self.initial.items()}

    def teardown(self):
        if hasattr(self, 'harness'):
            self.harness.__exit__(None, None, None)

    def call(self, name, request):
        started = time.monotonic()
        future = self.clients[name].call_async(request)
        self.ros.executor.spin_until_future_complete(future, timeout_sec=ANSWER_BOUND_S)
        assert future.done(), f'{name} did not answer within {ANSWER_BOUND_S} s'
        assert time.monotonic() - started < ANSWER_BOUND_S
        return future.result()

    def expect_results(self, key_of_entry, entries, results):
        assert len(results) == len(entries)
        for (name, key), result in zip(key_of_entry, results):
            if result.successful:
                i = SPHERES.index(name)
                self.expected[key][i] = self.ros.sim.simulation.spheres.__dict__[key][i]
            else:
                assert result.reason  # a refusal always says why
                assert len(result.reason) < 400

    @rule(key=st.sampled_from(['mass', 'radius']),
          entries=st.lists(st.tuples(NAMES, parameter_values()), max_size=4))
    def set_sphere(self, key, entries):
        request = SetParameters.Request(parameters=[
            ParameterMessage(name=name, value=value) for name, value in entries])
        results = self.call(f'set_{key}', request).results
        self.expect_results([(name, key) for name, _ in entries], entries, results)
        for (name, value), result in zip(entries, results):
            if result.successful:  # only finite numbers within the range get through
                assert value.type in (ParameterType.PARAMETER_DOUBLE,
                                      ParameterType.PARAMETER_INTEGER)

    @rule(entries=st.lists(st.tuples(PARAMETER_NAMES, parameter_values()), max_size=3))
    def ros2_param_set(self, entries):
        request = SetParameters.Request(parameters=[
            ParameterMessage(name=name, value=value) for name, value in entries])
        results = self.call('set_parameters', request).results
        assert len(results) == len(entries)
        for (name, value), result in zip(entries, results):
            sphere, _, key = name.partition('.')
            if result.successful and sphere in SPHERES and key in ('mass', 'radius'):
                i = SPHERES.index(sphere)
                self.expected[key][i] = getattr(self.ros.sim.simulation.spheres, key)[i]
            elif result.successful:
                assert name == 'use_sim_time', (name, value)

    @rule(sphere=st.sampled_from(SPHERES),
          force=st.tuples(*[st.one_of(ANY_DOUBLE, st.floats(-1e9, 1e9))] * 3))
    def wrench(self, sphere, force):
        message = Wrench()
        message.force.x, message.force.y, message.force.z = force
        self.wrenches[sphere].publish(message)
        self.ros.spin_for(0.02)

    @rule(paused=st.booleans())
    def pause(self, paused):
        assert self.call('pause', SetBool.Request(data=paused)).success

    @rule()
    def reset(self):
        assert self.call('reset', Trigger.Request()).success
        self.expected = {key: values.copy() for key, values in self.initial.items()}

    @rule(seconds=st.sampled_from([0.01, 0.05, 0.2]))
    def run(self, seconds):
        self.ros.spin_for(seconds)

    @invariant()
    def alive_finite_inside_and_as_asked(self):
        if not hasattr(self, 'ros'):
            return
        answer = self.call('get_parameters', GetParameters.Request(names=['cork.mass']))
        assert len(answer.values) == 1
        spheres = self.ros.sim.simulation.spheres
        for key in ('mass', 'radius'):
            assert getattr(spheres, key).tolist() == self.expected[key].tolist(), key
            for i, name in enumerate(SPHERES):
                assert self.ros.sim.get_parameter(f'{name}.{key}').value == \
                    self.expected[key][i]
        for message in self.poses:
            for pose, radius in zip(message.poses, spheres.radius):
                for coordinate in (pose.position.x, pose.position.y, pose.position.z):
                    assert math.isfinite(coordinate)
                    assert abs(coordinate) <= POOL_HALF_WIDTH_M
        self.poses.clear()


# A fixed set in CI (profile 'ci'), new ones locally, many more in the deep profile.
_profile_examples = settings().max_examples
LiveNode.TestCase.settings = settings(
    max_examples=max(10, _profile_examples // 2), stateful_step_count=12, deadline=None,
    suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large],
    derandomize=os.environ.get('HYPOTHESIS_PROFILE') == 'ci')
test_a_live_node_survives_random_hostile_sequences = LiveNode.TestCase
