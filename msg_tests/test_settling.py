"""Spheres come to rest: on the floor with every integrator, and afloat at their draft with
the default integrator at any step."""
import math

import numpy as np
import pytest

from pool_sim.physics import INTEGRATORS, Simulation
from scenes import floating_draft_ratio, G, one_sphere, sphere_volume, WATER

STEEL_DENSITY, RADIUS, MU_S = 7850.0, 0.1, 0.6
FLOOR_Z = -4.0 + RADIUS


def steel_dropped(integrator, rate_hz=30.0, **keys):
    return Simulation(one_sphere(RADIUS, STEEL_DENSITY, position=(0, 0, 0.0),
                                 integrator=integrator, physics_rate_hz=rate_hz,
                                 contact__static_friction=MU_S, **keys))


@pytest.mark.parametrize('integrator', list(INTEGRATORS))
def test_a_steel_ball_dropped_into_the_water_comes_to_rest_on_the_floor(integrator):
    # Explicit Euler used to chatter on the floor for ever (4.8 mm, 0.29 m/s at 30 Hz): its
    # position lags its velocity, so resting on the floor it ended each step exactly on it,
    # moving into it, and that did not count as contact.
    sim = steel_dropped(integrator)
    sim.advance(10.0)
    for _ in range(60):
        sim.step()
        assert sim.spheres.position[2, 0] == FLOOR_Z
        assert np.all(sim.spheres.velocity[:, 0] == 0.0)


@pytest.mark.parametrize('integrator', list(INTEGRATORS))
@pytest.mark.parametrize('push', ['force', 'current'])
def test_static_friction_holds_a_resting_ball_against_a_push_below_its_limit(integrator, push):
    # 0.9 of mu_s*N, by a force or by the drag of a current. Explicit Euler used to slide
    # under a current of 0.94 of the critical speed.
    normal_force = (STEEL_DENSITY - WATER) * sphere_volume(RADIUS) * G
    if push == 'force':
        sim = steel_dropped(integrator)
        sim.advance(10.0)
        sim.set_external_force('ball', [0.9 * MU_S * normal_force, 0.0, 0.0])
    else:
        drag_factor = 0.5 * WATER * 0.47 * math.pi * RADIUS**2  # drag = factor * speed^2
        critical_speed = math.sqrt(MU_S * normal_force / drag_factor)
        sim = steel_dropped(integrator, water__current=[math.sqrt(0.9) * critical_speed, 0, 0])
        sim.advance(10.0)
    start = sim.spheres.position[:, 0].copy()
    sim.advance(5.0)
    assert np.array_equal(sim.spheres.position[:, 0], start)
    assert np.all(sim.spheres.velocity[:, 0] == 0.0)


PING_PONG_MASS, PING_PONG_RADIUS = 0.0027, 0.02
DENSITY_RATIO = (PING_PONG_MASS / sphere_volume(PING_PONG_RADIUS) - 1.2) / (WATER - 1.2)
DRAFT_Z = PING_PONG_RADIUS * (1.0 - floating_draft_ratio(DENSITY_RATIO))


@pytest.mark.parametrize('added_mass', [False, True])
@pytest.mark.parametrize('dt', [0.1, 0.2, 0.3, 0.4, 0.5, 1.0])
def test_a_ping_pong_ball_released_under_water_settles_at_its_draft_at_any_step(dt, added_mass):
    """It used to hop over the waterline band (up to z = 0.26 m) for all of 60 s at steps of
    0.3-0.5 s with added mass: the buoyancy spring only saw the stiffness where a step began,
    none from fully under the water. Now it settles within seconds, and never rises above
    the exact solution's peak (DOP853: 0.0577 m, with added mass 0.0631 m)."""
    effects = ['gravity', 'buoyancy', 'drag', 'contact', 'friction'] + (
        ['added_mass'] if added_mass else [])
    sim = Simulation(one_sphere(PING_PONG_RADIUS, mass=PING_PONG_MASS, position=(0, 0, -1.0),
                                effects=effects, physics_rate_hz=1.0 / dt))
    heights = []
    for _ in range(round(60.0 / dt)):
        sim.step()
        heights.append(sim.spheres.position[2, 0])
    heights = np.array(heights)
    assert heights.max() < (0.0631 if added_mass else 0.0577)
    away = np.flatnonzero(np.abs(heights - DRAFT_Z) >= 1e-3)
    settled_from = (away[-1] + 2 if away.size else 1) * dt
    assert settled_from <= 10.0
    assert heights[-1] == pytest.approx(DRAFT_Z, abs=1e-9)
