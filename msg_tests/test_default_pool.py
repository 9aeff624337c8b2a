"""The seed's pool ends as its Figure 9 shows; every integrator runs it; steps are bounded."""
import numpy as np
import pytest

from pool_sim.physics import INTEGRATORS, Scene, Simulation
from scenes import floating_draft_ratio


def test_default_pool_ends_as_the_seeds_figure_9():
    # Quadratic drag damps a small bob only slowly: an independent DOP853 solution of the
    # cork still bobs 1 % off its draft at 60 s and is within 0.6 % at 120 s.
    sim = Simulation(Scene.default())
    sim.advance(120.0)
    z = dict(zip(sim.spheres.names, sim.spheres.position[2]))
    r = dict(zip(sim.spheres.names, sim.spheres.radius))
    # cork floats high: most of it above the water.
    assert (r['cork'] - z['cork']) / r['cork'] == pytest.approx(
        floating_draft_ratio((250.0 - 1.2) / 998.8), rel=0.02)
    # steel rests on the floor.
    assert z['steel'] == -4.0 + r['steel']
    # ice floats with only a small cap above the water: less than a fifth of its height.
    assert 0.0 < z['ice'] + r['ice'] < 0.2 * 2 * r['ice']
    assert np.all(np.abs(sim.spheres.velocity) < 0.02)


@pytest.fixture(scope='module')
def reference_after_splash():
    reference = Simulation(Scene.default().with_values(physics_rate_hz=1000.0))
    reference.advance(2.5)
    return reference


@pytest.mark.parametrize('integrator', sorted(INTEGRATORS))
def test_every_integrator_runs_the_default_pool_to_the_same_place(integrator,
                                                                  reference_after_splash):
    sim = Simulation(Scene.default().with_values(integrator=integrator,
                                                 physics_rate_hz=1000.0))
    sim.advance(2.5)
    assert np.all(np.isfinite(sim.spheres.position))
    reference = reference_after_splash
    # After splashing in, all methods agree to a few centimetres at 1 kHz.
    np.testing.assert_allclose(sim.spheres.position, reference.spheres.position, atol=0.05)


def test_a_long_interval_is_split_into_equal_steps_no_longer_than_the_configured_one():
    sim = Simulation(Scene.default())
    calls = []
    original = sim.run
    sim.run = lambda steps, dt: (calls.append((steps, dt)), original(steps, dt))
    sim.advance(0.0123)
    [(steps, dt)] = calls  # one compiled call for all of them
    assert steps == 3 and dt <= sim.max_step
    assert steps * dt == pytest.approx(0.0123, abs=1e-15)
    assert sim.time == pytest.approx(0.0123, abs=1e-15)
