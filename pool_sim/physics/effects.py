"""The smooth forces, one small function each, and the composition a scene asks for.

Forces from each medium are weighted by the fraction of the sphere's volume inside it:
`water_fraction` (n,) is that fraction for water, 1 - water_fraction for air.
Every force function adds into `force` (3, n) N in place and returns nothing.
"""
import numpy as np

from .media import (cap_fraction, cap_fraction_slope, linear_fraction, linear_fraction_slope,
                    waterline_area)

EFFECTS = ('gravity', 'buoyancy', 'drag', 'lift', 'added_mass', 'contact', 'friction')
DEFAULT_EFFECTS = ('gravity', 'buoyancy', 'drag', 'contact', 'friction')
_NEEDS_WATER_FRACTION = {'buoyancy', 'drag', 'lift', 'added_mass'}


def gravity_force(env, spheres, position, velocity, water_fraction, force):
    """m*g."""
    force += env.gravity[:, None] * spheres.mass


def buoyancy_force(env, spheres, position, velocity, water_fraction, force):
    """-rho*V_sub*g from each medium: always against gravity, whatever its direction."""
    displaced_mass = spheres.volume * (
        env.air.density + (env.water.density - env.air.density) * water_fraction)
    force -= env.gravity[:, None] * displaced_mass


def lift_force(env, spheres, position, velocity, water_fraction, force):
    """1/2*rho*C_l*A*|v_rel|^2 along the part of the lifting normal perpendicular to v_rel."""
    normal = spheres.lift_normal
    for medium, fraction in ((env.air, 1.0 - water_fraction), (env.water, water_fraction)):
        relative = velocity - medium.flow_velocity[:, None]
        speed_sq = np.einsum('ij,ij->j', relative, relative)
        # direction = |w|^2 * (n - (n.w^)w^): perpendicular to w, in the plane of n and w.
        direction = normal * speed_sq - np.einsum('ij,ij->j', normal, relative) * relative
        length = np.sqrt(np.einsum('ij,ij->j', direction, direction))
        magnitude = (0.5 * medium.density * fraction * spheres.lift_coefficient
                     * spheres.lift_area * speed_sq)
        # Along the velocity itself the lifting plane is undefined: no lift there.
        scale = np.divide(magnitude, length, out=np.zeros_like(length), where=length > 1e-300)
        force += direction * scale


def drag_factors(env, spheres, water_fraction):
    """1/2*rho*C_d*A*fraction per medium, kg/m: drag = -factor * |v_rel| * v_rel.

    (factor_air, factor_water), each (n,).
    """
    shape = 0.5 * spheres.drag_coefficient * spheres.cross_section
    return (shape * env.air.density * (1.0 - water_fraction),
            shape * env.water.density * water_fraction)


def drag_gains(env, factors, velocity):
    """Quadratic drag written as linear gains: F = -gain_air*(v - wind) - gain_water*(v - current).

    factors: drag_factors' (factor_air, factor_water). gain = factor * |v_rel|, kg/s, one
    (n,) array per medium.
    """
    gains = []
    for medium, factor in zip((env.air, env.water), factors):
        relative = velocity - medium.flow_velocity[:, None]
        gains.append(factor * np.sqrt(np.einsum('ij,ij->j', relative, relative)))
    return gains[0], gains[1]


def added_mass(env, spheres, water_fraction):
    """1/2*rho*V in each medium (kg): the fluid a sphere must push aside as it accelerates."""
    return 0.5 * spheres.volume * (
        env.air.density + (env.water.density - env.air.density) * water_fraction)


