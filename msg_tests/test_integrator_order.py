"""Orders of convergence on the falling steel sphere, against its closed form (not timing)."""
import math

import numpy as np
import pytest

from benchmarks.reference import falling_in_deep_water
from pool_sim.physics import Scene, Simulation

RADIUS, Z0, HORIZON = 0.01, -1.0, 1.0
MASS = 7850.0 * 4.0 / 3.0 * math.pi * RADIUS**3


def max_error(integrator, rate_hz):
    scene = Scene({'sphere_names': ['steel'], 'steel.radius': RADIUS, 'steel.mass': MASS,
                   'steel.position': [0.0, 0.0, Z0], 'effects': ['gravity', 'buoyancy', 'drag'],
                   'pool.min': [-5.0, -5.0, -100.0], 'integrator': integrator,
                   'physics_rate_hz': float(rate_hz)})
    sim = Simulation(scene)
    errors = []
    for sample in range(1, 11):
        sim.advance(0.1)
        errors.append(abs(sim.spheres.position[2, 0]
                          - falling_in_deep_water(0.1 * sample, Z0, RADIUS, MASS)))
    return max(errors)


@pytest.mark.parametrize('integrator, order, rates', [
    ('explicit_euler', 1, (200, 400, 800)),
    ('semi_implicit_euler', 1, (200, 400, 800)),
    ('linearly_implicit_euler', 1, (200, 400, 800)),
    ('velocity_verlet', 2, (100, 200, 400)),
    ('rk4', 4, (50, 100, 200)),
])
def test_observed_order_matches_the_method(integrator, order, rates):
    errors = [max_error(integrator, rate) for rate in rates]
    slope = np.polyfit(np.log([1.0 / r for r in rates]), np.log(errors), 1)[0]
    assert slope == pytest.approx(order, abs=0.15), (errors, slope)
