"""The benchmarks' scenes are the ones their results say they are: benchmarks/contact_stages
--scattered times the scene the node's real-time factor is measured on
(results/collisions/node_rate.md compares the two)."""
import numpy as np
import pytest

from benchmarks.common import scattered_scene
from benchmarks.node_rate import spheres_params_file
from pool_sim.physics import Scene


@pytest.mark.parametrize('count', [3, 1000])
@pytest.mark.parametrize('solver', [None, 'soft_step'])
def test_the_scattered_scene_is_the_one_the_node_reads(tmp_path, count, solver):
    # The node's side: node_rate's params file read as the node reads it.
    path = spheres_params_file(count, tmp_path / 'spheres.yaml', True, solver, True)
    node = Scene.from_yaml(path)
    ours = scattered_scene(count, True, solver)
    assert node.global_values() == ours.global_values()
    for key in ('position', 'radius', 'mass', 'velocity'):
        assert np.array_equal(node.sphere_array(key), ours.sphere_array(key)), key


def test_the_scattered_scene_without_collisions_differs_only_in_its_effects():
    colliding, smooth = scattered_scene(50, True), scattered_scene(50, False)
    assert tuple(colliding['effects']) == (*smooth['effects'], 'collisions')
    assert np.array_equal(colliding.sphere_array('position'), smooth.sphere_array('position'))


def test_compare_commits_steps_the_base_commits_physics_not_the_working_trees(tmp_path):
    """benchmarks/compare_commits: the base's physics core comes out of git as a package of
    its own, and the scene built for it is that package's Scene."""
    import sys
    from benchmarks import compare_commits
    folder = tmp_path / 'base'
    folder.mkdir()
    try:
        base = compare_commits.base_physics('HEAD', folder)
        assert base.__name__ == 'pool_sim_base_physics'
        assert str(folder) in base.__file__
        import pool_sim.physics
        assert base.Simulation is not pool_sim.physics.Simulation
        for made in (base.Simulation, base.Scene):
            assert made.__module__.startswith('pool_sim_base_physics')
    finally:
        sys.path.remove(str(folder))
        for name in [name for name in sys.modules if name.startswith('pool_sim_base_physics')]:
            del sys.modules[name]
