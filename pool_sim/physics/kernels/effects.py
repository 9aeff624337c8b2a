"""The smooth forces, one small compiled function each, and their composition (the effects
a scene lists: effect_flags in physics/effects.py).

Every function here works on one sphere and is compiled by numba and inlined where it is
called: the step (physics/stepper.py) composes them into one loop over the spheres, in which an
effect the scene does not list is a branch on a compile-time constant, removed before the
loop is built. What a sphere is to these functions:

- `listed`, `env`, `body`: the scene's flags, the world and one sphere, namedtuples read
  by name (layout.py: Listed, Env, Body, each field's unit there).
- positions and velocities are 3-tuples, m and m/s; forces 3-tuples, N.

Forces from each medium are weighted by the fraction of the sphere's volume inside it:
`fraction` is that fraction for water, 1 - fraction for air.
"""
import math

import numba
import numpy as np

from ..effects import effect_flags
from . import compiled
from .layout import body_of, env_of
from .media import submerged_fraction, submerged_fraction_slope, waterline_volume_slope
from .wave_table import ADDED_MASS, ADDED_MASS_SLOPE, DAMPING_RATE, DRAFTS, MASS_AXIS

HALF_PI = 0.5 * math.pi
# The wave table's grid: drafts s = d/r and t = mu/(1 + mu), both evenly spaced.
_DRAFT_CELLS, _MASS_CELLS = DRAFTS.size - 1, MASS_AXIS.size - 1
_CELLS_PER_DRAFT = _DRAFT_CELLS / (DRAFTS[-1] - DRAFTS[0])
assert DRAFTS[0] == 0.0 and MASS_AXIS[0] == 0.0 and MASS_AXIS[-1] == 1.0
# The table heave_radiation reads, as Env.wave_table (layout.py): the added mass, its slope
# in s and the damping rate, (3, drafts, masses). Passed in, never read as a global: numba
# would embed a global array in the code, which a GPU's 64 kB of constants cannot hold.
WAVE_TABLE = np.ascontiguousarray(np.stack((ADDED_MASS, ADDED_MASS_SLOPE, DAMPING_RATE)))
_ADDED, _ADDED_SLOPE, _DAMPING = range(3)  # its planes


_LISTED_SCALAR = effect_flags(['wave_radiation'])


@compiled
def water_fraction(listed, env, body, z):
    """Fraction of the sphere under water; 0 without computing it when no listed effect
    needs it (gravity alone, or nothing)."""
    if not (listed.buoyancy or listed.drag or listed.lift or listed.added_mass):
        return 0.0
    return submerged_fraction(listed.cap, z, body.radius, body.inverse_radius, env.surface_z)


@compiled
def gravity_force(env, body):
    """m*g."""
    mass = body.mass
    return env.gravity_x * mass, env.gravity_y * mass, env.gravity_z * mass


@compiled
def displaced_mass(env, body, fraction):
    """rho*V_sub summed over both media, kg."""
    return body.volume * (env.air_density + (env.water_density - env.air_density) * fraction)


@compiled
def buoyancy_force(env, body, fraction):
    """-rho*V_sub*g from each medium: always against gravity, whatever its direction."""
    displaced = displaced_mass(env, body, fraction)
    return -env.gravity_x * displaced, -env.gravity_y * displaced, -env.gravity_z * displaced


@compiled
def added_mass(env, body, fraction):
    """1/2*rho*V in each medium (kg): the fluid a sphere must push aside as it accelerates."""
    return 0.5 * displaced_mass(env, body, fraction)


@compiled
def drag_factors(env, body, fraction):
    """(factor_air, factor_water) = 1/2*rho*C_d*A*fraction per medium, kg/m: the drag of
    a medium is -factor * |v_rel| * v_rel."""
    shape = 0.5 * body.drag_coefficient * body.cross_section
    return shape * env.air_density * (1.0 - fraction), shape * env.water_density * fraction


