"""All spheres as one struct of arrays: vectors are (3, n), component-major; scalars are (n,).

Component-major keeps each of x, y, z contiguous, which is what numpy streams fastest.
Setters validate first and only then write, so a refused value changes nothing.

Every number a client or a file can set has a physically meaningful range, checked here
(numbers, vectors) and shown in the node's parameter descriptors. Within the ranges the
arithmetic of a step cannot overflow; what an unstable explicit integrator still does is
caught by the step guard (Simulation).
"""
from dataclasses import dataclass
import math
import numbers
import re
from typing import NamedTuple

import numpy as np


class InvalidInput(ValueError):
    """A value the simulation refuses; the message names the key and what is allowed."""


# The ranges of the quantities the core takes from outside (inclusive).
MASS_RANGE_KG = (1e-6, 1e9)  # a milligram to a large ship
RADIUS_RANGE_M = (1e-4, 1e3)  # a tenth of a millimetre to a kilometre (it must fit the pool)
# m^2: none to 10 km^2, beyond pi r^2 of the largest sphere (r = 1e3 m), which it follows
LIFT_AREA_RANGE_M2 = (0.0, 1e7)
# The lift curve (effects.lift_coefficient): thin-aerofoil theory's slope, 2 pi per radian,
# and a stall at 15 degrees, where thin plates and most aerofoils stall.
LIFT_SLOPE = 2.0 * math.pi  # 1/rad
STALL_ANGLE = math.radians(15.0)  # rad
FORCE_LIMIT_N = 1e9  # per component: far beyond any thruster (a Saturn V lifts off on 3.5e7)
# How many names a message lists before it counts the rest, so that a reply or a log line
# stays short with thousands of spheres.
NAMES_SHOWN = 4
# Longest repr of a refused value a message quotes.
VALUE_SHOWN_CHARACTERS = 60
# A sphere name is one ROS name token (it becomes a topic name part): a letter or an
# underscore, then letters, digits and underscores; no '__' (ROS reserves it).
NAME_TOKEN = re.compile(r'[A-Za-z_][A-Za-z0-9_]*')
NAME_MAX_CHARACTERS = 64


def named_few(items, count=None) -> str:
    """The first NAMES_SHOWN of `items` (of `count` in all), then how many more."""
    count = len(items) if count is None else count
    shown_items = list(items[:NAMES_SHOWN])
    more = count - len(shown_items)
    return ', '.join(shown_items) + (f' and {more} more' if more > 0 else '')


def shortened(text: str) -> str:
    """text, cut to VALUE_SHOWN_CHARACTERS: a refusal never echoes a huge input."""
    if len(text) <= VALUE_SHOWN_CHARACTERS:
        return text
    return text[:VALUE_SHOWN_CHARACTERS - 3] + '...'


def shown(value) -> str:
    """repr(value), shortened."""
    return shortened(repr(value))


def is_number(value) -> bool:
    """int, float or a numpy number; bool (and numpy's bool) is not a number."""
    return (isinstance(value, numbers.Real) and not isinstance(value, (bool, np.bool_)))


def _as_float(value) -> float:
    """float(value); inf for an int beyond a double's range (float() raises there)."""
    try:
        return float(value)
    except OverflowError:
        return math.inf


def check_number(name: str, value, low, high, unit='') -> float:
    """A finite float within [low, high], or InvalidInput naming `name` and the range."""
    if not is_number(value):
        raise InvalidInput(f'{name}: expected a number, got {type(value).__name__} '
                           f'{shown(value)}')
    number = _as_float(value)
    if not math.isfinite(number):
        raise InvalidInput(f'{name}: must be finite, got {shown(value)}')
    if not low <= number <= high:
        raise InvalidInput(f'{name}: must be {range_words(low, high, unit)}, got '
                           f'{shown(value)}')
    return number


def range_words(low, high, unit='') -> str:
    """'within [low, high] unit', as refusals and parameter descriptors say it."""
    unit = f' {unit}' if unit else ''
    return f'within [{low:g}, {high:g}]{unit}'


def check_vector(name: str, value, low, high, unit='') -> np.ndarray:
    """Three finite numbers, each within [low, high], or InvalidInput naming `name`."""
    if type(value) in (tuple, list) and len(value) == 3 and all(
            type(c) is float and low <= c <= high for c in value):
        return np.array(value)  # the common case, a message's three doubles: at once
    components = list(value) if isinstance(value, (list, tuple, np.ndarray)) else None
    if components is None or len(components) != 3 or not all(map(is_number, components)):
        raise InvalidInput(f'{name}: expected 3 numbers [x, y, z], got {shown(value)}')
    vector = np.array([_as_float(c) for c in components])
    if not np.all(np.isfinite(vector)):
        raise InvalidInput(f'{name}: every component must be finite, got {shown(value)}')
    if vector.min() < low or vector.max() > high:
        raise InvalidInput(f'{name}: every component must be {range_words(low, high, unit)}, '
                           f'got {shown(value)}')
    return vector


