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


def smooth_motion(times, position, velocity, sphere, world, effects, submerged_volume='cap'):
    """(3, len(times)) positions of one sphere under the smooth effects listed (gravity,
    buoyancy, drag, lift, added_mass), solved by DOP853 at rtol 1e-12: the model pool_sim
    states, written here again from its description, in three dimensions.

    sphere: dict of mass, radius, drag_coefficient, lift_coefficient, lift_area,
    lift_normal (3), external_force (3).  world: dict of gravity (3), air_density, wind (3),
    water_density, current (3), surface_z.  submerged_volume: 'cap' (the exact spherical
    cap) or 'linear' (depth / diameter).
    Each medium acts on the part of the volume inside it; added mass is half the displaced
    fluid's mass, joining the inertia.
    """
    r, m = sphere['radius'], sphere['mass']
    volume, area = 4.0 / 3.0 * math.pi * r**3, math.pi * r**2
    gravity = np.asarray(world['gravity'], dtype=float)
    media = ((world['air_density'], np.asarray(world['wind'], dtype=float)),
             (world['water_density'], np.asarray(world['current'], dtype=float)))
    normal = np.asarray(sphere['lift_normal'], dtype=float)
    external = np.asarray(sphere['external_force'], dtype=float)

    def rate(t, state):
        x, v = state[:3], state[3:]
        depth = min(max(world['surface_z'] - (x[2] - r), 0.0), 2.0 * r)
        if submerged_volume == 'cap':
            under = math.pi * depth * depth * (3.0 * r - depth) / 3.0 / volume
        else:
            under = depth / (2.0 * r)
        shares = (1.0 - under, under)
        displaced = sum(density * share for (density, _), share in zip(media, shares)) * volume
        force = external.copy()
        if 'gravity' in effects:
            force += m * gravity
        if 'buoyancy' in effects:
            force -= displaced * gravity
        for (density, flow), share in zip(media, shares):
            relative = v - flow
            speed = float(np.linalg.norm(relative))
            if 'drag' in effects:
                force -= 0.5 * density * sphere['drag_coefficient'] * area * share * speed \
                    * relative
            if 'lift' in effects and speed > 0.0:
                across = normal - (normal @ relative) / speed**2 * relative
                size = float(np.linalg.norm(across))
                if size > 0.0:
                    force += (0.5 * density * sphere['lift_coefficient'] * sphere['lift_area']
                              * share * speed**2 / size) * across
        inertia = m + (0.5 * displaced if 'added_mass' in effects else 0.0)
        return np.concatenate([v, force / inertia])
    solution = solve_ivp(rate, (0.0, float(times[-1])), np.concatenate([position, velocity]),
                         method='DOP853', t_eval=times, rtol=1e-12, atol=1e-14,
                         max_step=0.005)
    assert solution.success, solution.message
    return solution.y[:3]
