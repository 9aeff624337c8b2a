"""The smooth forces, one small compiled function each, and the composition a scene lists.

Every function here works on one sphere and is compiled by numba and inlined where it is
called: the step (stepper.py) composes them into one loop over the spheres, in which an
effect the scene does not list is a branch on a compile-time constant, removed before the
loop is built. What a sphere is to these functions:

- `listed`: the scene's effects as compile-time flags, see effect_flags().
- `env`: the world, a flat tuple (gx, gy, gz, air_density, wind_x, wind_y, wind_z,
  water_density, current_x, current_y, current_z, surface_z): m/s^2, kg/m^3, m/s, m.
- `body`: one sphere's properties, a flat tuple (mass kg, radius m, volume m^3,
  cross_section m^2, drag_coefficient, lift_coefficient, lift_area m^2, lift normal
  (3, unit), external force (3, N, world axes), 1/radius 1/m).
- positions and velocities are 3-tuples, m and m/s; forces 3-tuples, N.

Forces from each medium are weighted by the fraction of the sphere's volume inside it:
`fraction` is that fraction for water, 1 - fraction for air.
"""
import math

from .media import compiled, submerged_fraction, submerged_fraction_slope, \
    waterline_volume_slope

EFFECTS = ('gravity', 'buoyancy', 'drag', 'lift', 'added_mass', 'contact', 'friction')
DEFAULT_EFFECTS = ('gravity', 'buoyancy', 'drag', 'contact', 'friction')
# The smooth effects, in the order of effect_flags' tuple (then the submerged-volume model).
SMOOTH_EFFECTS = ('gravity', 'buoyancy', 'drag', 'lift', 'added_mass')


def effect_flags(effects, submerged_volume='cap', scalar=True):
    """The compile-time tuple the compiled functions branch on: (gravity, buoyancy, drag,
    lift, added_mass, cap, scalar) as bools; cap is False for the linear submerged volume;
    scalar (the plain loop, not the vectorised one) lets a function skip work a sphere does
    not need by a branch, which a vectorised loop would pay for on both sides."""
    unknown = set(effects) - set(EFFECTS)
    if unknown:
        raise ValueError(f'effects: unknown {sorted(unknown)}; allowed: {list(EFFECTS)}')
    if submerged_volume not in ('cap', 'linear'):
        raise ValueError(f"submerged_volume: 'cap' or 'linear', got {submerged_volume!r}")
    return tuple(name in effects for name in SMOOTH_EFFECTS) + (submerged_volume == 'cap',
                                                                 bool(scalar))


@compiled
def water_fraction(listed, env, body, z):
    """Fraction of the sphere under water; 0 without computing it when no listed effect
    needs it (gravity alone, or nothing)."""
    gravity, buoyancy, drag, lift, added, cap, scalar = listed
    if not (buoyancy or drag or lift or added):
        return 0.0
    return submerged_fraction(cap, z, body[1], body[13], env[11])


@compiled
def gravity_force(env, body):
    """m*g."""
    mass = body[0]
    return env[0] * mass, env[1] * mass, env[2] * mass


@compiled
def displaced_mass(env, body, fraction):
    """rho*V_sub summed over both media, kg."""
    return body[2] * (env[3] + (env[7] - env[3]) * fraction)


@compiled
def buoyancy_force(env, body, fraction):
    """-rho*V_sub*g from each medium: always against gravity, whatever its direction."""
    displaced = displaced_mass(env, body, fraction)
    return -env[0] * displaced, -env[1] * displaced, -env[2] * displaced


@compiled
def added_mass(env, body, fraction):
    """1/2*rho*V in each medium (kg): the fluid a sphere must push aside as it accelerates."""
    return 0.5 * displaced_mass(env, body, fraction)


@compiled
def drag_factors(env, body, fraction):
    """(factor_air, factor_water) = 1/2*rho*C_d*A*fraction per medium, kg/m: the drag of
    a medium is -factor * |v_rel| * v_rel."""
    shape = 0.5 * body[4] * body[3]
    return shape * env[3] * (1.0 - fraction), shape * env[7] * fraction


