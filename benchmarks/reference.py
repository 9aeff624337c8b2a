"""Reference answers that do not come from pool_sim's code.

- The steel sphere falling from rest through deep water: closed form.
- A sphere moving vertically through the surface: the same equations pool_sim models,
  written here again from the physics (exact cap, media weighted by volume fraction) and
  solved by scipy's DOP853 at rtol 1e-12.
"""
import math

import numpy as np
from scipy.integrate import solve_ivp

G = 9.81


def falling_in_deep_water(t, z0, radius, mass, drag_coefficient=0.47, water=1000.0):
    """Height z(t) (m) of a sphere released at rest at z0, fully submerged, no added mass.

    With g' = g*(m - rho*V)/m and v_t = sqrt(2*(m - rho*V)*g / (rho*C_d*A)):
    v(t) = -v_t*tanh(g'*t/v_t) and z(t) = z0 - (v_t^2/g')*ln cosh(g'*t/v_t).
    (With added mass, m + rho*V/2 would replace m in g' only; v_t is unchanged.)
    """
    volume, area = 4.0 / 3.0 * math.pi * radius**3, math.pi * radius**2
    net_weight = (mass - water * volume) * G
    terminal = math.sqrt(2.0 * net_weight / (water * drag_coefficient * area))
    reduced_gravity = net_weight / mass
    x = reduced_gravity * np.asarray(t) / terminal
    # ln cosh x without overflow: x + ln(1 + e^-2x) - ln 2
    log_cosh = x + np.log1p(np.exp(-2.0 * x)) - math.log(2.0)
    return z0 - terminal**2 / reduced_gravity * log_cosh


def vertical_through_the_surface(times, z0, v0, radius, mass, drag_coefficient=0.47,
                                 water=1000.0, air=1.2, surface_z=0.0):
    """z at `times` for gravity + buoyancy + drag, solved by DOP853 at rtol 1e-12."""
    volume, area = 4.0 / 3.0 * math.pi * radius**3, math.pi * radius**2

    def rate(t, state):
        z, v = state
        depth = min(max(surface_z - (z - radius), 0.0), 2.0 * radius)
        under = math.pi * depth * depth * (3.0 * radius - depth) / 3.0 / volume
        density = air * (1.0 - under) + water * under  # displaced fluid, volume-weighted
        force = -mass * G + density * volume * G - 0.5 * density * drag_coefficient * area \
            * abs(v) * v
        return [v, force / mass]
    solution = solve_ivp(rate, (0.0, float(times[-1])), [z0, v0], method='DOP853',
                         t_eval=times, rtol=1e-12, atol=1e-14, max_step=0.01)
    assert solution.success, solution.message
    return solution.y[0]
