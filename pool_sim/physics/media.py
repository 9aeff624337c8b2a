"""The world the spheres live in: two fluids split by a horizontal surface, inside a box.

Air fills z > surface_z and water z < surface_z. How much of a sphere is in each is the
exact spherical cap below the surface (or, for comparison only, the linear approximation).
The per-sphere geometry the step uses is compiled (kernels/media.py); the volume integrals
here, which only the energy diagnostics need, are numpy.
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
