"""Loading the node's own parameter table back (`ros2 param load` of a `ros2 param dump`)
changes nothing: a lift area that follows its radius keeps following it, after a radius
from a params file and after ~/set_radius (found in review: the table and the plan computed
pi r^2 two ways, rounding apart from the core's pi r r)."""
from rcl_interfaces.srv import SetParameters
from rclpy.parameter import Parameter

from pool_sim.testing import PoolSim


def reload_lift_areas(sim):
    dumped = list(sim.node.get_parameter('spheres.lift_area').value)
    result = sim.node.set_parameters([Parameter('spheres.lift_area', value=dumped)])[0]
    assert result.successful, result.reason
    with sim.node.lock():
        spheres = sim.node.simulation.spheres
        assert spheres.lift_area.tolist() == dumped  # the table shows what the core has
        return spheres.lift_area_follows_radius.tolist()


def test_reloading_a_fresh_table_keeps_the_area_following():
    with PoolSim({'per_sphere_topics': False, 'cork.radius': 0.07}, lockstep=False) as sim:
        assert reload_lift_areas(sim) == [True, True, True]


def test_reloading_the_table_after_set_radius_keeps_the_area_following():
    with PoolSim({'per_sphere_topics': False}, lockstep=False) as sim:
        answer = sim.call(SetParameters, 'set_radius', SetParameters.Request(
            parameters=[Parameter('cork', value=0.07).to_parameter_msg()]))
        assert answer.results[0].successful
        assert reload_lift_areas(sim) == [True, True, True]