@compiled
def drag_force(env, factor_air, factor_water, velocity):
    """-factor*|v - u|*(v - u) per medium, u = wind or current."""
    vx, vy, vz = velocity
    ax, ay, az = vx - env.wind_x, vy - env.wind_y, vz - env.wind_z
    wx, wy, wz = vx - env.current_x, vy - env.current_y, vz - env.current_z
    gain_air = factor_air * math.sqrt(ax * ax + ay * ay + az * az)
    gain_water = factor_water * math.sqrt(wx * wx + wy * wy + wz * wz)
    return (-(gain_air * ax + gain_water * wx), -(gain_air * ay + gain_water * wy),
            -(gain_air * az + gain_water * wz))


@compiled
def lift_coefficient(body, attack):
    """|C_l| at the angle of attack `attack` (rad, 0 = edge-on .. pi/2 = face-on): the
    lift-curve slope lift_slope * attack, capped at |lift_coefficient| (the most the surface
    gives), up to stall_angle; past the stall it falls linearly to zero face-on."""
    slope, stall, peak = body.lift_slope, body.stall_angle, abs(body.lift_coefficient)
    if attack <= stall:
        rising = slope * attack
        return rising if rising < peak else peak
    at_stall = slope * stall
    at_stall = at_stall if at_stall < peak else peak
    return at_stall * (HALF_PI - attack) / (HALF_PI - stall)


@compiled
def medium_lift(density, fraction, body, rx, ry, rz):
    """1/2*rho*C_l(alpha)*A*|w|^2*fraction, perpendicular to the sphere's velocity w =
    (rx, ry, rz) relative to the medium, in the plane of w and the lifting normal n.

    alpha is the angle between w and the lifting surface: 0 edge-on (no lift), pi/2
    face-on (no lift: past the stall). The flow pushes the surface away from the side it
    meets, so the lift points along the part of n across w, signed against n.w (and by the
    sign of lift_coefficient): it changes smoothly through both ends, never flips."""
    nx, ny, nz = body.lift_normal_x, body.lift_normal_y, body.lift_normal_z
    speed_sq = rx * rx + ry * ry + rz * rz
    along = nx * rx + ny * ry + nz * rz
    # |w|^2 * (n - (n.w^)w^): perpendicular to w, in the plane of n and w; |w|^2 cos(alpha) long.
    dx, dy, dz = nx * speed_sq - along * rx, ny * speed_sq - along * ry, nz * speed_sq - along * rz
    length = math.sqrt(dx * dx + dy * dy + dz * dz)
    attack = math.atan2(abs(along) * math.sqrt(speed_sq), length)
    magnitude = (0.5 * density * fraction * body.lift_area * speed_sq
                 * lift_coefficient(body, attack))
    signed = -magnitude if (along > 0.0) == (body.lift_coefficient > 0.0) else magnitude
    scale = signed / length if length > 0.0 else 0.0
    return dx * scale, dy * scale, dz * scale


@compiled
def lift_force(listed, env, body, fraction, velocity):
    """Lift from the air and from the water, each weighted by the part of the sphere in it.
    In a scalar loop a medium the sphere is not in costs nothing (most spheres are wholly in
    one); a vectorised one computes both, which keeps it vectorised."""
    vx, vy, vz = velocity
    ax = ay = az = wx = wy = wz = 0.0
    # The constant first: in the vectorised build the condition is then no branch at all.
    if not listed.scalar or fraction < 1.0:
        ax, ay, az = medium_lift(env.air_density, 1.0 - fraction, body, vx - env.wind_x,
                                 vy - env.wind_y, vz - env.wind_z)
    if not listed.scalar or fraction > 0.0:
        wx, wy, wz = medium_lift(env.water_density, fraction, body, vx - env.current_x,
                                 vy - env.current_y, vz - env.current_z)
    return ax + wx, ay + wy, az + wz


@compiled
def inertia(listed, env, body, fraction):
    """kg that resists acceleration: the mass, plus added mass when listed."""
    if listed.added_mass:
        return body.mass + added_mass(env, body, fraction)
    return body.mass


