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


def test_solve_passes_times_the_passes_a_step_runs(monkeypatch):
    """benchmarks/solve_passes: the passes it times one by one, run in a substep's order on
    the rows it builds, make the solver's own substeps' numbers to the bit."""
    from benchmarks import solve_passes
    from pool_sim.physics.contacts import soft_step
    ready, settings, dt, threshold, restitution = solve_passes.prepared(1000, 3.0, False)
    members = ready.sphere.size
    ground = ready.solve_order[:, 1] == members
    assert ground.any() and not ground.all()  # landed: pairs, and faces
    substeps, h = int(settings[0]), dt / settings[0]

    def fresh():
        return (ready.rows.copy(), ready.velocity.copy(), ready.moved.copy(),
                np.zeros(members, dtype=np.bool_))
    rows, velocity, moved, supported = fresh()
    soft_step._substeps(rows, ready.solve_order, velocity, moved, ready.change,
                        ready.inverse_mass, settings, dt, ready.support, threshold, supported)
    one_by_one, velocity_too, moved_too, supported = fresh()
    for substep in range(substeps):
        soft_step.change_pass(velocity_too, ready.change)
        soft_step.carried_pass(one_by_one, ready.solve_order, velocity_too, ready.inverse_mass)
        for bias in (True, False):
            if not bias:
                soft_step.move_pass(moved_too, velocity_too, h)
            soft_step.solve_pass(one_by_one, ready.solve_order, velocity_too, moved_too,
                                 ready.inverse_mass, settings[3], bias, 1.0 / h,
                                 bias or substep < substeps - 1)
            if bias:
                soft_step._support_sweep(*ready.support, velocity_too, moved_too, 1.0 / h,
                                         threshold, supported)
    for ours, theirs in ((rows, one_by_one), (velocity, velocity_too), (moved, moved_too)):
        assert np.array_equal(ours, theirs)
    # The restitution pass reads the rows marked to bounce only, with the numbers it made
    # reading every row.
    assert 0 < ready.bounces.sum() < ready.bounces.size
    marked, everything = (rows.copy(), velocity.copy()), (rows.copy(), velocity.copy())
    for (restituted, restituted_velocity), bounces in ((marked, ready.bounces),
                                                        (everything, np.ones_like(ready.bounces))):
        soft_step.restitution_pass(restituted, ready.solve_order, restituted_velocity,
                                   ready.inverse_mass, threshold, restitution, bounces)
    assert np.array_equal(marked[0], everything[0]) and np.array_equal(marked[1], everything[1])
    assert not np.array_equal(marked[1], velocity)  # some bounced
    monkeypatch.setattr(solve_passes, 'REPEATS', 1)
    times = solve_passes.pass_times(ready, settings, dt, threshold, restitution)
    assert all(np.isfinite(value) and value > 0.0 for value in times.values())
    table = solve_passes.table([('resting pile', 1000, ready.rows.shape[0], members, 1, times)])
    assert table.count('\n') == 2 and "a step's substeps" in table
    assert 'restitution, every row read' in table
