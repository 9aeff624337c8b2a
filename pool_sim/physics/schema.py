"""The scene's schema: every key the physics takes, its kind, default, unit and range, and
the checks a value passes (one value, or a whole array over the spheres at once).

A per-sphere key comes in either of two forms: `<name>.<key>` for one sphere, or
`spheres.<key>`, one list over sphere_names, which is how a person writes a scene of 100 000
spheres. A vector key comes as three lists, `spheres.<key>.x`, `.y`, `.z` (ROS parameters
cannot nest lists; and rcl's params-file parser grows a list one number at a time, so three
lists of n parse nine times faster than one of 3n), or as one flat list x0, y0, z0, x1, ....

Keys the physics does not run (the node's publish rate, pacing, lockstep, ...) are not
here: whoever runs a scene adds its own with a SceneExtension, checked by the same rules.
"""
from collections import Counter
from dataclasses import dataclass, field
import itertools
import re
from typing import Callable, Optional

import numpy as np

from .contact import ContactParameters
from .contacts import DEFAULT_SOLVER, soft_step, SOLVERS
from .contacts.colouring import COLOURINGS
from .cuda import BACKENDS
from .effects import DEFAULT_EFFECTS, EFFECTS
from .integrators import DEFAULT_INTEGRATOR, INTEGRATORS
from .spheres import (check_number, check_sphere_name, check_vector, InvalidInput,
                      range_words,
                      LIFT_AREA_RANGE_M2, LIFT_SLOPE, MASS_RANGE_KG, NAME_MAX_CHARACTERS,
                      NAME_TOKEN, named_few, RADIUS_RANGE_M, shown, STALL_ANGLE)


@dataclass(frozen=True)
class Key:
    """One parameter: its kind ('number', 'integer', 'vector', 'string', 'strings', 'bool'), default,
    a description with its unit, the inclusive range [low, high] of a number or of each
    component of a vector (every one has both ends; None for the other kinds), and for the
    other kinds a check (a predicate and the words for what is allowed; a per-sphere key's
    predicate takes one value or an array of them, row by row)."""

    kind: str
    default: object
    description: str
    low: float = None
    high: float = None
    unit: str = ''
    allowed: tuple = (None, '')


# The ranges. They are wide enough for any pool a user builds on Earth or elsewhere, and
# narrow enough that no product or square in a step can overflow a double (speeds of
# 1e4 m/s square to 1e8; a 1e9 kg sphere at them has 1e17 J).
ACCELERATION_LIMIT = 1e3  # m/s^2 per component of gravity: the Sun's surface has 274
SPEED_LIMIT = 1e4  # m/s per component of a velocity, wind or current
LENGTH_LIMIT = 1e4  # m per coordinate of the pool, the surface and positions
DENSITY_RANGE = (0.0, 1e5)  # kg/m^3: vacuum to beyond osmium's 22 590
FRICTION_RANGE = (0.0, 10.0)
DRAG_COEFFICIENT_RANGE = (0.0, 10.0)  # a sphere 0.1-0.5, a flat plate ~1.2
LIFT_COEFFICIENT_RANGE = (-10.0, 10.0)  # wings with flaps reach ~3 (steeper or later stall)
LIFT_AREA_RANGE = LIFT_AREA_RANGE_M2  # m^2 (in spheres.py: set_lift_area checks it too)
LIFT_SLOPE_RANGE = (0.0, 100.0)  # 1/rad: thin aerofoils 2 pi
STALL_ANGLE_RANGE = (0.01, 1.5)  # rad: below pi/2, so the curve falls to 0 face-on
PHYSICS_RATE_RANGE = (1.0, 1e5)  # Hz: steps from 1 s to 10 us


def _vector(default, description, limit, unit):
    return Key('vector', default, description, -limit, limit, unit)