@compiled
def explicit_force(listed, env, body, velocity, fraction):
    """Every listed force but drag, plus the external force, N: what the default integrator
    takes explicitly."""
    fx, fy, fz = body.force_x, body.force_y, body.force_z
    if listed.gravity:
        gx, gy, gz = gravity_force(env, body)
        fx, fy, fz = fx + gx, fy + gy, fz + gz
    if listed.buoyancy:
        bx, by, bz = buoyancy_force(env, body, fraction)
        fx, fy, fz = fx + bx, fy + by, fz + bz
    if listed.lift:
        lx, ly, lz = lift_force(listed, env, body, fraction, velocity)
        fx, fy, fz = fx + lx, fy + ly, fz + lz
    return fx, fy, fz


@compiled
def near_surface(env, body, z):
    """Whether a sphere centred at height z (m) crosses the water's surface: its draft
    d / r in (0, 2), where heave_radiation is not zero (false for NaN)."""
    draft = 1.0 + (env.surface_z - z) * body.inverse_radius
    return (draft > 0.0) & (draft < 2.0)


@compiled
def heave_radiation(listed, env, body, z):
    """(added kg, added_slope kg/m, damping kg/s) of the waves a sphere crossing the surface
    radiates as it heaves: linear potential flow's added mass A33 and radiation damping B33
    at its draft, at the dominant complex root of its heave there (wave_table.py, from
    Capytaine's BEM; the added mass is tapered to zero over the last 0.2 r before the sphere
    is wholly under). added_slope is dA33/dz. All zero off the surface, or without water.

    The force is -A33 z'' - B33 (z' - current_z), and, while the sphere takes on water to
    carry (dA33/dt > 0), -dA33/dt z': it shares its momentum with that water, as at a
    water entry (von Karman). Water it stops carrying keeps its energy: it leaves as waves,
    pushing nothing back (which would fling a light sphere out with the energy of water
    thousands of times its mass). So 1/2 (m + A33) z'^2 + potential, the water carried
    counted, never grows.
    """
    radius, inverse_radius, density = body.radius, body.inverse_radius, env.water_density
    draft = 1.0 + (env.surface_z - z) * inverse_radius  # s = d / r: 0 touching, 2 wholly under
    inside = near_surface(env, body, z)
    if listed.scalar and not inside:
        return 0.0, 0.0, 0.0
    # In (s, t = mu / (1 + mu)), mu = m / (rho r^3): the added mass a cubic Hermite spline
    # in s (its slope continuous inside the band, so the force of the water taken on jumps
    # only where the band begins and ends), linear in t; the damping bilinear. Clamped
    # before the index is taken, NaN to 0.
    scale = density * radius * radius * radius
    row = draft * _CELLS_PER_DRAFT
    row = row if row > 0.0 else 0.0
    row = row if row < _DRAFT_CELLS else float(_DRAFT_CELLS)
    i = min(int(row), _DRAFT_CELLS - 1)
    column = body.mass / (body.mass + scale) * _MASS_CELLS
    column = column if column > 0.0 else 0.0
    column = column if column < _MASS_CELLS else float(_MASS_CELLS)
    j = min(int(column), _MASS_CELLS - 1)
    u, w = row - i, column - j
    table = env.wave_table
    low = table[_ADDED, i, j] + w * (table[_ADDED, i, j + 1] - table[_ADDED, i, j])
    high = table[_ADDED, i + 1, j] + w * (table[_ADDED, i + 1, j + 1] - table[_ADDED, i + 1, j])
    # Slopes per cell (ds = one cell): the nodes' dA/ds over the cells per unit of s.
    cell = 1.0 / _CELLS_PER_DRAFT
    slope_low = cell * (table[_ADDED_SLOPE, i, j] + w * (table[_ADDED_SLOPE, i, j + 1]
                                                         - table[_ADDED_SLOPE, i, j]))
    slope_high = cell * (table[_ADDED_SLOPE, i + 1, j] + w * (
        table[_ADDED_SLOPE, i + 1, j + 1] - table[_ADDED_SLOPE, i + 1, j]))
    rate_low = table[_DAMPING, i, j] + w * (table[_DAMPING, i, j + 1] - table[_DAMPING, i, j])
    rate_high = table[_DAMPING, i + 1, j] + w * (table[_DAMPING, i + 1, j + 1]
                                                 - table[_DAMPING, i + 1, j])
    on = 1.0 if inside else 0.0
    # Hermite basis on u in [0, 1]
    u2 = u * u
    u3 = u2 * u
    value = ((2.0 * u3 - 3.0 * u2 + 1.0) * low + (u3 - 2.0 * u2 + u) * slope_low
             + (3.0 * u2 - 2.0 * u3) * high + (u3 - u2) * slope_high)
    per_cell = ((6.0 * u2 - 6.0 * u) * (low - high) + (3.0 * u2 - 4.0 * u + 1.0) * slope_low
                + (3.0 * u2 - 2.0 * u) * slope_high)
    added = on * scale * value
    # d/dz = d/du * du/ds * ds/dz, ds/dz = -1/r
    added_slope = -on * scale * per_cell * _CELLS_PER_DRAFT * inverse_radius
    damping = on * scale * math.sqrt(abs(env.gravity_z) * inverse_radius) * (
        rate_low + u * (rate_high - rate_low))
    return added, added_slope, damping


