"""The world the spheres live in: two fluids split by a horizontal surface, inside a box.

Air fills z > surface_z and water z < surface_z. How much of a sphere is in each is the
exact spherical cap below the surface (or, for comparison only, the linear approximation).
The per-sphere geometry the step uses is compiled (numba); the volume integrals, which only
the energy diagnostics need, are numpy.
"""
from dataclasses import dataclass, field
import math

import numba
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


def compiled(function):
    """A per-sphere scalar function, compiled by numba and inlined wherever it is called, so
    the step a scene composes from these is one loop body the compiler can specialise."""
    return numba.njit(forceinline=True, error_model='numpy')(function)


@compiled
def submerged_fraction(cap, z, radius, inverse_radius, surface_z):
    """Fraction of a sphere's volume below the surface (inverse_radius = 1/radius, 1/m: a
    product where a division would cost several).

    cap (True): the exact spherical cap: the cap of height h holds pi*h^2*(3r - h)/3 of the
    sphere's 4*pi*r^3/3. False: the seed's approximation, depth / diameter (for comparison).
    """
    depth = surface_z - (z - radius)
    depth = 0.0 if depth < 0.0 else depth
    depth = 2.0 * radius if depth > 2.0 * radius else depth
    h = depth * inverse_radius
    if cap:
        return 0.25 * h * h * (3.0 - h)
    return 0.5 * h


@compiled
def submerged_fraction_slope(cap, z_from, z_to, radius, inverse_radius, surface_z):
    """-(change of submerged_fraction) / (change of z) from z_from to z_to, 1/m: the secant
    slope, and at z_from == z_to the slope itself.

    In h = depth / r the cap's fraction is the cubic h^2 (3 - h) / 4, whose divided
    difference (3 (h1 + h2) - (h1^2 + h1 h2 + h2^2)) / 4 needs no division by h2 - h1, so
    there is no cancellation however close the heights; the linear model's is 1/2. Beyond
    the waterline band the fraction does not change, which the share of the way from z_from
    to z_to inside the band accounts for.
    """
    h1 = min(max((surface_z - z_from) * inverse_radius + 1.0, 0.0), 2.0)
    h2 = min(max((surface_z - z_to) * inverse_radius + 1.0, 0.0), 2.0)
    travel = z_to - z_from
    share = (h1 - h2) * radius / (travel if travel != 0.0 else 1.0)
    share = share if travel != 0.0 else 1.0
    if cap:
        return 0.25 * (3.0 * (h1 + h2) - (h1 * h1 + h1 * h2 + h2 * h2)) * inverse_radius * share
    in_band = h1 != h2 or (h1 > 0.0 and h1 < 2.0)
    return 0.5 * inverse_radius * share if in_band else 0.0


@compiled
def waterline_volume_slope(cap, z, radius, volume, surface_z):
    """-dV_sub/dz at z, m^2: the area of the sphere's section at the surface (exact cap), or
    V/(2r) while the linear model's sphere crosses the surface; 0 when it does not."""
    offset = z - surface_z
    if cap:
        reach = radius * radius - offset * offset
        return math.pi * (reach if reach > 0.0 else 0.0)
    return 0.5 * volume / radius if abs(offset) < radius else 0.0


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