GLOBAL_KEYS = {
    'sphere_names': Key('strings', (), 'names of the spheres, in publishing order'),
    'gravity': _vector((0.0, 0.0, -9.81), 'gravitational acceleration, m/s^2',
                       ACCELERATION_LIMIT, 'm/s^2'),
    'air.density': Key('number', 1.2, 'air density, kg/m^3', *DENSITY_RANGE, 'kg/m^3'),
    'air.wind': _vector((0.0, 0.0, 0.0), 'air flow velocity, m/s', SPEED_LIMIT, 'm/s'),
    'water.density': Key('number', 1000.0, 'water density, kg/m^3 (at least the air\'s)',
                         *DENSITY_RANGE, 'kg/m^3'),
    'water.surface_z': Key('number', 0.0, 'height of the water surface, m', -LENGTH_LIMIT,
                           LENGTH_LIMIT, 'm'),
    'water.current': _vector((0.0, 0.0, 0.0), 'water flow velocity, m/s', SPEED_LIMIT, 'm/s'),
    'pool.min': _vector((-4.0, -4.0, -4.0), 'pool corner with the floor, m', LENGTH_LIMIT,
                        'm'),
    'pool.max': _vector((4.0, 4.0, 4.0), 'pool corner with the ceiling, m', LENGTH_LIMIT,
                        'm'),
    'contact.restitution': Key('number', ContactParameters.restitution,
                               'normal speed kept in a bounce, 0..1', 0.0, 1.0),
    'contact.static_friction': Key('number', ContactParameters.static_friction,
                                   'static friction coefficient', *FRICTION_RANGE),
    'contact.kinetic_friction': Key('number', ContactParameters.kinetic_friction,
                                    'kinetic friction coefficient (at most the static)',
                                    *FRICTION_RANGE),
    'contact.rolling_friction': Key('number', ContactParameters.rolling_friction,
                                    'rolling resistance coefficient', *FRICTION_RANGE),
    'effects': Key('strings', DEFAULT_EFFECTS, 'the physics that runs; anything else costs '
                   'nothing', allowed=(lambda v: set(v) <= set(EFFECTS),
                                       f'a subset of {list(EFFECTS)}')),
    'integrator': Key('string', DEFAULT_INTEGRATOR, 'fixed-step integrator',
                      allowed=(lambda v: v in INTEGRATORS, f'one of {list(INTEGRATORS)}')),
    'contact_solver': Key('string', DEFAULT_SOLVER, 'how sphere-sphere contacts (the '
                          'collisions effect) are resolved',
                          allowed=(lambda v: v in SOLVERS, f'one of {sorted(SOLVERS)}')),
    'soft_step.substeps': Key('integer', soft_step.SUBSTEPS, 'substeps of the soft_step '
                              'contact solver per step', 1, 64),
    'soft_step.stiffness_hz': Key('number', soft_step.STIFFNESS_HZ, 'soft_step: a '
                                  "contact's stiffness as its frequency, Hz (held below a "
                                  'quarter of the substep rate)', 0.01, 1e6, 'Hz'),
    'soft_step.damping_ratio': Key('number', soft_step.DAMPING_RATIO, "soft_step: a "
                                   "contact's damping ratio (1: critical)", 0.0, 1e3),
    'soft_step.push_out_speed': Key('number', soft_step.PUSH_OUT_SPEED, 'soft_step: the '
                                    'fastest an overlap is pushed apart, m/s', 0.0, 1e3,
                                    'm/s'),
    'soft_step.colouring': Key('string', 'auto', "soft_step: the order its contacts are "
                               'coloured in, which is the order they are swept in: found (as '
                               'detection finds them), priority (by a hash of their index, '
                               "as a GPU colours them: on the CPU, the GPU's sweep), or "
                               'auto (found on the CPU, priority on a GPU); docs/gpu.md',
                               allowed=(lambda v: v in COLOURINGS,
                                        f'one of {list(COLOURINGS)}')),
    'backend': Key('string', 'cpu', 'where the step runs: cpu, or cuda (one NVIDIA GPU, '
                   "numba-cuda: pip install 'pool_sim[cuda]'; docs/gpu.md)",
                   allowed=(lambda v: v in BACKENDS, f'one of {list(BACKENDS)}')),
    'physics_rate_hz': Key('number', 200.0, 'physics steps per simulated second',
                           *PHYSICS_RATE_RANGE, 'Hz'),
}

# The soft_step solver's settings, in the order it takes them (contacts/soft_step.py),
# then whether it colours by priority (stepper.scene_constants).
SOLVER_SETTINGS = ('soft_step.substeps', 'soft_step.stiffness_hz', 'soft_step.damping_ratio',
                   'soft_step.push_out_speed')

