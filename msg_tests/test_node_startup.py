"""How the node starts: defaults, params that are refused, an empty effects list, the keeper."""
from geometry_msgs.msg import PoseArray
import pytest
import rclpy
from rclpy.context import Context

from pool_sim.physics import InvalidInput
from pool_sim.ros.depth_keeper import DepthKeeper
from pool_sim.ros.simulator_node import named_few, PoolSimNode
from ros_harness import Harness, overrides


def test_without_a_params_file_it_runs_the_seeds_pool_with_every_key_declared():
    with Harness() as ros:
        assert ros.sim.get_parameter('sphere_names').value == ['cork', 'steel', 'ice']
        assert ros.sim.get_parameter('effects').value == [
            'gravity', 'buoyancy', 'drag', 'wave_radiation', 'contact', 'friction']
        assert ros.sim.get_parameter('steel.drag_coefficient').value == 0.47
        assert list(ros.sim.get_parameter('pool.min').value) == [-4.0, -4.0, -4.0]
        assert ros.sim.get_parameter('integrator').value == 'linearly_implicit_euler'


@pytest.mark.parametrize('params, message', [
    ({'cork.colour': 'red'}, 'cork.colour: unknown key'),
    ({'cork.mass': 'heavy'}, 'cork.mass: expected a number'),
    ({'physics_rate_hz': -5.0}, r'physics_rate_hz: must be within \[1, 100000\] Hz'),
    ({'sphere_names': []}, 'sphere_names: the node needs at least one sphere'),
    ({'sphere_names': ['a'], 'cork.mass': 1.0}, 'cork.mass: unknown key'),
    ({'integrator': 'magic'}, 'integrator: must be one of'),
    ({'backend': 'gpu'}, r"backend: must be one of \['cpu', 'cuda'\]"),
    # No GPU here (test_cuda_backend's simulator runs in a child process of its own).
    ({'backend': 'cuda'}, 'backend: cuda cannot run here: no'),
])
def test_a_bad_parameter_stops_the_node_naming_the_key(params, message):
    context = Context()
    rclpy.init(context=context)
    try:
        with pytest.raises(InvalidInput, match=message):
            PoolSimNode(context=context, parameter_overrides=overrides(params))
    finally:
        rclpy.shutdown(context=context)


def test_an_empty_effects_list_arrives_unset_and_means_nothing_runs_but_external_forces():
    params = {'effects': [], 'real_time_factor': 0.0}
    with Harness(params) as ros:
        assert ros.sim.simulation.stepper.configuration[1] == (False,) * 6 + (True, True)
        poses = ros.collect(PoseArray, 'poses')
        assert ros.spin_until(lambda: ros.sim.simulation.time > 1.0 and poses)
        # No gravity: everything floats where it was put.
        assert ros.sim.simulation.spheres.position[2].tolist() == [3.7, 3.8, 3.75]


def test_a_new_sphere_list_from_a_params_file_starts_from_the_schema_defaults():
    params = {'sphere_names': ['buoy'], 'buoy.position': [1.0, 1.0, -1.0]}
    with Harness(params) as ros:
        spheres = ros.sim.simulation.spheres
        assert spheres.names == ('buoy',)
        assert spheres.mass.tolist() == [1.0] and spheres.radius.tolist() == [0.1]


def test_the_depth_keeper_holds_its_sphere_within_5_cm_after_20_s():
    target_depth = 1.0

    def keeper(**kwargs):
        return DepthKeeper(parameter_overrides=overrides(
            {'sphere': 'ice', 'target_depth': target_depth}), **kwargs)
    with Harness({'real_time_factor': 5.0}, extra_nodes=[keeper]) as ros:
        assert ros.spin_until(lambda: ros.sim.simulation.time >= 20.0, timeout_s=30.0)
        z = ros.state('ice')[0][2]
        assert abs(z - (-target_depth)) < 0.05
        # The others are untouched by the keeper.
        assert ros.sim.simulation.spheres.external_force[:, :2].tolist() == [[0, 0]] * 3


def test_log_lines_name_a_few_spheres_and_count_the_rest():
    # A 2 000-sphere start-up line once listed every name.
    assert named_few(['cork', 'steel', 'ice']) == 'cork, steel, ice'
    names = [f's{i}' for i in range(2000)]
    assert named_few(names) == 's0, s1, s2, s3 and 1996 more'
    heights = [f's{i} z=1.00 m' for i in range(4)]  # the status line passes only the first
    assert named_few(heights, count=6) == ', '.join(heights) + ' and 2 more'
