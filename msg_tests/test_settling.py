"""Spheres come to rest on the floor with every integrator."""
import math

import numpy as np
import pytest

from pool_sim.physics import INTEGRATORS, Simulation
from scenes import G, one_sphere, sphere_volume, WATER

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