SPHERE_KEYS = {
    'mass': Key('number', 1.0, 'mass, kg', *MASS_RANGE_KG, 'kg'),
    'radius': Key('number', 0.1, 'radius, m (the sphere must fit the pool)', *RADIUS_RANGE_M,
                  'm'),
    'position': _vector((0.0, 0.0, 0.0), 'initial position of the centre, m (the whole '
                        'sphere inside the pool)', LENGTH_LIMIT, 'm'),
    'velocity': _vector((0.0, 0.0, 0.0), 'initial velocity, m/s', SPEED_LIMIT, 'm/s'),
    'drag_coefficient': Key('number', 0.47, 'drag coefficient C_d', *DRAG_COEFFICIENT_RANGE),
    'lift_area': Key('number', None, 'lifting surface area, m^2 (default: the cross-section '
                     'pi*r^2)', *LIFT_AREA_RANGE, 'm^2'),
    'lift_normal': Key('vector', (0.0, 0.0, 1.0), 'normal of the lifting surface (any '
                       'length from 1e-6 up; normalised)', -1e3, 1e3, '',
                       (lambda v: np.linalg.norm(np.asarray(v, dtype=float), axis=-1) >= 1e-6,
                        'a non-zero vector')),
    'lift_coefficient': Key('number', 0.0, 'the most lift coefficient C_l the surface gives '
                            '(0: no lift; negative: lifts the other way); reached only where '
                            'lift_slope * stall_angle is at least as much',
                            *LIFT_COEFFICIENT_RANGE),
    'lift_slope': Key('number', LIFT_SLOPE, 'lift-curve slope dC_l/dalpha up to the stall, '
                      '1/rad', *LIFT_SLOPE_RANGE, '1/rad'),
    'stall_angle': Key('number', STALL_ANGLE, 'angle of attack of the stall, rad (past it '
                       'C_l falls to 0 face-on)', *STALL_ANGLE_RANGE, 'rad'),
}


@dataclass(frozen=True)
class SceneExtension:
    """Keys a scene carries for whoever runs it, which the physics does not read: checked
    and defaulted as the physics' own keys are (Scene(params, extension=...)).

    keys: {name: Key} of its global keys. reserved: more first name parts no sphere may take
    (beside the first part of every global key and 'spheres'). follow_spheres: its keys that
    name spheres, so with_spheres may change them with the spheres. check(scene): raises
    InvalidInput when its keys disagree with the rest of the scene."""

    keys: dict = field(default_factory=dict)
    reserved: frozenset = frozenset()
    follow_spheres: tuple = ()
    check: Optional[Callable] = None


NO_EXTENSION = SceneExtension()
_GLOBAL_FIRST_PARTS = frozenset(key.split('.')[0] for key in GLOBAL_KEYS)


def reserved_names(extension: SceneExtension = NO_EXTENSION) -> frozenset:
    """First name parts a sphere may not take: its keys would clash with these parameters
    (or parameter groups). 'spheres' holds the array form of the per-sphere keys."""
    return frozenset({key.split('.')[0] for key in (*GLOBAL_KEYS, *extension.keys)}
                     | {'spheres'} | extension.reserved)


ARRAY_PREFIX = 'spheres.'
COMPONENTS = ('x', 'y', 'z')
# Types numpy converts exactly as float() does, so a list of only these is checked as one
# array. Anything else (bool, str, None, a rarer number type) goes through check_value item
# by item, which refuses or takes it as a single key would.
_PLAIN_NUMBER_TYPES = frozenset({float, int, np.float64, np.int64})
# Every name a ROS name token, each followed by a newline: 100 000 names checked in one match.
_TOKEN_LINES = re.compile(rf'(?:{NAME_TOKEN.pattern}\n)*')


def join_components(params: dict) -> dict:
    """`spheres.<vector key>.x/.y/.z` joined into one flat `spheres.<key>` list (x0, y0, z0,
    x1, ...), or InvalidInput naming the component missing, of another length or not a
    list of numbers. Other keys pass as they are."""
    vector_keys = [key for key, spec in SPHERE_KEYS.items() if spec.kind == 'vector']
    for key in vector_keys:
        parts = [f'{ARRAY_PREFIX}{key}.{c}' for c in COMPONENTS]
        given = [part for part in parts if part in params]
        if not given:
            continue
        if len(given) < 3:
            missing = [part for part in parts if part not in params]
            raise InvalidInput(f'{missing[0]}: give all three of {", ".join(parts)}')
        if f'{ARRAY_PREFIX}{key}' in params:
            raise InvalidInput(f'{ARRAY_PREFIX}{key}: given both as one list and as '
                               f'{parts[0]}, .y, .z; give each key one way')
        columns = []
        for part in parts:
            value = [] if params[part] is None else params[part]
            if not isinstance(value, (list, tuple, np.ndarray)):
                raise InvalidInput(f'{part}: expected a list of numbers over sphere_names, '
                                   f'got {shown(value)}')
            columns.append(list(value))
        if len({len(column) for column in columns}) != 1:
            raise InvalidInput(f'{parts[1]}: {len(columns[1])} numbers against '
                               f'{len(columns[0])} in {parts[0]}; one per name in sphere_names')
        params = {name: value for name, value in params.items() if name not in parts}
        params[f'{ARRAY_PREFIX}{key}'] = [v for row in zip(*columns) for v in row]
    return params


