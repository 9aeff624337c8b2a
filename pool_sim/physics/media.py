"""The world the spheres live in: two fluids split by a horizontal surface, inside a box.

Air fills z > surface_z and water z < surface_z. How much of a sphere is in each is the
exact spherical cap below the surface (or, for comparison only, the linear approximation).
"""
from dataclasses import dataclass, field

import numpy as np


@dataclass(frozen=True)
class Medium:
    """A fluid at rest or in uniform flow.

    density: kg/m^3.  flow_velocity: (3,) m/s, the wind or current the drag acts against.
    """

    density: float
    flow_velocity: np.ndarray = field(default_factory=lambda: np.zeros(3))


@dataclass(frozen=True)
class Pool:
    """The box the spheres live in: floor at corner_min[2], ceiling at corner_max[2] (m)."""

    corner_min: np.ndarray
    corner_max: np.ndarray

    @property
    def extent(self) -> np.ndarray:
        return self.corner_max - self.corner_min


@dataclass(frozen=True)
class Environment:
    """Everything the forces depend on that is not a property of a sphere.

    gravity: (3,) m/s^2, any direction.  surface_z: height of the water surface (m).
    """

    gravity: np.ndarray
    air: Medium
    water: Medium
    surface_z: float
    pool: Pool


def submerged_depth(z, radius, surface_z):
    """Height of the sphere's part below the surface, clipped to [0, 2r] (m)."""
    return np.clip(surface_z - (z - radius), 0.0, 2.0 * radius)


def cap_fraction(z, radius, surface_z):
    """Exact fraction of a sphere's volume below the surface.

    The cap of height h holds pi*h^2*(3r - h)/3 of the sphere's 4*pi*r^3/3.
    """
    h_over_r = submerged_depth(z, radius, surface_z) / radius
    return 0.25 * h_over_r * h_over_r * (3.0 - h_over_r)


def _secant_terms(z_from, z_to, radius, surface_z):
    """(h1, h2, share): h = submerged depth / r at both heights, held to [0, 2], and the
    share of the way from z_from to z_to that lies in the waterline band (1 where equal)."""
    h1 = np.clip((surface_z - z_from) / radius + 1.0, 0.0, 2.0)
    h2 = np.clip((surface_z - z_to) / radius + 1.0, 0.0, 2.0)
    travel = z_to - z_from
    moving = travel != 0.0
    share = np.divide((h1 - h2) * radius, travel, out=np.ones_like(h1), where=moving)
    return h1, h2, share


def cap_fraction_slope(z_from, z_to, radius, surface_z):
    """-(change of cap_fraction) / (change of z) from z_from to z_to, 1/m: the secant
    slope, and at z_from == z_to the slope itself.

    In h the fraction is the cubic h^2 (3 - h) / 4, whose divided difference
    (3 (h1 + h2) - (h1^2 + h1 h2 + h2^2)) / 4 needs no division by h2 - h1, so there is no
    cancellation however close the heights; beyond the band the fraction does not change,
    which the share of the way inside the band accounts for.
    """
    h1, h2, share = _secant_terms(z_from, z_to, radius, surface_z)
    return 0.25 * (3.0 * (h1 + h2) - (h1 * h1 + h1 * h2 + h2 * h2)) / radius * share


def linear_fraction_slope(z_from, z_to, radius, surface_z):
    """As cap_fraction_slope for linear_fraction (slope 1/(2r) within the band)."""
    h1, h2, share = _secant_terms(z_from, z_to, radius, surface_z)
    in_band = (h1 != h2) | ((h1 > 0.0) & (h1 < 2.0))
    return np.where(in_band, 0.5 / radius * share, 0.0)


def linear_fraction(z, radius, surface_z):
    """The seed's approximation: fraction = depth / diameter. Kept only for comparison."""
    return submerged_depth(z, radius, surface_z) / (2.0 * radius)


def cap_volume_integral(z, radius, surface_z):
    """W(z) = integral of the submerged volume over the sphere's depth, m^4.

    dW/dz = -V_sub(z), so W builds the buoyancy potential: W = pi*(r*h^3 - h^4/4)/3 while the
    cap grows, then grows linearly at V once the sphere is under.
    """
    full_depth = surface_z - (z - radius)
    h = np.clip(full_depth, 0.0, 2.0 * radius)
    under = np.maximum(full_depth - 2.0 * radius, 0.0)
    volume = 4.0 / 3.0 * np.pi * radius**3
    return np.pi * (radius * h**3 - 0.25 * h**4) / 3.0 + volume * under


def linear_volume_integral(z, radius, surface_z):
    """W(z) of the linear approximation (V_sub = V*h/(2r)), m^4: V*h^2/(4r) while crossing,
    then growing at V once the sphere is under. dW/dz = -V_sub(z), as cap_volume_integral."""
    full_depth = surface_z - (z - radius)
    h = np.clip(full_depth, 0.0, 2.0 * radius)
    under = np.maximum(full_depth - 2.0 * radius, 0.0)
    volume = 4.0 / 3.0 * np.pi * radius**3
    return volume * h * h / (4.0 * radius) + volume * under


def waterline_area(z, radius, surface_z):
    """Area of the sphere's cross-section at the water surface, m^2 (0 when not crossing it)."""
    offset = z - surface_z
    return np.pi * np.maximum(radius * radius - offset * offset, 0.0)
