"""The default step fused into one compiled loop over spheres (numba), for speed at scale.

The numpy pipeline makes ~40 passes over the arrays per step, so it is bound by memory
traffic and by numpy's per-call cost at small n. This kernel reads each sphere once and
writes it once. It computes exactly what the numpy pipeline computes for
linearly_implicit_euler with the effects gravity, buoyancy (exact cap), drag, contact and
friction; a test holds the two to agreement. An effect the scene does not list is a branch
not taken. Anything else (lift, added mass, other integrators, the linear submerged volume)
runs on the numpy pipeline, and so does everything when numba is not installed.
"""
import math

import numpy as np

try:
    import numba
except ImportError:  # optional: the numpy pipeline does everything without it
    numba = None

FUSED_EFFECTS = frozenset({'gravity', 'buoyancy', 'drag', 'contact', 'friction'})
FUSED_INTEGRATOR = 'linearly_implicit_euler'


def supports(scene, submerged_volume):
    """True when the fused kernel computes this scene exactly as the numpy pipeline does."""
    return (numba is not None and scene['integrator'] == FUSED_INTEGRATOR
            and submerged_volume == 'cap' and set(scene['effects']) <= FUSED_EFFECTS)


def _step(position, velocity, mass, radius, volume, cross_section, drag_coefficient,
          external_force, gravity, air_density, wind, water_density, current, surface_z,
          pool_min, pool_max, contact, dt, has_gravity, has_buoyancy, has_drag, has_contact,
          has_friction):
    """One step of every sphere, in place. Arrays as in Spheres; contact =
    (restitution, static, kinetic, rolling friction); has_*: the scene's effects."""
    restitution, static_friction, kinetic_friction, rolling_friction = contact
    density_step = water_density - air_density
    needs_fraction = has_buoyancy or has_drag
    # Scratch for one sphere, allocated once: an allocation per sphere would cost more than
    # the physics.
    new_x, new_v, old_x, old_v = np.empty(3), np.empty(3), np.empty(3), np.empty(3)
    force, momentum, denominator = np.empty(3), np.empty(3), np.empty(3)
    for i in range(position.shape[1]):
        m, r = mass[i], radius[i]
        for a in range(3):
            old_x[a] = position[a, i]
            old_v[a] = velocity[a, i]
        z = old_x[2]
        # Wholly in one medium (most spheres, most steps): the cap is exactly 0 or 1.
        crossing = z - r < surface_z < z + r
        fraction = 0.0
        if needs_fraction:
            if crossing:
                h = (surface_z - (z - r)) / r
                fraction = 0.25 * h * h * (3.0 - h)
            elif z + r <= surface_z:
                fraction = 1.0
        displaced = volume[i] * (air_density + density_step * fraction)
        for a in range(3):
            f = external_force[a, i]
            if has_gravity:
                f += gravity[a] * m
            if has_buoyancy:
                f -= gravity[a] * displaced
            force[a] = f
        for a in range(3):
            momentum[a] = m * old_v[a] + dt * force[a]
            denominator[a] = m
        if has_drag:
            shape = 0.5 * drag_coefficient[i] * cross_section[i]
            factor_air = shape * air_density * (1.0 - fraction)
            factor_water = shape * water_density * fraction
            total = factor_air + factor_water
            inverse_total = 1.0 / total if total > 0.0 else 1.0
            pushed_sq = 0.0
            speed_air_sq = 0.0
            speed_water_sq = 0.0
            for a in range(3):
                mean_flow = (factor_air * wind[a] + factor_water * current[a]) * inverse_total
                relative_momentum = m * (old_v[a] - mean_flow) + dt * force[a]
                pushed_sq += relative_momentum * relative_momentum
                speed_air_sq += (old_v[a] - wind[a]) ** 2
                speed_water_sq += (old_v[a] - current[a]) ** 2
            pushed = math.sqrt(pushed_sq)
            end_speed = 2.0 * pushed / (m + math.sqrt(m * m + 4.0 * dt * total * pushed))
            # A medium the sphere is not in has factor 0: its speed is not needed.
            gain_air = (factor_air * max(math.sqrt(speed_air_sq), end_speed)
                        if factor_air > 0.0 else 0.0)
            gain_water = (factor_water * max(math.sqrt(speed_water_sq), end_speed)
                          if factor_water > 0.0 else 0.0)
            for a in range(3):
                momentum[a] += dt * gain_air * wind[a]
                momentum[a] += dt * gain_water * current[a]
                denominator[a] += dt * gain_air
                denominator[a] += dt * gain_water
        weight = 0.5
        if has_buoyancy and crossing:  # the waterline spring exists only while crossing
            offset = z - surface_z
            waterline = math.pi * max(r * r - offset * offset, 0.0)
            stiffness = max(gravity[2] * density_step * -waterline, 0.0)
            spring = dt * dt * stiffness
            h_squared = spring / m
            weight = 0.5 + 0.5 * h_squared / (4.0 + h_squared)
            momentum[2] -= weight * (1.0 - weight) * spring * old_v[2]
            denominator[2] += weight * weight * spring
        # x and y share a denominator: one division for both.
        inverse_horizontal = 1.0 / denominator[0]
        new_v[0] = momentum[0] * inverse_horizontal
        new_v[1] = momentum[1] * inverse_horizontal
        new_v[2] = momentum[2] / denominator[2]
        for a in range(3):
            new_x[a] = old_x[a] + 0.5 * dt * (old_v[a] + new_v[a])
        if weight != 0.5:
            new_x[2] += (weight - 0.5) * dt * (new_v[2] - old_v[2])
        if has_contact:
            floor_impulse = 0.0
            for a in range(3):
                low = pool_min[a] + r
                high = pool_max[a] - r
                below = new_x[a] < low
                if below or new_x[a] > high:
                    inward = 1.0 if below else -1.0
                    normal_speed = inward * new_v[a]
                    if normal_speed >= 0.0:
                        bounced = normal_speed
                    else:
                        bounced = restitution * max(-inward * old_v[a], 0.0)
                    new_x[a] = low if below else high
                    new_v[a] = inward * bounced
                    if a == 2 and below:
                        floor_impulse = bounced - normal_speed
            if has_friction and floor_impulse > 0.0:
                tx, ty = new_v[0], new_v[1]
                tangential_speed = math.hypot(tx, ty)
                if tangential_speed <= static_friction * floor_impulse:
                    new_x[0], new_x[1] = old_x[0], old_x[1]
                    new_v[0], new_v[1] = 0.0, 0.0
                else:
                    slowdown = min(tangential_speed,
                                   (kinetic_friction + rolling_friction) * floor_impulse)
                    scale = 1.0 - slowdown / tangential_speed if tangential_speed > 0.0 else 1.0
                    new_v[0], new_v[1] = tx * scale, ty * scale
                    new_x[0] += dt * (new_v[0] - tx)
                    new_x[1] += dt * (new_v[1] - ty)
                for a in range(2):
                    new_x[a] = min(max(new_x[a], pool_min[a] + r), pool_max[a] - r)
        for a in range(3):
            position[a, i] = new_x[a]
            velocity[a, i] = new_v[a]


fused_step = numba.njit(cache=True, nogil=True)(_step) if numba is not None else None


def step(simulation, dt):
    """Advance `simulation` (a Simulation the kernel supports) by dt in place."""
    env, spheres, contact = simulation.environment, simulation.spheres, simulation.contact_parameters
    effects = simulation.effect_flags
    fused_step(spheres.position, spheres.velocity, spheres.mass, spheres.radius, spheres.volume,
               spheres.cross_section, spheres.drag_coefficient, spheres.external_force,
               env.gravity, env.air.density, env.air.flow_velocity, env.water.density,
               env.water.flow_velocity, env.surface_z, env.pool.corner_min, env.pool.corner_max,
               (contact.restitution, contact.static_friction, contact.kinetic_friction,
                contact.rolling_friction), dt, *effects)