def check_integer(name: str, value, low, high, unit='') -> int:
    """A Python int within [low, high], or InvalidInput naming `name` (a port is no
    decimal: 8765.0 is refused as rclpy's integer parameters refuse a double)."""
    if not isinstance(value, (int, np.integer)) or isinstance(value, (bool, np.bool_)):
        raise InvalidInput(f'{name}: expected an integer, got {type(value).__name__} '
                           f'{shown(value)}')
    if not low <= value <= high:
        raise InvalidInput(f'{name}: must be {range_words(low, high, unit)}, got {shown(value)}')
    return int(value)


def check_value(name: str, key: Key, value):
    """The value in its canonical Python type, or InvalidInput naming `name`."""
    if key.kind == 'number':
        value = check_number(name, value, key.low, key.high, key.unit)
    elif key.kind == 'integer':
        value = check_integer(name, value, key.low, key.high, key.unit)
    elif key.kind == 'vector':
        value = tuple(check_vector(name, value, key.low, key.high, key.unit).tolist())
    elif key.kind == 'string':
        if not isinstance(value, str):
            raise InvalidInput(f'{name}: expected a string, got {shown(value)}')
    elif key.kind == 'strings':
        # rclpy hands an empty YAML list over as a parameter that is not set (None).
        value = () if value is None else value
        if not isinstance(value, (list, tuple)) or not all(isinstance(v, str) for v in value):
            raise InvalidInput(f'{name}: expected a list of strings, got {shown(value)}')
        value = tuple(value)
    elif key.kind == 'bool':
        if not isinstance(value, bool):
            raise InvalidInput(f'{name}: expected true or false, got {shown(value)}')
    predicate, words = key.allowed
    if predicate is not None and not predicate(value):
        raise InvalidInput(f'{name}: must be {words}, got {shown(value)}')
    return value


def flatten(params: dict, prefix: str = '') -> dict:
    """{'steel': {'mass': 1}} -> {'steel.mass': 1}, as ROS names nested YAML parameters."""
    if not prefix and all(type(name) is str and not isinstance(value, dict)
                          for name, value in params.items()):
        return dict(params)  # already flat (800 000 keys of a large scene: a copy, no more)
    flat = {}
    for name, value in params.items():
        if isinstance(value, dict):
            flat.update(flatten(value, f'{prefix}{name}.'))
        else:
            flat[f'{prefix}{name}'] = value
    return flat


def check_sphere_names(value, reserved=None) -> tuple:
    """sphere_names as a tuple of unique, valid, unreserved names, or InvalidInput.
    reserved: the first name parts no sphere may take (default: reserved_names())."""
    reserved = reserved_names() if reserved is None else reserved
    names = check_value('sphere_names', GLOBAL_KEYS['sphere_names'], value)
    if _all_free_tokens(names, reserved) and len(set(names)) == len(names):
        return names
    for name in names:  # one is refused: find it, in its words
        check_sphere_name(name)
        if name in reserved:
            raise InvalidInput(f'sphere_names: {name!r} is taken by a parameter of the '
                               'node or of ROS; reserved: the first part of every global '
                               f'key and {", ".join(sorted(reserved - _GLOBAL_FIRST_PARTS))}')
    if len(set(names)) != len(names):
        repeated = sorted(name for name, count in Counter(names).items() if count > 1)
        raise InvalidInput(f'sphere_names: names must be unique; repeated: '
                           f'{named_few(repeated)}')
    return names


