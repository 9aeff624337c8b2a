"""The step guard, the last line of defence: a sphere a step would leave non-finite (or
whose bounce would not fit a double) goes back to where the step began, at rest, counted and
named, and the others step on as if nothing had happened."""
import numpy as np
import pytest

from pool_sim.physics import Scene, Simulation, stepper
from pool_sim.physics.stability import stable_step_bound
from scenes import one_sphere

FLOAT_LIMIT = 'forces beyond what float arithmetic can hold'


def two_spheres(**keys):
    """A ping-pong ball (index 0) and a steel ball (index 1) under water."""
    return Scene({'sphere_names': ['ping', 'steel'],
                  'ping.mass': 0.0027, 'ping.radius': 0.02, 'ping.position': [0.0, 0.0, -1.0],
                  'steel.mass': 7850.0 * 4.0 / 3.0 * np.pi * 0.1**3, 'steel.radius': 0.1,
                  'steel.position': [1.0, 0.0, -1.0], **keys})


def assert_finite_and_inside(sim):
    pool, radius = sim.environment.pool, sim.spheres.radius
    assert np.all(np.isfinite(sim.spheres.position)) and np.all(np.isfinite(sim.spheres.velocity))
    assert np.all(sim.spheres.position >= pool.corner_min[:, None] + radius)
    assert np.all(sim.spheres.position <= pool.corner_max[:, None] - radius)


def test_rk4_far_beyond_its_stable_step_puts_the_light_sphere_back_and_names_the_cause():
    # RK4 holds the ping-pong ball only below 1.44 ms: at 1/30 s its drag blows up, again
    # and again. The steel ball is stable at this step and must not notice.
    scene = two_spheres(integrator='rk4', physics_rate_hz=30.0)
    sim = Simulation(scene)
    recovered = set()
    for _ in range(300):
        sim.step()
        assert_finite_and_inside(sim)
        recovered.update(sim.take_recovered())
    assert recovered == {0}
    assert sim.recoveries >= 5
    bound = stable_step_bound(scene, spheres=sim.spheres, indices=[0])
    assert sim.likely_cause(0) == (
        f'rk4 is unstable at 0.0333 s for this sphere (stable below {bound:.3g} s); use '
        'linearly_implicit_euler or a higher physics_rate_hz')
    assert sim.spheres.position[2, 1] == pytest.approx(-3.9)  # steel: on the floor, as ever


def test_a_force_beyond_float_arithmetic_leaves_that_sphere_at_rest_where_it_was():
    sim = Simulation(two_spheres())
    unforced = Simulation(two_spheres())
    sim.spheres.external_force[2, 0] = 1e300  # past every setter's check, set directly
    for step in range(1, 11):
        sim.step()
        unforced.step()
        assert_finite_and_inside(sim)
        assert sim.take_recovered() == [0]
        assert sim.recoveries == step
        assert np.array_equal(sim.spheres.position[:, 0], [0.0, 0.0, -1.0])
        assert np.all(sim.spheres.velocity[:, 0] == 0.0)
        # The other sphere steps exactly as it would alone.
        assert np.array_equal(sim.spheres.position[:, 1], unforced.spheres.position[:, 1])
        assert np.array_equal(sim.spheres.velocity[:, 1], unforced.spheres.velocity[:, 1])
    assert sim.likely_cause(0) == (
        f'{FLOAT_LIMIT}: check mass, radius and external force')
    assert sim.take_recovered() == []  # taken: cleared until the next one
    sim.reset()
    assert sim.recoveries == 10  # the count outlives a reset


def test_a_bounce_that_overflows_is_caught_after_contact():
    # Without drag nothing overflows before the floor; the bounce's v^2 then does.
    scene = two_spheres(effects=['gravity', 'buoyancy', 'contact', 'friction'])
    sim = Simulation(scene)
    sim.spheres.velocity[2, 0] = -1e200
    sim.step()
    assert_finite_and_inside(sim)
    assert sim.take_recovered() == [0] and sim.recoveries == 1
    assert np.array_equal(sim.spheres.position[:, 0], [0.0, 0.0, -1.0])
    assert np.all(sim.spheres.velocity[:, 0] == 0.0)


@pytest.mark.parametrize('count', [32, 192])  # the plain build and the parallel one
def test_the_step_counts_and_flags_every_failed_sphere(count, monkeypatch):
    monkeypatch.setattr(stepper, 'parallel_from_spheres', lambda: 64)
    names = [f's{i}' for i in range(count)]
    params = {'sphere_names': names}
    for i, name in enumerate(names):
        params[f'{name}.position'] = [-3.0 + 6.0 * i / count, 0.0, -1.0]
    sim = Simulation(Scene(params))
    failing = list(range(3, count, 7))
    sim.spheres.external_force[2, failing] = 1e300
    for step in range(1, 4):
        sim.step()
        assert_finite_and_inside(sim)
        assert sim.take_recovered() == failing
        assert sim.recoveries == step * len(failing)
    sim.run(5, sim.max_step)  # five steps in one call: each put back five times, named once
    assert sim.take_recovered() == failing and sim.recoveries == 8 * len(failing)


def test_the_likely_cause_names_the_bound_for_spheres_given_as_arrays():
    # A scene of many spheres is built as arrays (initial_spheres), with no per-sphere keys.
    template = Simulation(one_sphere(0.02, mass=0.0027, position=(0.0, 0.0, -1.0)))
    scene = Scene({'integrator': 'rk4', 'physics_rate_hz': 30.0})
    sim = Simulation(scene, initial_spheres=template.spheres.copy())
    for _ in range(30):
        sim.step()
    assert sim.recoveries > 0
    assert 'rk4 is unstable at 0.0333 s for this sphere' in sim.likely_cause(0)
