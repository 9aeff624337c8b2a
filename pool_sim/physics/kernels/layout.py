"""What one sphere and the world are to the per-sphere functions: namedtuples of floats
(numba folds a field read by name to the same code as one read by number).

- `Listed`: the scene's choices as compile-time flags (bools), see effects.effect_flags:
  gravity, buoyancy, drag, lift, added_mass, wave_radiation (each listed or not); cap (the
  exact spherical-cap submerged volume, False for the linear one); scalar (the plain loop,
  not the vectorised one: a function may skip work a sphere does not need by a branch,
  which a vectorised loop would pay for on both sides).
- `Env`: the world. gravity_x, gravity_y, gravity_z m/s^2; air_density kg/m^3; wind_x,
  wind_y, wind_z m/s; water_density kg/m^3; current_x, current_y, current_z m/s;
  surface_z m (the water's surface); wave_table, the heave radiation table (3, drafts,
  masses) float64 (effects.WAVE_TABLE), an array read by heave_radiation. The step takes
  the floats as a (12,) float64 array in this order and the table beside it (env_of): an
  argument, not a module constant, because a GPU holds only 64 kB of constants.
- `Body`: one sphere. mass kg; radius m; volume m^3; cross_section m^2; drag_coefficient,
  lift_coefficient (dimensionless); lift_area m^2; lift_normal_x, _y, _z (a unit vector);
  force_x, force_y, force_z N (the external force, world axes); inverse_radius 1/m (a
  product where a division would cost several); lift_slope 1/rad; stall_angle rad. Packed
  from the spheres' arrays (PROPERTIES) by body_of only.
"""
from collections import namedtuple

from . import compiled

Listed = namedtuple('Listed', ('gravity', 'buoyancy', 'drag', 'lift', 'added_mass',
                               'wave_radiation', 'cap', 'scalar'))
Env = namedtuple('Env', ('gravity_x', 'gravity_y', 'gravity_z', 'air_density', 'wind_x',
                         'wind_y', 'wind_z', 'water_density', 'current_x', 'current_y',
                         'current_z', 'surface_z', 'wave_table'))
Body = namedtuple('Body', ('mass', 'radius', 'volume', 'cross_section', 'drag_coefficient',
                           'lift_coefficient', 'lift_area', 'lift_normal_x', 'lift_normal_y',
                           'lift_normal_z', 'force_x', 'force_y', 'force_z',
                           'inverse_radius', 'lift_slope', 'stall_angle'))
# The spheres' arrays a Body is read from, by their names on Spheres: (n,) each, but
# lift_normal and external_force (3, n).
PROPERTIES = ('mass', 'radius', 'volume', 'cross_section', 'drag_coefficient',
              'lift_coefficient', 'lift_area', 'lift_normal', 'external_force', 'lift_slope',
              'stall_angle')
# Every array of the spheres a step reads: the state, then PROPERTIES.
SPHERE_ARRAYS = ('position', 'velocity', *PROPERTIES)


@compiled
def env_of(environment, wave_table):
    """The world from its (12,) float64 array, in Env's order, and the wave table."""
    return Env(environment[0], environment[1], environment[2], environment[3],
               environment[4], environment[5], environment[6], environment[7],
               environment[8], environment[9], environment[10], environment[11], wave_table)


def properties_of(spheres):
    """The tuple of a Spheres' arrays body_of takes (PROPERTIES, in order)."""
    return tuple(getattr(spheres, name) for name in PROPERTIES)


@compiled
def body_of(properties, i):
    """Sphere i from the tuple of the spheres' arrays (PROPERTIES, in order)."""
    (mass, radius, volume, cross_section, drag_coefficient, lift_coefficient, lift_area,
     lift_normal, external_force, lift_slope, stall_angle) = properties
    return Body(mass[i], radius[i], volume[i], cross_section[i], drag_coefficient[i],
                lift_coefficient[i], lift_area[i], lift_normal[0, i], lift_normal[1, i],
                lift_normal[2, i], external_force[0, i], external_force[1, i],
                external_force[2, i], 1.0 / radius[i], lift_slope[i], stall_angle[i])