def check_external_force(name: str, force_n) -> np.ndarray:
    """(3,) N: three finite components, each within +-FORCE_LIMIT_N, or InvalidInput."""
    return check_vector(name, force_n, -FORCE_LIMIT_N, FORCE_LIMIT_N, 'N')


def check_sphere_name(name) -> str:
    """A sphere name that is one valid ROS name token, or InvalidInput saying why."""
    if not isinstance(name, str):
        raise InvalidInput(f'sphere_names: expected strings, got {shown(name)}')
    if len(name) > NAME_MAX_CHARACTERS:
        raise InvalidInput(f'sphere_names: {shown(name)} is longer than '
                           f'{NAME_MAX_CHARACTERS} characters')
    if not NAME_TOKEN.fullmatch(name) or '__' in name:
        raise InvalidInput(
            f'sphere_names: {shown(name)} is not a valid ROS name token (a letter or _, then '
            "letters, digits and _, no '__')")
    return name


@dataclass
class Spheres:
    """Per-sphere properties and kinematic state.

    position, velocity: (3, n) m, m/s.  mass: (n,) kg.  radius: (n,) m.
    drag_coefficient, lift_coefficient: (n,) dimensionless.  lift_area: (n,) m^2.
    lift_normal: (3, n) unit vectors.  external_force: (3, n) N, world frame.
    lift_area_follows_radius: (n,) bool: where True, set_radius keeps lift_area = pi r^2
    (the scene did not give the area); set_lift_area ends it. All False when not given.
    lift_slope: (n,) 1/rad, the lift curve's slope, and stall_angle: (n,) rad, where it
    stalls (see effects.lift_coefficient); LIFT_SLOPE and STALL_ANGLE when not given.
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
    lift_area_follows_radius: np.ndarray = None
    lift_slope: np.ndarray = None
    stall_angle: np.ndarray = None

    def __post_init__(self):
        self.index = {name: i for i, name in enumerate(self.names)}
        if self.lift_slope is None:
            self.lift_slope = np.full(len(self.names), LIFT_SLOPE)
        if self.stall_angle is None:
            self.stall_angle = np.full(len(self.names), STALL_ANGLE)
        self.volume = 4.0 / 3.0 * np.pi * self.radius**3
        self.cross_section = np.pi * self.radius**2
        if self.lift_area_follows_radius is None:
            self.lift_area_follows_radius = np.zeros(len(self.names), dtype=bool)

    @property
    def count(self) -> int:
        return len(self.names)

    def copy(self) -> 'Spheres':
        """An independent copy, bit for bit: the derived arrays are copied, not recomputed
        (a vectorised power need not round as the scalar one set_radius uses)."""
        copied = Spheres(self.names, **{f: getattr(self, f).copy() for f in _ARRAY_FIELDS},
                         lift_area_follows_radius=self.lift_area_follows_radius.copy())
        for field in _DERIVED_FIELDS:
            setattr(copied, field, getattr(self, field).copy())
        return copied

    def carry_over(self, source: 'Spheres') -> None:
        """Every sphere of self that `source` has too (by name) takes its whole state from
        source: every array, the derived ones included."""
        pairs = [(i, source.index[name]) for i, name in enumerate(self.names)
                 if name in source.index]
        if not pairs:
            return
        target, origin = np.array(pairs, dtype=np.intp).T
        for field in (*_ARRAY_FIELDS, *_DERIVED_FIELDS, 'lift_area_follows_radius'):
            getattr(self, field)[..., target] = getattr(source, field)[..., origin]

    def lookup(self, name: str) -> int:
        """Index of the sphere called `name`, or InvalidInput naming a few known names."""
        try:
            return self.index[name]
        except (KeyError, TypeError):
            raise InvalidInput(f'unknown sphere {shown(name)}; known spheres: '
                               f'{named_few(self.names)}') from None

    def check_mass(self, name: str, mass_kg) -> float:
        """The mass as a float, or InvalidInput; changes nothing."""
        self.lookup(name)
        return check_number(f'{name}.mass', mass_kg, *MASS_RANGE_KG, 'kg')

    def check_radius(self, name: str, radius_m, pool) -> float:
        """The radius as a float if it is in range and fits the pool, or InvalidInput."""
        self.lookup(name)
        radius = check_number(f'{name}.radius', radius_m, *RADIUS_RANGE_M, 'm')
        if 2.0 * radius >= float(np.min(pool.extent)):
            raise InvalidInput(
                f'{name}.radius: {radius} m does not fit the pool (smallest side '
                f'{float(np.min(pool.extent))} m)')
        return radius

    def check_lift_area(self, name: str, area_m2) -> float:
        """The lift area (m^2) as a float, or InvalidInput; changes nothing."""
        self.lookup(name)
        return check_number(f'{name}.lift_area', area_m2, *LIFT_AREA_RANGE_M2, 'm^2')

    def check_change(self, name: str, key: str, value, pool) -> 'CheckedChange':
        """A live change of one sphere's mass (kg), radius (m) or lift_area (m^2), checked
        once here; apply_change writes it without checking again. InvalidInput if refused."""
        if key == 'mass':
            value = self.check_mass(name, value)
        elif key == 'radius':
            value = self.check_radius(name, value, pool)
        elif key == 'lift_area':
            value = self.check_lift_area(name, value)
        else:
            raise InvalidInput(f'{name}.{key}: cannot change while running (only '
                               f'{", ".join(LIVE_KEYS)} can)')
        return CheckedChange(self.lookup(name), key, value)

    def apply_change(self, change: 'CheckedChange', pool) -> None:
        """Write a change check_change made (for these spheres: indices are theirs). A new
        radius keeps volume, cross-section and a following lift area in step and pushes the
        sphere back inside the pool; a lift area given stops following the radius."""
        i, value = change.index, change.value
        if change.key == 'mass':
            self.mass[i] = value
        elif change.key == 'radius':
            self.radius[i] = value
            self.volume[i] = 4.0 / 3.0 * np.pi * value**3
            self.cross_section[i] = np.pi * value**2
            if self.lift_area_follows_radius[i]:
                self.lift_area[i] = math.pi * value * value  # as the scene's default
            self.position[:, i] = np.clip(
                self.position[:, i], pool.corner_min + value, pool.corner_max - value)
        else:
            self.lift_area[i] = value
            self.lift_area_follows_radius[i] = False

    def set_mass(self, name: str, mass_kg) -> None:
        self.apply_change(self.check_change(name, 'mass', mass_kg, None), None)

    def set_radius(self, name: str, radius_m, pool) -> None:
        """New radius; the sphere is pushed back inside the pool if it now overlaps a wall."""
        self.apply_change(self.check_change(name, 'radius', radius_m, pool), pool)

    def set_lift_area(self, name: str, area_m2) -> None:
        """New lift area (m^2); from now on it stays when the radius changes."""
        self.apply_change(self.check_change(name, 'lift_area', area_m2, None), None)

    def set_external_force(self, name: str, force_n) -> None:
        i = self.lookup(name)
        self.external_force[:, i] = check_external_force(f'{name} wrench force', force_n)

    def set_external_forces(self, forces_n) -> None:
        """Every sphere's external force at once: forces_n (n, 3) N in sphere order, each
        row checked (finite, within FORCE_LIMIT_N); InvalidInput naming the first bad row,
        and nothing written."""
        forces = np.asarray(forces_n, dtype=float)
        if forces.shape != (self.count, 3):
            raise InvalidInput(f'expected ({self.count}, 3) forces, got shape {forces.shape}')
        bad = ~(np.isfinite(forces) & (np.abs(forces) <= FORCE_LIMIT_N)).all(axis=1)
        if bad.any():
            row = int(np.flatnonzero(bad)[0])
            check_external_force(f'row {row} ({self.names[row]})', forces[row])  # raises
        self.external_force[:] = forces.T

    def release_external_forces(self, which) -> None:
        """No external force from now on on the spheres `which` selects (a (n,) bool mask
        or indices): their input timed out."""
        self.external_force[:, which] = 0.0


class CheckedChange(NamedTuple):
    """A live change Spheres.check_change accepted: write it with apply_change."""
    index: int  # the sphere's index in the Spheres that checked it
    key: str  # 'mass' (kg), 'radius' (m) or 'lift_area' (m^2)
    value: float


# What may change on a sphere while the simulation runs.
LIVE_KEYS = ('mass', 'radius', 'lift_area')


_ARRAY_FIELDS = ('position', 'velocity', 'mass', 'radius', 'drag_coefficient', 'lift_area',
                 'lift_normal', 'lift_coefficient', 'external_force', 'lift_slope',
                 'stall_angle')
_DERIVED_FIELDS = ('volume', 'cross_section')
