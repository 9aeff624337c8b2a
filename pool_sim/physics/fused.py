"""The default step fused into one compiled loop over spheres (numba), for speed at scale.

The numpy pipeline makes ~40 passes over the arrays per step, so it is bound by memory
traffic and by numpy's per-call cost at small n. This kernel reads each sphere once and
writes it once. It computes exactly what the numpy pipeline computes for
linearly_implicit_euler with the effects gravity, buoyancy (exact cap), drag, contact and
friction; a test holds the two to agreement. An effect the scene does not list is a branch
not taken. Anything else (lift, added mass, other integrators, the linear submerged volume)
runs on the numpy pipeline, and so does everything when numba is not installed.

From parallel_from_spheres() spheres up the smooth pass runs as a numba parallel loop, on as
many threads as numba is set to use in the calling thread (use_threads; the node uses one).
"""
import math
import threading
import types

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


def _smooth(position, velocity, mass, radius, volume, cross_section, drag_coefficient,
            external_force, gravity, air_density, wind, water_density, current, surface_z, dt,
            has_gravity, has_buoyancy, has_drag, old_position, old_velocity):
    """The smooth part of linearly_implicit_euler, in place; old_* receive the start state.

    Written with scalars and selects, allocation-free: the same arithmetic as the numpy
    pipeline. Compiled twice: as a plain loop, and as a parallel loop (prange) for many
    spheres, which pays for itself even on one thread: numba proves a parallel loop's
    arrays do not alias and tells LLVM so, which then computes four spheres at once
    (packed square roots and divisions) where the plain loop stays scalar.
    """
    gx, gy, gz = gravity[0], gravity[1], gravity[2]
    wx, wy, wz = wind[0], wind[1], wind[2]
    cx, cy, cz = current[0], current[1], current[2]
    density_step = water_density - air_density
    # How many spheres the step left a non-finite number (v * 0 is 0 for a finite v, else
    # NaN). An integer reduction keeps the loop vectorised (a conditional store made it 2-3x
    # slower, a float sum scalar); the serial pass finds the spheres when there are any.
    nonfinite = 0
    for i in numba.prange(position.shape[1]):
        x, y, z = position[0, i], position[1, i], position[2, i]
        vx, vy, vz = velocity[0, i], velocity[1, i], velocity[2, i]
        old_position[0, i], old_position[1, i], old_position[2, i] = x, y, z
        old_velocity[0, i], old_velocity[1, i], old_velocity[2, i] = vx, vy, vz
        m, r = mass[i], radius[i]
        fraction = 0.0  # of the volume under water: geometry for buoyancy and drag only
        h = 0.0  # submerged depth / r, clipped to [0, 2]
        inverse_r = 1.0 / r  # one division where three would do the same
        if has_buoyancy or has_drag:
            depth = surface_z - (z - r)
            depth = 0.0 if depth < 0.0 else depth
            depth = 2.0 * r if depth > 2.0 * r else depth
            h = depth * inverse_r
            fraction = 0.25 * h * h * (3.0 - h)
        fx, fy, fz = external_force[0, i], external_force[1, i], external_force[2, i]
        if has_gravity:
            fx += gx * m
            fy += gy * m
            fz += gz * m
        if has_buoyancy:
            displaced = volume[i] * (air_density + density_step * fraction)
            fx -= gx * displaced
            fy -= gy * displaced
            fz -= gz * displaced
        px, py, pz = m * vx + dt * fx, m * vy + dt * fy, m * vz + dt * fz
        horizontal = m
        vertical = m
        if has_drag:
            shape = 0.5 * drag_coefficient[i] * cross_section[i]
            factor_air = shape * air_density * (1.0 - fraction)
            factor_water = shape * water_density * fraction
            total = factor_air + factor_water
            divisor = total if total > 0.0 else 1.0
            mx = (factor_air * wx + factor_water * cx) / divisor
            my = (factor_air * wy + factor_water * cy) / divisor
            mz = (factor_air * wz + factor_water * cz) / divisor
            rx, ry, rz = m * (vx - mx) + dt * fx, m * (vy - my) + dt * fy, m * (vz - mz) + dt * fz
            pushed = math.sqrt(rx * rx + ry * ry + rz * rz)
            end_speed = 2.0 * pushed / (m + math.sqrt(m * m + 4.0 * dt * total * pushed))
            speed_air = math.sqrt((vx - wx) ** 2 + (vy - wy) ** 2 + (vz - wz) ** 2)
            speed_water = math.sqrt((vx - cx) ** 2 + (vy - cy) ** 2 + (vz - cz) ** 2)
            gain_air = factor_air * (speed_air if speed_air > end_speed else end_speed)
            gain_water = factor_water * (speed_water if speed_water > end_speed else end_speed)
            px += dt * gain_air * wx
            py += dt * gain_air * wy
            pz += dt * gain_air * wz
            px += dt * gain_water * cx
            py += dt * gain_water * cy
            pz += dt * gain_water * cz
            horizontal += dt * gain_air
            horizontal += dt * gain_water
            vertical = horizontal
        weight = 0.5
        inverse_horizontal = 1.0 / horizontal  # the solve's divisor, and vertical's so far
        if has_buoyancy:
            offset = z - surface_z
            reach = r * r - offset * offset
            waterline = math.pi * (reach if reach > 0.0 else 0.0)
            stiffness = gz * density_step * -waterline
            # The secant slope toward where z would end without the spring (held to the
            # waterline band), as Dynamics.vertical_stiffness and media.cap_fraction_slope.
            predicted_z = z + 0.5 * dt * (vz + pz * inverse_horizontal)
            predicted_z = min(max(predicted_z, surface_z - r), surface_z + r)
            predicted_h = min(max((surface_z - predicted_z) * inverse_r + 1.0, 0.0), 2.0)
            travel = predicted_z - z
            share = (h - predicted_h) * r / (travel if travel != 0.0 else 1.0)
            share = share if travel != 0.0 else 1.0
            divided = 0.25 * (3.0 * (predicted_h + h) - (predicted_h * predicted_h
                                                        + predicted_h * h + h * h))
            secant_stiffness = -gz * density_step * volume[i] * divided * inverse_r * share
            stiffness = secant_stiffness if secant_stiffness > stiffness else stiffness
            stiffness = stiffness if stiffness > 0.0 else 0.0
            spring = dt * dt * stiffness
            h_squared = spring / m
            weight = 0.5 + 0.5 * h_squared / (4.0 + h_squared)
            pz -= weight * (1.0 - weight) * spring * vz
            vertical += weight * weight * spring
        nvx, nvy, nvz = px * inverse_horizontal, py * inverse_horizontal, pz / vertical
        nx = x + 0.5 * dt * (vx + nvx)
        ny = y + 0.5 * dt * (vy + nvy)
        nz = z + 0.5 * dt * (vz + nvz) + (weight - 0.5) * dt * (nvz - vz)
        velocity[0, i], velocity[1, i], velocity[2, i] = nvx, nvy, nvz
        position[0, i], position[1, i], position[2, i] = nx, ny, nz
        zero_if_finite = nx * 0.0 + ny * 0.0 + nz * 0.0 + nvx * 0.0 + nvy * 0.0 + nvz * 0.0
        nonfinite += 0 if zero_if_finite == 0.0 else 1
    return nonfinite


