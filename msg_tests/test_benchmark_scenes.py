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