@numba.njit(error_model='numpy')  # not cached: numba's cache would miss a new wave_table
def heave_added_masses(environment, properties, z):
    """(n,) kg: heave_radiation's added mass of each sphere at centre height z (n,) m, for
    the energy of the water the spheres carry. environment: (12,), in Env's order;
    properties: the spheres' arrays (kernels/layout.py's properties_of)."""
    env = env_of(environment, WAVE_TABLE)
    added = np.zeros(z.shape[0])
    for i in range(z.shape[0]):
        body = body_of(properties, i)
        added[i] = heave_radiation(_LISTED_SCALAR, env, body, z[i])[0]
    return added


@compiled
def water_taken_on(listed, env, body, inertia_z, added, z, vz):
    """v_z (m/s) of a sphere of vertical inertia inertia_z (kg, with the added mass `added`
    it carried) moved to height z (m) at v_z = vz: where it carries more water there, it
    shares its momentum with the water taken on; where less, v_z stays (heave_radiation)."""
    taken_on = heave_radiation(listed, env, body, z)[0] - added
    return vz * inertia_z / (inertia_z + taken_on) if taken_on > 0.0 else vz


@compiled
def acceleration(listed, env, body, position, velocity):
    """m/s^2 of every listed smooth force and the external force: what the explicit
    integrators step."""
    fraction = water_fraction(listed, env, body, position[2])
    fx, fy, fz = explicit_force(listed, env, body, velocity, fraction)
    if listed.drag:
        factor_air, factor_water = drag_factors(env, body, fraction)
        dx, dy, dz = drag_force(env, factor_air, factor_water, velocity)
        fx, fy, fz = fx + dx, fy + dy, fz + dz
    resisting = inertia(listed, env, body, fraction)
    if listed.wave_radiation:
        added, added_slope, damping = heave_radiation(listed, env, body, position[2])
        vz = velocity[2]
        taking_on = added_slope * vz  # dA33/dt, kg/s
        fz -= (taking_on if taking_on > 0.0 else 0.0) * vz + damping * (vz - env.current_z)
        return fx / resisting, fy / resisting, fz / (resisting + added)
    return fx / resisting, fy / resisting, fz / resisting


@compiled
def buoyancy_stiffness(cap, env, body, z, predicted_z):
    """N/m: buoyancy's restoring stiffness -dF_z/dz over a step, never negative.

    The larger of the slope at the step's start and the secant slope from there to
    predicted_z (m, where z would end without the spring), which is held to the waterline
    band: the slope is non-zero only while a sphere crosses the surface, so a step from
    fully under (or above) the water that would cross the band would otherwise feel no
    spring at all.
    """
    radius, volume, inverse_radius = body.radius, body.volume, body.inverse_radius
    surface_z = env.surface_z
    spring_per_volume_slope = -env.gravity_z * (env.water_density - env.air_density)
    predicted_z = min(max(predicted_z, surface_z - radius), surface_z + radius)
    at_start = spring_per_volume_slope * waterline_volume_slope(cap, z, radius, volume,
                                                                surface_z)
    secant = spring_per_volume_slope * volume * submerged_fraction_slope(
        cap, z, predicted_z, radius, inverse_radius, surface_z)
    stiffness = secant if secant > at_start else at_start
    return stiffness if stiffness > 0.0 else 0.0