def _contact_and_guard(position, velocity, radius, old_position, old_velocity, pool_min,
                       pool_max, contact, dt, check_finite, has_contact, has_friction,
                       failed):
    """The step guard, then (has_contact) floor, walls, ceiling and floor friction, in place:
    as contact.resolve_contacts and Simulation's guard.

    check_finite (the smooth pass saw a non-finite number): a sphere it left non-finite goes
    back where it began, at rest, flagged in failed (n,) (zero on entry); so does one whose
    bounce speed would not fit a double. Returns how many were. Contact itself only ever
    puts a sphere on a face, inside. A plain loop with branches, rarely taken.
    """
    restitution, static_friction, kinetic_friction, rolling_friction = contact
    count = 0
    for i in range(position.shape[1]):
        # v * 0 is 0 for a finite v and NaN otherwise: one test for six numbers.
        if check_finite and not (position[0, i] * 0.0 + position[1, i] * 0.0 + position[2, i] * 0.0
                + velocity[0, i] * 0.0 + velocity[1, i] * 0.0 + velocity[2, i] * 0.0) == 0.0:
            for a in range(3):
                position[a, i], velocity[a, i] = old_position[a, i], 0.0
            failed[i] = 1
            count += 1
            continue
        if not has_contact:
            continue
        r = radius[i]
        floor_impulse = 0.0
        put_back = False
        for a in range(3):
            low = pool_min[a] + r
            high = pool_max[a] - r
            p = position[a, i]
            if low < p < high:
                continue  # almost every sphere, on every axis: two comparisons
            v = velocity[a, i]
            below = p < low or (p == low and v < 0.0)
            if below or p > high or (p == high and v > 0.0):
                inward = 1.0 if below else -1.0
                face = low if below else high
                normal_speed = inward * v
                if normal_speed >= 0.0:
                    bounced = normal_speed
                elif old_velocity[a, i] == 0.0 and old_position[a, i] == face:
                    bounced = 0.0  # at rest on the face: what impact_speed gives, at once
                else:  # contact.impact_speed
                    approach_start, approach_end = -inward * old_velocity[a, i], -normal_speed
                    before = max(inward * (old_position[a, i] - face), 0.0)
                    past = max(inward * (face - p), 0.0)
                    acceleration = (approach_end - approach_start) / dt
                    squared = min(approach_start * approach_start + 2.0 * acceleration * before,
                                  approach_end * approach_end - 2.0 * acceleration * past)
                    bounced = restitution * math.sqrt(max(squared, 0.0))
                    if not bounced > approach_end - approach_start:  # resting contact
                        bounced = 0.0
                    if not math.isfinite(bounced):  # v^2 beyond a double: the step guard
                        for b in range(3):
                            position[b, i], velocity[b, i] = old_position[b, i], 0.0
                        failed[i] = 1
                        count += 1
                        put_back = True
                        break
                position[a, i] = face
                velocity[a, i] = inward * bounced
                if a == 2 and below:
                    floor_impulse = bounced - normal_speed
        if put_back:
            continue
        if has_friction and floor_impulse > 0.0:
            tx, ty = velocity[0, i], velocity[1, i]
            tangential_speed = math.hypot(tx, ty)
            if tangential_speed <= static_friction * floor_impulse:
                position[0, i], position[1, i] = old_position[0, i], old_position[1, i]
                velocity[0, i], velocity[1, i] = 0.0, 0.0
            else:
                slowdown = min(tangential_speed,
                               (kinetic_friction + rolling_friction) * floor_impulse)
                scale = 1.0 - slowdown / tangential_speed if tangential_speed > 0.0 else 1.0
                velocity[0, i], velocity[1, i] = tx * scale, ty * scale
                position[0, i] += dt * (velocity[0, i] - tx)
                position[1, i] += dt * (velocity[1, i] - ty)
            for a in range(2):
                position[a, i] = min(max(position[a, i], pool_min[a] + r), pool_max[a] - r)
    return count