class Dynamics:
    """The smooth part of a scene: the forces its `effects` list names, and nothing else.

    Composed once; an effect that is not listed is never called.
    submerged_volume: 'cap' (exact) or 'linear' (the seed's approximation, for comparison).
    """

    def __init__(self, env, effects, submerged_volume='cap'):
        unknown = set(effects) - set(EFFECTS)
        if unknown:
            raise ValueError(f'effects: unknown {sorted(unknown)}; allowed: {list(EFFECTS)}')
        self.env = env
        self.effects = tuple(effects)
        self.explicit_forces = [fn for name, fn in (('gravity', gravity_force),
                                                    ('buoyancy', buoyancy_force),
                                                    ('lift', lift_force)) if name in effects]
        self.has_drag = 'drag' in effects
        self.has_added_mass = 'added_mass' in effects
        self.has_buoyancy = 'buoyancy' in effects
        self.needs_water_fraction = bool(_NEEDS_WATER_FRACTION & set(effects))
        self.fraction_of = {'cap': cap_fraction, 'linear': linear_fraction}[submerged_volume]
        self.fraction_slope_of = {'cap': cap_fraction_slope,
                                  'linear': linear_fraction_slope}[submerged_volume]
        self.submerged_volume = submerged_volume

    def water_fraction(self, spheres, position):
        """(n,) fraction of each sphere under water, or None when no effect needs it."""
        if not self.needs_water_fraction:
            return None
        return self.fraction_of(position[2], spheres.radius, self.env.surface_z)

    def inertia(self, spheres, water_fraction):
        """(n,) kg that resists acceleration: the mass, plus added mass when listed."""
        if self.has_added_mass:
            return spheres.mass + added_mass(self.env, spheres, water_fraction)
        return spheres.mass

    def explicit_force(self, spheres, position, velocity, water_fraction):
        """(3, n) N: every listed force except drag, plus the external force."""
        force = spheres.external_force.copy()
        for add_force in self.explicit_forces:
            add_force(self.env, spheres, position, velocity, water_fraction, force)
        return force

    def drag_gains(self, spheres, velocity, water_fraction):
        """(gain_air, gain_water) kg/s, or None when drag is not listed."""
        factors = self.drag_factors(spheres, water_fraction)
        return None if factors is None else drag_gains(self.env, factors, velocity)

    def drag_factors(self, spheres, water_fraction):
        """(factor_air, factor_water) kg/m, or None when drag is not listed."""
        if not self.has_drag:
            return None
        return drag_factors(self.env, spheres, water_fraction)

    def drag_force(self, gains, velocity):
        gain_air, gain_water = gains
        return -(gain_air * (velocity - self.env.air.flow_velocity[:, None])
                 + gain_water * (velocity - self.env.water.flow_velocity[:, None]))

    def vertical_stiffness(self, spheres, position, predicted_z):
        """(n,) N/m: buoyancy's restoring stiffness -dF_z/dz over a step, clipped at 0.

        The larger of the slope at the step's start and the secant slope from there to
        predicted_z (m, where z would end without the spring, held to the waterline band).
        The slope is non-zero only
        while a sphere crosses the surface, so a step from fully under (or above) the water
        that would cross the waterline band would otherwise feel no spring at all.
        """
        if not self.has_buoyancy:
            return None
        radius, surface_z = spheres.radius, self.env.surface_z
        if self.submerged_volume == 'cap':
            dvolume_dz = -waterline_area(position[2], radius, surface_z)
        else:
            crossing = np.abs(position[2] - surface_z) < radius
            dvolume_dz = -np.where(crossing, spheres.volume / (2.0 * radius), 0.0)
        predicted_z = np.clip(predicted_z, surface_z - radius, surface_z + radius)
        secant = -spheres.volume * self.fraction_slope_of(position[2], predicted_z, radius,
                                                          surface_z)
        spring_per_volume_slope = self.env.gravity[2] * (self.env.water.density
                                                         - self.env.air.density)
        return np.maximum(np.maximum(spring_per_volume_slope * dvolume_dz,
                                     spring_per_volume_slope * secant), 0.0)

    def acceleration(self, spheres, position, velocity):
        """(3, n) m/s^2 of the smooth forces: what the explicit integrators step."""
        water_fraction = self.water_fraction(spheres, position)
        force = self.explicit_force(spheres, position, velocity, water_fraction)
        gains = self.drag_gains(spheres, velocity, water_fraction)
        if gains is not None:
            force += self.drag_force(gains, velocity)
        return force / self.inertia(spheres, water_fraction)
