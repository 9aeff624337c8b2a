"""All spheres as one struct of arrays: vectors are (3, n), component-major; scalars are (n,).

Component-major keeps each of x, y, z contiguous, which is what numpy streams fastest.
Setters validate first and only then write, so a refused value changes nothing.
"""
from dataclasses import dataclass
import math

import numpy as np


class InvalidInput(ValueError):
    """A value the simulation refuses; the message names the key and what is allowed."""


def check_positive(name: str, value) -> float:
    """A finite number > 0, or InvalidInput naming `name`."""
    if isinstance(value, bool) or not isinstance(value, (int, float, np.floating, np.integer)):
        raise InvalidInput(f'{name}: expected a number, got {type(value).__name__} {value!r}')
    value = float(value)
    if not math.isfinite(value) or value <= 0.0:
        raise InvalidInput(f'{name}: must be finite and > 0, got {value!r}')
    return value


def check_vector(name: str, value) -> np.ndarray:
    """Three finite numbers, or InvalidInput naming `name`."""
    try:
        vector = np.asarray(value, dtype=float)
    except (TypeError, ValueError):
        raise InvalidInput(f'{name}: expected 3 numbers [x, y, z], got {value!r}') from None
    if vector.shape != (3,) or any(isinstance(v, bool) for v in np.ravel(value)):
        raise InvalidInput(f'{name}: expected 3 numbers [x, y, z], got {value!r}')
    if not np.all(np.isfinite(vector)):
        raise InvalidInput(f'{name}: every component must be finite, got {value!r}')
    return vector


@dataclass
class Spheres:
    """Per-sphere properties and kinematic state.

    position, velocity: (3, n) m, m/s.  mass: (n,) kg.  radius: (n,) m.
    drag_coefficient, lift_coefficient: (n,) dimensionless.  lift_area: (n,) m^2.
    lift_normal: (3, n) unit vectors.  external_force: (3, n) N, world frame.
    volume (m^3) and cross_section (m^2) are derived from radius and kept in step by set_radius.
    """

    names: tuple
    position: np.ndarray
    velocity: np.ndarray
    mass: np.ndarray
    radius: np.ndarray
    drag_coefficient: np.ndarray
    lift_area: np.ndarray
    lift_normal: np.ndarray
    lift_coefficient: np.ndarray
    external_force: np.ndarray

    def __post_init__(self):
        self.index = {name: i for i, name in enumerate(self.names)}
        self.volume = 4.0 / 3.0 * np.pi * self.radius**3
        self.cross_section = np.pi * self.radius**2

    @property
    def count(self) -> int:
        return len(self.names)

    def copy(self) -> 'Spheres':
        return Spheres(self.names, *(getattr(self, f).copy() for f in _ARRAY_FIELDS))

    def lookup(self, name: str) -> int:
        """Index of the sphere called `name`, or InvalidInput listing the known names."""
        try:
            return self.index[name]
        except (KeyError, TypeError):
            raise InvalidInput(
                f'unknown sphere {name!r}; known spheres: {", ".join(self.names)}') from None

    def check_mass(self, name: str, mass_kg) -> float:
        """The mass as a float, or InvalidInput; changes nothing."""
        self.lookup(name)
        return check_positive(f'{name}.mass', mass_kg)

    def check_radius(self, name: str, radius_m, pool) -> float:
        """The radius as a float if it is > 0 and fits the pool, or InvalidInput."""
        self.lookup(name)
        radius = check_positive(f'{name}.radius', radius_m)
        if 2.0 * radius >= float(np.min(pool.extent)):
            raise InvalidInput(
                f'{name}.radius: {radius} m does not fit the pool (smallest side '
                f'{float(np.min(pool.extent))} m)')
        return radius

    def set_mass(self, name: str, mass_kg) -> None:
        self.mass[self.lookup(name)] = self.check_mass(name, mass_kg)

    def set_radius(self, name: str, radius_m, pool) -> None:
        """New radius; the sphere is pushed back inside the pool if it now overlaps a wall."""
        radius = self.check_radius(name, radius_m, pool)
        i = self.lookup(name)
        self.radius[i] = radius
        self.volume[i] = 4.0 / 3.0 * np.pi * radius**3
        self.cross_section[i] = np.pi * radius**2
        self.position[:, i] = np.clip(
            self.position[:, i], pool.corner_min + radius, pool.corner_max - radius)

    def set_external_force(self, name: str, force_n) -> None:
        i = self.lookup(name)
        self.external_force[:, i] = check_vector(f'{name} wrench force', force_n)


_ARRAY_FIELDS = ('position', 'velocity', 'mass', 'radius', 'drag_coefficient', 'lift_area',
                 'lift_normal', 'lift_coefficient', 'external_force')