def _renamed(function, name):
    """The same code as a function of another name. numba's on-disk cache tells compiled
    functions apart by name and line, not by options: without this, the parallel build
    and the plain one would overwrite each other's cache."""
    copy = types.FunctionType(function.__code__.replace(co_name=name), function.__globals__,
                              name)
    copy.__qualname__ = name
    return copy


if numba is not None:
    _smooth_serial = numba.njit(cache=True, nogil=True, error_model='numpy')(_smooth)
    _smooth_parallel = numba.njit(cache=True, nogil=True, error_model='numpy', parallel=True)(
        _renamed(_smooth, '_smooth_parallel'))
    _contact_and_guard_kernel = numba.njit(cache=True, nogil=True, error_model='numpy')(
        _contact_and_guard)
# Below this many spheres launching the parallel loop costs more than vectorising saves.
# A launch costs ~5 us with the OpenMP or TBB threading layer and ~100 us with numba's own
# workqueue, the one left where neither library is installed (measured, one thread: at
# 1 000 spheres 21 against 55 us a step with OpenMP, 107 against 58 us with workqueue; at
# 10 000, 299 against 433 us with workqueue).
PARALLEL_FROM_SPHERES = {'omp': 64, 'tbb': 64, 'workqueue': 4096}
_threading_layer = None  # numba knows it only after a parallel launch: set after our first
# numba's default threading layer (workqueue) aborts the process when two threads launch
# parallel loops at once: simulations stepped from several threads take turns.
_parallel_launch = threading.Lock()


def use_threads(count):
    """Threads the parallel loop may use when the calling thread steps (numba's setting,
    per thread; numba's default is one per core)."""
    if numba is not None:
        numba.set_num_threads(count)


def parallel_from_spheres():
    """How many spheres make the parallel build worth launching, for numba's threading
    layer (taken to be OpenMP's until our first launch shows which it is)."""
    return PARALLEL_FROM_SPHERES.get(_threading_layer or 'omp',
                                     PARALLEL_FROM_SPHERES['workqueue'])


_NONE_FAILED = np.empty(0, dtype=np.intp)


def step(simulation, dt):
    """Advance `simulation` (a Simulation the kernel supports) by dt in place.

    Returns the indices of the spheres the step guard put back (see Simulation)."""
    global _threading_layer
    env, spheres = simulation.environment, simulation.spheres
    has_gravity, has_buoyancy, has_drag, has_contact, has_friction = simulation.effect_flags
    scratch = simulation.fused_scratch
    if scratch is None or scratch[0].shape != spheres.position.shape:
        scratch = simulation.fused_scratch = (
            np.empty_like(spheres.position), np.empty_like(spheres.velocity),
            np.zeros(spheres.position.shape[1], dtype=np.uint8))
    old_position, old_velocity, failed = scratch
    arguments = (spheres.position, spheres.velocity, spheres.mass, spheres.radius,
                 spheres.volume, spheres.cross_section, spheres.drag_coefficient,
                 spheres.external_force, env.gravity, env.air.density, env.air.flow_velocity,
                 env.water.density, env.water.flow_velocity, env.surface_z, dt, has_gravity,
                 has_buoyancy, has_drag, old_position, old_velocity)
    if spheres.position.shape[1] >= parallel_from_spheres():
        with _parallel_launch:
            nonfinite = _smooth_parallel(*arguments)
            _threading_layer = _threading_layer or numba.threading_layer()
    else:
        nonfinite = _smooth_serial(*arguments)
    check_finite = nonfinite > 0
    if not (has_contact or check_finite):
        return _NONE_FAILED
    count = _contact_and_guard_kernel(
        spheres.position, spheres.velocity, spheres.radius, old_position, old_velocity,
        env.pool.corner_min, env.pool.corner_max, simulation.contact_tuple, dt, check_finite,
        has_contact, has_friction, failed)
    if not count:
        return _NONE_FAILED
    indices = np.flatnonzero(failed)
    failed[indices] = 0
    return indices