@compiled
def drag_force(env, factor_air, factor_water, velocity):
    """-factor*|v - u|*(v - u) per medium, u = wind or current."""
    vx, vy, vz = velocity
    ax, ay, az = vx - env[4], vy - env[5], vz - env[6]
    wx, wy, wz = vx - env[8], vy - env[9], vz - env[10]
    gain_air = factor_air * math.sqrt(ax * ax + ay * ay + az * az)
    gain_water = factor_water * math.sqrt(wx * wx + wy * wy + wz * wz)
    return (-(gain_air * ax + gain_water * wx), -(gain_air * ay + gain_water * wy),
            -(gain_air * az + gain_water * wz))


@compiled
def medium_lift(density, fraction, body, rx, ry, rz):
    """1/2*rho*C_l*A*|w|^2*fraction along the part of the lifting normal perpendicular to the
    relative velocity w = (rx, ry, rz); none along w itself, where that plane is undefined."""
    nx, ny, nz = body[7], body[8], body[9]
    speed_sq = rx * rx + ry * ry + rz * rz
    along = nx * rx + ny * ry + nz * rz
    # |w|^2 * (n - (n.w^)w^): perpendicular to w, in the plane of n and w.
    dx, dy, dz = nx * speed_sq - along * rx, ny * speed_sq - along * ry, nz * speed_sq - along * rz
    length = math.sqrt(dx * dx + dy * dy + dz * dz)
    magnitude = 0.5 * density * fraction * body[5] * body[6] * speed_sq
    scale = magnitude / length if length > 1e-300 else 0.0
    return dx * scale, dy * scale, dz * scale


@compiled
def lift_force(listed, env, body, fraction, velocity):
    """Lift from the air and from the water, each weighted by the part of the sphere in it.
    In a scalar loop a medium the sphere is not in costs nothing (most spheres are wholly in
    one); a vectorised one computes both, which keeps it vectorised."""
    vx, vy, vz = velocity
    ax = ay = az = wx = wy = wz = 0.0
    # The constant first: in the vectorised build the condition is then no branch at all.
    if not listed[6] or fraction < 1.0:
        ax, ay, az = medium_lift(env[3], 1.0 - fraction, body, vx - env[4], vy - env[5],
                                 vz - env[6])
    if not listed[6] or fraction > 0.0:
        wx, wy, wz = medium_lift(env[7], fraction, body, vx - env[8], vy - env[9], vz - env[10])
    return ax + wx, ay + wy, az + wz


@compiled
def inertia(listed, env, body, fraction):
    """kg that resists acceleration: the mass, plus added mass when listed."""
    if listed[4]:
        return body[0] + added_mass(env, body, fraction)
    return body[0]


@compiled
def explicit_force(listed, env, body, velocity, fraction):
    """Every listed force but drag, plus the external force, N: what the default integrator
    takes explicitly."""
    fx, fy, fz = body[10], body[11], body[12]
    if listed[0]:
        gx, gy, gz = gravity_force(env, body)
        fx, fy, fz = fx + gx, fy + gy, fz + gz
    if listed[1]:
        bx, by, bz = buoyancy_force(env, body, fraction)
        fx, fy, fz = fx + bx, fy + by, fz + bz
    if listed[3]:
        lx, ly, lz = lift_force(listed, env, body, fraction, velocity)
        fx, fy, fz = fx + lx, fy + ly, fz + lz
    return fx, fy, fz


@compiled
def acceleration(listed, env, body, position, velocity):
    """m/s^2 of every listed smooth force and the external force: what the explicit
    integrators step."""
    fraction = water_fraction(listed, env, body, position[2])
    fx, fy, fz = explicit_force(listed, env, body, velocity, fraction)
    if listed[2]:
        factor_air, factor_water = drag_factors(env, body, fraction)
        dx, dy, dz = drag_force(env, factor_air, factor_water, velocity)
        fx, fy, fz = fx + dx, fy + dy, fz + dz
    resisting = inertia(listed, env, body, fraction)
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
    radius, volume, inverse_radius, surface_z = body[1], body[2], body[13], env[11]
    spring_per_volume_slope = -env[2] * (env[7] - env[3])
    predicted_z = min(max(predicted_z, surface_z - radius), surface_z + radius)
    at_start = spring_per_volume_slope * waterline_volume_slope(cap, z, radius, volume,
                                                                surface_z)
    secant = spring_per_volume_slope * volume * submerged_fraction_slope(
        cap, z, predicted_z, radius, inverse_radius, surface_z)
    stiffness = secant if secant > at_start else at_start
    return stiffness if stiffness > 0.0 else 0.0
