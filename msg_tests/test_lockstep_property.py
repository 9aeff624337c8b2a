"""Hypothesis: any sequence of what a test does to a lockstep node (advance, reset, set_mass,
set_radius, pause and step, spawn and remove, lockstep settings, forces pushed directly) gives
bitwise the same states when played twice, and the keeper never misses an instant."""
import hashlib

from hypothesis import given, HealthCheck, settings, strategies as st
from rcl_interfaces.srv import SetParameters
from rclpy.parameter import Parameter
from std_srvs.srv import SetBool, Trigger

from pool_sim.ros.depth_keeper import DepthKeeper
from pool_sim.testing import PoolSim

SCENE = {'lockstep_inputs': ['ice'], 'wrench_timeout': 0.0, 'real_time_factor': 0.0}
operations = st.lists(st.one_of(
    st.tuples(st.just('advance'), st.sampled_from([0.02, 0.1, 0.5, 1.0])),
    st.tuples(st.just('reset'), st.none()),
    st.tuples(st.just('set_mass'), st.tuples(st.sampled_from(['cork', 'steel', 'ice']),
                                            st.floats(0.5, 50.0))),
    st.tuples(st.just('set_radius'), st.tuples(st.sampled_from(['cork', 'steel']),
                                              st.floats(0.05, 0.3))),
    st.tuples(st.just('pause_and_step'), st.integers(1, 3)),
    st.tuples(st.just('spawn'), st.floats(-3.0, 3.0)),
    st.tuples(st.just('remove'), st.none()),
    st.tuples(st.just('push'), st.tuples(st.sampled_from(['cork', 'steel']),
                                        st.floats(-500.0, 500.0))),
    st.tuples(st.just('timeout'), st.floats(1.0, 30.0)),
), min_size=1, max_size=8)


def play(ops):
    """Digests of the states after each operation, and the misses."""
    found = []
    with PoolSim(SCENE) as sim:
        sim.add(DepthKeeper)
        for name, value in ops:
            if name == 'advance':
                sim.advance(value)
            elif name == 'reset':
                assert sim.call(Trigger, 'reset', Trigger.Request()).success
            elif name in ('set_mass', 'set_radius'):
                sphere, number = value
                sim.call(SetParameters, name, SetParameters.Request(
                    parameters=[Parameter(sphere, value=number).to_parameter_msg()]))
            elif name == 'pause_and_step':
                sim.call(SetBool, 'pause', SetBool.Request(data=True))
                for _ in range(value):
                    sim.call(Trigger, 'step', Trigger.Request())
                sim.call(SetBool, 'pause', SetBool.Request(data=False))
            elif name == 'spawn' and 'buoy' not in sim.node.simulation.spheres.names:
                sim.node.set_parameters_atomically([
                    Parameter('sphere_names',
                              value=list(sim.node.simulation.spheres.names) + ['buoy']),
                    Parameter('buoy.position', value=[value, 1.0, 1.0])])
            elif name == 'remove' and 'buoy' in sim.node.simulation.spheres.names:
                sim.node.set_parameters_atomically([
                    Parameter('sphere_names', value=['cork', 'steel', 'ice'])])
            elif name == 'push':
                sim.set_force(value[0], [0.0, 0.0, value[1]])
            elif name == 'timeout':
                sim.node.set_parameters([Parameter('lockstep_timeout', value=value)])
            sim.advance(0.1)  # the keeper answers after every operation
            found.append(hashlib.sha256(sim.states().tobytes()).hexdigest())
        return found, sim.node.lockstep.misses


@settings(deadline=None, suppress_health_check=[HealthCheck.too_slow],  # ci 8, deep 200
          max_examples=max(8, settings.default.max_examples // 5))
@given(operations)
def test_any_sequence_played_twice_gives_the_same_states(ops):
    first, misses = play(ops)
    assert misses == 0
    assert play(ops) == (first, 0)