def check_some_sphere_names(value, reserved=None) -> tuple:
    """As check_sphere_names, and at least one: what a node runs and spawns (a Scene of no
    spheres is fine for the core)."""
    names = check_sphere_names(value, reserved)
    if not names:
        raise InvalidInput('sphere_names: the node needs at least one sphere, got []')
    return names


def _all_free_tokens(names: tuple, reserved: frozenset) -> bool:
    """True when every name is a valid ROS name token and none is reserved, checked at once
    (a newline inside a name shows as one newline too many)."""
    lines = '\n'.join(names) + '\n' if names else ''  # names: strings (check_value)
    return (lines.count('\n') == len(names)
            and max(map(len, names), default=0) <= NAME_MAX_CHARACTERS
            and '__' not in lines and _TOKEN_LINES.fullmatch(lines) is not None
            and reserved.isdisjoint(names))


def _plain_floats(items):
    """items (a list, tuple or 1-d array) as a float array, or None when some item is not of
    a plain number type (then they are checked one by one)."""
    if isinstance(items, np.ndarray):
        return items.astype(float) if items.dtype.kind in 'iuf' else None
    if not set(map(type, items)) <= _PLAIN_NUMBER_TYPES:
        return None
    try:
        return np.array(items, dtype=float)
    except OverflowError:  # an int beyond a double: check_number words it
        return None


def _rows_allowed(spec: Key, rows: np.ndarray) -> np.ndarray:
    """(m,) bool: which of the values (m,) or vectors (m, 3) check_value would take."""
    allowed = np.isfinite(rows) & (rows >= spec.low) & (rows <= spec.high)
    if rows.ndim == 2:
        allowed = allowed.all(axis=1)
    predicate = spec.allowed[0]
    if predicate is not None:
        allowed[allowed] = predicate(rows[allowed])
    return allowed


def _default_column(spec: Key, count: int) -> np.ndarray:
    """A per-sphere key's default for `count` spheres; NaN for lift_area (set from the
    radius once the radius is known)."""
    if spec.kind == 'vector':
        return np.tile(np.asarray(spec.default, dtype=float), (count, 1))
    return np.full(count, np.nan if spec.default is None else spec.default, dtype=float)


def _checked_sphere_array(key: str, value, names: tuple) -> np.ndarray:
    """spheres.<key> as floats, (n,) for a number key and (n, 3) for a vector key, or
    InvalidInput naming the key and, for a value, the first sphere refused and its index."""
    spec, label, count = SPHERE_KEYS[key], f'{ARRAY_PREFIX}{key}', len(names)
    width = 3 if spec.kind == 'vector' else 1
    items = [] if value is None else value  # rclpy hands an empty list over as None
    if not (isinstance(items, (list, tuple))
            or (isinstance(items, np.ndarray) and items.ndim == 1)):
        raise InvalidInput(f'{label}: expected one flat list of numbers over sphere_names, '
                           f'got {shown(value)}')
    if len(items) != width * count:
        per = ('one per name in sphere_names' if width == 1
               else '3 per name in sphere_names, flattened [x0, y0, z0, x1, ...]')
        raise InvalidInput(f'{label}: expected {width * count} numbers ({per}), got '
                           f'{len(items)}')

    def checked(i):
        item = items[i] if width == 1 else items[width * i:width * (i + 1)]
        return check_value(f'{label}: {names[i]} (index {i})', spec, item)

    floats = _plain_floats(items)
    if floats is not None:
        rows = floats.reshape(count, width) if width > 1 else floats
        allowed = _rows_allowed(spec, rows)
        if allowed.all():
            return rows
        checked(int(np.argmin(allowed)))  # the first refused one: raises, in its words
    # Items numpy does not take whole: one by one (the first refused one raises).
    rows = np.array([checked(i) for i in range(count)], dtype=float)
    return rows.reshape(count, width) if width > 1 else rows


def _plain_sphere_values(spec: Key, values: list):
    """`<name>.<key>` values of one key as floats ((m,) or (m, 3)) when all are plain and
    allowed, else None (then check_value, sphere by sphere, finds the one refused)."""
    if spec.kind == 'vector':
        if not all(type(v) in (list, tuple) and len(v) == 3 for v in values):
            return None
        floats = _plain_floats(list(itertools.chain.from_iterable(values)))
        rows = None if floats is None else floats.reshape(-1, 3)
    else:
        rows = _plain_floats(values)
    if rows is None or not _rows_allowed(spec, rows).all():
        return None
    return rows


