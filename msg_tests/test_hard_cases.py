"""The cases that break other simulators, with the default integrator: never NaN, never out."""
import numpy as np
import pytest

from pool_sim.physics import Simulation
from scenes import floating_draft_ratio, one_sphere

PING_PONG_MASS, PING_PONG_RADIUS = 0.0027, 0.02


def run_checked(sim, duration):
    """Advance step by step, checking every state: finite and inside the pool."""
    pool = sim.environment.pool
    trace = []
    for _ in range(int(round(duration / sim.max_step))):
        sim.step()
        position = sim.spheres.position
        assert np.all(np.isfinite(position)) and np.all(np.isfinite(sim.spheres.velocity))
        radius = sim.spheres.radius
        assert np.all(position >= pool.corner_min[:, None] + radius[None] - 1e-12)
        assert np.all(position <= pool.corner_max[:, None] - radius[None] + 1e-12)
        trace.append(position[2, 0])
    return np.array(trace)


@pytest.mark.parametrize('rate_hz', [30.0, 10.0])
def test_ping_pong_ball_released_under_water_rises_breaks_the_surface_and_settles(rate_hz):
    sim = Simulation(one_sphere(PING_PONG_RADIUS, mass=PING_PONG_MASS, position=(0, 0, -1.0),
                                physics_rate_hz=rate_hz))
    heights = run_checked(sim, 30.0)
    assert heights.max() > 0.0  # broke the surface
    density_ratio = (PING_PONG_MASS / (4 / 3 * np.pi * PING_PONG_RADIUS**3) - 1.2) / 998.8
    expected_z = PING_PONG_RADIUS * (1.0 - floating_draft_ratio(density_ratio))
    assert heights[-1] == pytest.approx(expected_z, abs=1e-4)
    assert abs(sim.spheres.velocity[2, 0]) < 1e-4
    # Settled: the last 5 s move by less than a tenth of a millimetre.
    tail = heights[-int(5.0 * rate_hz):]
    assert tail.max() - tail.min() < 1e-4


def test_steel_ball_thrown_at_the_floor_at_50_m_per_s_does_not_pass_through_it():
    sim = Simulation(one_sphere(0.05, 7850.0, position=(0, 0, -1.0), velocity=(3.0, 0.0, -50.0),
                                physics_rate_hz=20.0))
    heights = run_checked(sim, 10.0)
    assert heights.min() == pytest.approx(-4.0 + 0.05, abs=1e-12)
    assert sim.spheres.position[2, 0] == pytest.approx(-3.95, abs=1e-12)


def test_sphere_resting_on_the_floor_stays_at_rest_without_jitter():
    sim = Simulation(one_sphere(0.1, 7850.0, position=(1.0, 2.0, -3.9)))
    heights = run_checked(sim, 10.0)
    assert np.all(heights == -3.9)
    assert np.all(sim.spheres.velocity == 0.0)
    assert np.all(sim.spheres.position[:2, 0] == [1.0, 2.0])


@pytest.mark.parametrize('rate_hz', [200.0, 10.0])
def test_heavy_sphere_landing_on_the_floor_settles(rate_hz):
    sim = Simulation(one_sphere(1.0, mass=1e4, position=(0, 0, 2.0), physics_rate_hz=rate_hz))
    heights = run_checked(sim, 20.0)
    assert heights[-1] == -3.0
    assert np.all(sim.spheres.velocity == 0.0)


def test_balloon_light_sphere_under_water_rises_without_blowing_up():
    # 1 kg/m^3: lighter than air too, so it ends against the ceiling, at rest.
    sim = Simulation(one_sphere(0.1, 1.0, position=(0, 0, -3.0), physics_rate_hz=10.0))
    run_checked(sim, 20.0)
    assert sim.spheres.position[2, 0] == pytest.approx(4.0 - 0.1)
    assert np.all(np.abs(sim.spheres.velocity) < 1e-9)


@pytest.mark.parametrize('rate_hz', [200.0, 10.0])
def test_neutrally_buoyant_sphere_straddling_the_surface_sinks_under_and_coasts(rate_hz):
    """Half out of the water it weighs more than it displaces; once under it is neutral and
    coasts against quadratic drag alone: m*dv/dt = -c*v^2, so v -> m/(c*t), never zero."""
    radius, mass = 0.1, 1000.0 * 4.0 / 3.0 * np.pi * 0.1**3
    sim = Simulation(one_sphere(radius, mass=mass, position=(0, 0, 0.0),
                                physics_rate_hz=rate_hz))
    run_checked(sim, 30.0)
    assert sim.spheres.position[2, 0] < -radius  # fully under
    drag_factor = 0.5 * 1000.0 * 0.47 * np.pi * radius**2
    assert -sim.spheres.velocity[2, 0] == pytest.approx(mass / (drag_factor * 30.0), rel=0.2)


@pytest.mark.parametrize('rate_hz', [200.0, 10.0])
def test_radius_changed_from_1_cm_to_1_m_while_submerged(rate_hz):
    sim = Simulation(one_sphere(0.01, 7850.0, position=(0, 0, -2.0), physics_rate_hz=rate_hz))
    sim.advance(0.5)
    sim.set_radius('ball', 1.0)  # same 33 g in 4.2 m^3: lighter than air now
    heights = run_checked(sim, 30.0)
    assert heights.max() <= 4.0 - 1.0 + 1e-12
    # Shot up by a buoyancy 1.3 million times its weight, it ends against the ceiling.
    assert sim.spheres.position[2, 0] == pytest.approx(3.0)
    assert abs(sim.spheres.velocity[2, 0]) < 1e-6
