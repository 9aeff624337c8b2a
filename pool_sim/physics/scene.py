"""A scene: the same keys as the node's ROS parameters (contract section 4), validated.

Built from a flat dict of dotted keys ('steel.mass'), a nested dict, or a ROS params YAML
file. Every refusal is an InvalidInput whose message starts with the key it is about.

A per-sphere key comes in either of two forms: `<name>.<key>` for one sphere, or
`spheres.<key>`, one list over sphere_names, which is how a person writes a scene of 100 000
spheres. A vector key comes as three lists, `spheres.<key>.x`, `.y`, `.z` (ROS parameters
cannot nest lists; and rcl's params-file parser grows a list one number at a time, so three
lists of n parse nine times faster than one of 3n), or as one flat list x0, y0, z0, x1, ....
The scene keeps them as arrays over sphere_names either way.
"""
from collections import Counter
from dataclasses import dataclass
from functools import cached_property
import itertools
from pathlib import Path
import re

import numpy as np

from .contact import ContactParameters
from .effects import DEFAULT_EFFECTS, EFFECTS
from .integrators import DEFAULT_INTEGRATOR, INTEGRATORS
from .media import Environment, Medium, Pool
from .params_file import applying_parameters, read_params_document, sets_nothing_reason
from .spheres import (check_number, check_sphere_name, check_vector, InvalidInput,
                      LIFT_AREA_RANGE_M2, LIFT_SLOPE, MASS_RANGE_KG, NAME_MAX_CHARACTERS,
                      NAME_TOKEN, named_few, RADIUS_RANGE_M, shortened, shown, Spheres,
                      STALL_ANGLE)

NODE_NAME = 'pool_sim'


def default_scene_file() -> Path:
    """config/pool.yaml of a source checkout, or share/pool_sim/config/pool.yaml of the
    install prefix this module lives in (colcon, pip): found without asking ROS."""
    here = Path(__file__).resolve()
    candidates = [here.parents[2] / 'config' / 'pool.yaml']
    candidates += [p / 'share' / 'pool_sim' / 'config' / 'pool.yaml' for p in here.parents]
    for candidate in candidates:
        if candidate.is_file():
            return candidate
    raise FileNotFoundError('pool_sim: the default scene config/pool.yaml is not installed')


@dataclass(frozen=True)
class Key:
    """One parameter: its kind ('number', 'vector', 'string', 'strings', 'bool'), default,
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
PUBLISH_RATE_RANGE = (0.01, 1e4)  # Hz of simulated time
REAL_TIME_FACTOR_RANGE = (0.0, 1e4)  # 0 = as fast as the machine goes
WRENCH_TIMEOUT_RANGE = (0.0, 1e6)  # s of simulated time; 0 = for ever
LOCKSTEP_TIMEOUT_RANGE = (1e-3, 1e4)  # wall s; a dead controller costs at most this once
# The name of the ~/forces input (every sphere at once) in lockstep_inputs; no sphere takes it.
FORCES_INPUT = 'forces'


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
    'physics_rate_hz': Key('number', 200.0, 'physics steps per simulated second',
                           *PHYSICS_RATE_RANGE, 'Hz'),
    'publish_rate_hz': Key('number', 30.0, 'messages per simulated second',
                           *PUBLISH_RATE_RANGE, 'Hz'),
    'real_time_factor': Key('number', 1.0, 'simulated seconds per wall second, 0 = as fast '
                            'as possible', *REAL_TIME_FACTOR_RANGE),
    'publish_clock': Key('bool', False, 'publish /clock with simulation time'),
    'per_sphere_topics': Key('bool', True, "each sphere's own odom and wrench topics and "
                             '<sphere>.<key> parameters; false: only the array topics and '
                             'spheres.<key> array parameters, for scenes of many spheres'),
    'frame_id': Key('string', 'world', 'frame of every published pose',
                    allowed=(lambda v: v != '' and len(v) <= 256,
                             'a non-empty string of at most 256 characters')),
    'wrench_timeout': Key('number', 1.0, 'simulated seconds a wrench holds without a new '
                          'message, 0 = for ever', *WRENCH_TIMEOUT_RANGE, 's'),
    'lockstep': Key('bool', False, 'after each publish, step on only once every input of '
                    'lockstep_inputs has answered that instant (or lockstep_timeout passed)'),
    'lockstep_inputs': Key('strings', (), 'the inputs lockstep waits for: sphere names (a '
                           f'force on ~/wrench or ~/<sphere>/wrench) and {FORCES_INPUT!r} '
                           '(~/forces)',
                           allowed=(lambda v: len(set(v)) == len(v), 'names without repeats')),
    'lockstep_timeout': Key('number', 5.0, 'wall seconds lockstep waits for an input before '
                            'it goes on without it (until it answers again)',
                            *LOCKSTEP_TIMEOUT_RANGE, 's'),
}

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
# Keys of the node's that may change while it runs; the physics never reads them.
LOCKSTEP_KEYS = ('lockstep', 'lockstep_inputs', 'lockstep_timeout')
# First name parts a sphere may not take: its keys would clash with these parameters (or
# parameter groups) of the node or of rclpy in a params file.
# 'spheres' holds the array form of the per-sphere keys; 'forces' names ~/forces in
# lockstep_inputs.
RESERVED_NAMES = frozenset(
    {key.split('.')[0] for key in GLOBAL_KEYS}
    | {'spheres', 'use_sim_time', 'qos_overrides', 'start_type_description_service',
       FORCES_INPUT})
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


def check_value(name: str, key: Key, value):
    """The value in its canonical Python type, or InvalidInput naming `name`."""
    if key.kind == 'number':
        value = check_number(name, value, key.low, key.high, key.unit)
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


def check_sphere_names(value) -> tuple:
    """sphere_names as a tuple of unique, valid, unreserved names, or InvalidInput."""
    names = check_value('sphere_names', GLOBAL_KEYS['sphere_names'], value)
    if _all_free_tokens(names) and len(set(names)) == len(names):
        return names
    for name in names:  # one is refused: find it, in its words
        check_sphere_name(name)
        if name in RESERVED_NAMES:
            raise InvalidInput(f'sphere_names: {name!r} is taken by a parameter of the '
                               'node or of ROS; reserved: the first part of every global '
                               'key (gravity, water, pool, lockstep, ...), spheres, forces, '
                               'use_sim_time, qos_overrides, start_type_description_service')
    if len(set(names)) != len(names):
        repeated = sorted(name for name, count in Counter(names).items() if count > 1)
        raise InvalidInput(f'sphere_names: names must be unique; repeated: '
                           f'{named_few(repeated)}')
    return names


def check_some_sphere_names(value) -> tuple:
    """As check_sphere_names, and at least one: what a node runs and spawns (a Scene of no
    spheres is fine for the core)."""
    names = check_sphere_names(value)
    if not names:
        raise InvalidInput('sphere_names: the node needs at least one sphere, got []')
    return names


def _all_free_tokens(names: tuple) -> bool:
    """True when every name is a valid ROS name token and none is reserved, checked at once
    (a newline inside a name shows as one newline too many)."""
    lines = '\n'.join(names) + '\n' if names else ''  # names: strings (check_value)
    return (lines.count('\n') == len(names)
            and max(map(len, names), default=0) <= NAME_MAX_CHARACTERS
            and '__' not in lines and _TOKEN_LINES.fullmatch(lines) is not None
            and RESERVED_NAMES.isdisjoint(names))


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


class Scene:
    """A validated, fully defaulted set of parameters: `scene['steel.mass']`.

    Per-sphere values are kept as arrays over sphere_names (sphere_array); `values` gives
    every key in the `<name>.<key>` form, for small scenes. lift_area_given: (n,) bool,
    True where the params gave the lift area; elsewhere it is pi r^2 and follows the radius.
    """

    def __init__(self, params: dict, *, _sphere_start=None):
        """params: flat or nested keys, per-sphere keys in either form (each key one way).
        _sphere_start: for with_spheres: validated per-sphere arrays (and lift_area_given)
        the spheres start from instead of the schema defaults."""
        params = join_components(flatten(params))
        names = check_sphere_names(params.get('sphere_names', ()))
        self.sphere_names = names
        # Sort the keys: as arrays {key: value}, one by one {key: {sphere index: value}}.
        as_arrays, one_by_one = {}, {key: {} for key in SPHERE_KEYS}
        for name, value in params.items():
            if name in GLOBAL_KEYS:
                continue
            if name.startswith(ARRAY_PREFIX):
                key = name[len(ARRAY_PREFIX):]
                if key not in SPHERE_KEYS:
                    raise InvalidInput(f'{shortened(name)}: unknown key; per-sphere keys are '
                                       f'{list(SPHERE_KEYS)}')
                as_arrays[key] = value
                continue
            sphere, _, key = name.partition('.')
            index = self._index.get(sphere)
            if index is None or key not in SPHERE_KEYS:
                raise InvalidInput(f'{shortened(name)}: unknown key; spheres are '
                                   f'{named_few(names)}, global keys are {list(GLOBAL_KEYS)}')
            if not (key == 'lift_area' and value is None):  # None: not given
                one_by_one[key][index] = value
        for key in as_arrays:
            if one_by_one[key]:
                sphere = names[next(iter(one_by_one[key]))]
                raise InvalidInput(f'{ARRAY_PREFIX}{key}: given both as {ARRAY_PREFIX}{key} '
                                   f'and as {sphere}.{key}; give each key one way')
        self._globals = {'sphere_names': names}
        for name, spec in GLOBAL_KEYS.items():
            if name != 'sphere_names':
                self._globals[name] = (check_value(name, spec, params[name]) if name in params
                                       else spec.default)
        self._arrays, self.lift_area_given = self._sphere_arrays(as_arrays, one_by_one,
                                                                 _sphere_start or {})
        for column in (*self._arrays.values(), self.lift_area_given):
            column.flags.writeable = False  # a Scene does not change; sphere_array copies
        self._check_consistency(set(as_arrays))

    @cached_property
    def _index(self) -> dict:
        return {name: i for i, name in enumerate(self.sphere_names)}

    def _sphere_arrays(self, as_arrays, one_by_one, start):
        """({key: (n,) or (n, 3) floats}, lift_area_given (n,)), every value checked."""
        names, count = self.sphere_names, len(self.sphere_names)
        arrays = {}
        for key, spec in SPHERE_KEYS.items():
            if key in as_arrays:
                arrays[key] = _checked_sphere_array(key, as_arrays[key], names)
            else:
                arrays[key] = (start[key].copy() if key in start
                               else _default_column(spec, count))
        plain = {key: _plain_sphere_values(SPHERE_KEYS[key], list(given.values()))
                 for key, given in one_by_one.items() if given}
        if all(rows is not None for rows in plain.values()):
            for key, rows in plain.items():
                arrays[key][list(one_by_one[key])] = rows
        else:  # one is refused: find the first as a scene of single keys always has
            for i, name in enumerate(names):
                for key, spec in SPHERE_KEYS.items():
                    if i in one_by_one[key]:
                        arrays[key][i] = check_value(f'{name}.{key}', spec, one_by_one[key][i])
        area_given = (start['lift_area_given'].copy() if 'lift_area_given' in start
                      else np.zeros(count, dtype=bool))
        if 'lift_area' in as_arrays:
            area_given[:] = True
        area_given[list(one_by_one['lift_area'])] = True
        follows, radius = ~area_given, arrays['radius']
        # As Spheres.set_radius computes it, so that a live radius change agrees bit for bit.
        arrays['lift_area'][follows] = np.pi * radius[follows] * radius[follows]
        return arrays, area_given

    def __getitem__(self, name):
        """A global key's value, or one sphere's: a float, or a tuple of 3 for a vector."""
        if name in self._globals:
            return self._globals[name]
        sphere, _, key = name.partition('.') if isinstance(name, str) else (None, '', None)
        index, column = self._index.get(sphere), self._arrays.get(key)
        if index is None or column is None:
            raise KeyError(name)
        value = column[index]
        return tuple(value.tolist()) if column.ndim == 2 else float(value)

    @property
    def values(self) -> dict:
        """Every key, per-sphere ones as `<name>.<key>` (built on each call: for small
        scenes; a large one is better read with sphere_array)."""
        values = dict(self._globals)
        columns = {key: column.tolist() for key, column in self._arrays.items()}
        for i, name in enumerate(self.sphere_names):
            for key, column in columns.items():
                value = column[i]
                values[f'{name}.{key}'] = tuple(value) if isinstance(value, list) else value
        return values

    def global_values(self) -> dict:
        """The keys that are not per sphere (sphere_names among them)."""
        return dict(self._globals)

    def sphere_array(self, key: str) -> np.ndarray:
        """A copy of one per-sphere key over sphere_names: (n,), or (n, 3) for a vector."""
        if key not in self._arrays:
            raise InvalidInput(f'{shortened(str(key))}: unknown per-sphere key; one of '
                               f'{list(SPHERE_KEYS)}')
        return self._arrays[key].copy()

    @classmethod
    def from_yaml(cls, path, node_name: str = NODE_NAME, namespace: str = '/') -> 'Scene':
        """Read the `ros__parameters` that a ROS params file gives the node `node_name` in
        `namespace`, as rclpy matches sections (`/**`, `/**/<node_name>`, `<node_name>`,
        ...; see params_file), later sections winning. InvalidInput when the file sets
        nothing for that node."""
        document = read_params_document(path)
        node_fqn = f'{namespace.rstrip("/")}/{node_name}'
        params = {}
        for _, parameters in applying_parameters(document, node_fqn):
            params.update(flatten(parameters))
        if not params:
            raise InvalidInput(sets_nothing_reason(path, node_fqn)
                               or f'{path}: no ros__parameters for node {node_fqn}')
        return cls(params)

    @classmethod
    def default(cls) -> 'Scene':
        """The seed's swimming pool, from config/pool.yaml."""
        return cls.from_yaml(default_scene_file())

    def with_values(self, **changes) -> 'Scene':
        """A copy with some keys changed (dotted keys may be given as a dict). A changed
        sphere_names keeps the spheres this scene has, with their values; new spheres take
        the schema defaults."""
        changes = flatten(changes)
        names = (check_sphere_names(changes['sphere_names']) if 'sphere_names' in changes
                 else self.sphere_names)
        return self._derived(names, changes)

    def with_spheres(self, names, given=None) -> 'Scene':
        """A new scene of the spheres `names`, in that order, for spawn and remove.

        A sphere this scene has keeps its values but for the keys `given` gives; a new one
        takes the given values or the schema defaults. given: per-sphere keys in either form
        ('cork.mass', or 'spheres.mass' over `names`), flat or nested; sphere_names only if
        it is `names`. The global keys stay this scene's (with_values changes those) but for
        the lockstep keys, which name spheres, so they change with them.
        """
        given = flatten(given or {})
        names = check_some_sphere_names(names)
        for key, value in given.items():
            if key == 'sphere_names':
                if check_sphere_names(value) != names:
                    raise InvalidInput(f'sphere_names: {shown(value)} is not the names '
                                       f'given to with_spheres ({named_few(names)})')
            elif key in GLOBAL_KEYS and key not in LOCKSTEP_KEYS:
                raise InvalidInput(f'{key}: a global key; with_spheres changes the spheres '
                                   'and the lockstep keys, which name them, only '
                                   '(with_values changes the rest)')
        return self._derived(names, given)

    def _derived(self, names: tuple, changes: dict) -> 'Scene':
        """A scene of `names` whose spheres this scene has start from its values, the rest
        from the defaults; `changes` (flat keys, validated as in Scene()) laid over."""
        previous = np.fromiter((self._index.get(name, -1) for name in names), dtype=np.intp,
                               count=len(names))
        kept = previous >= 0
        start = {}
        for key, spec in SPHERE_KEYS.items():
            start[key] = _default_column(spec, len(names))
            start[key][kept] = self._arrays[key][previous[kept]]
        start['lift_area_given'] = np.zeros(len(names), dtype=bool)
        start['lift_area_given'][kept] = self.lift_area_given[previous[kept]]
        return Scene({**self._globals, 'sphere_names': names, **changes}, _sphere_start=start)

    def _check_consistency(self, keys_as_arrays=()):
        low, high = np.array(self['pool.min']), np.array(self['pool.max'])
        if not np.all(high > low):
            raise InvalidInput(f'pool.max: must exceed pool.min on every axis, got '
                               f'{list(high)} vs {list(low)}')
        if self['air.density'] > self['water.density']:
            raise InvalidInput(f'water.density: must be at least air.density '
                               f'({self["air.density"]:g} kg/m^3): the lighter fluid is above')
        if self['contact.kinetic_friction'] > self['contact.static_friction']:
            raise InvalidInput('contact.kinetic_friction: must not exceed '
                               'contact.static_friction')
        if 'friction' in self['effects'] and 'contact' not in self['effects']:
            raise InvalidInput('effects: friction acts through floor contact; list contact too')
        unknown = [name for name in self['lockstep_inputs']
                   if name != FORCES_INPUT and name not in self._index]
        if unknown:
            raise InvalidInput(f'lockstep_inputs: {named_few(unknown)} not in sphere_names '
                               f'({named_few(self.sphere_names)}) nor {FORCES_INPUT!r}: each '
                               'entry is a sphere whose force answers, or the ~/forces array')
        radius, position = self._arrays['radius'], self._arrays['position']
        too_big = 2.0 * radius >= float(np.min(high - low))
        outside = (np.any(position < low + radius[:, None], axis=1)
                   | np.any(position > high - radius[:, None], axis=1))
        refused = too_big | outside
        if not refused.any():
            return
        i = int(np.argmax(refused))  # the first sphere refused, as one by one
        name, radius = self.sphere_names[i], float(radius[i])

        def label(key):
            return (f'{ARRAY_PREFIX}{key}: {name} (index {i})' if key in keys_as_arrays
                    else f'{name}.{key}')
        if too_big[i]:
            raise InvalidInput(f'{label("radius")}: {radius} m does not fit the pool')
        raise InvalidInput(
            f'{label("position")}: the sphere (radius {radius:g} m) must start inside '
            f'the pool: its centre within {(low + radius).tolist()} to '
            f'{(high - radius).tolist()} m, got {position[i].tolist()}')

    def environment(self) -> Environment:
        return Environment(
            gravity=np.array(self['gravity']),
            air=Medium(self['air.density'], np.array(self['air.wind'])),
            water=Medium(self['water.density'], np.array(self['water.current'])),
            surface_z=self['water.surface_z'],
            pool=Pool(np.array(self['pool.min']), np.array(self['pool.max'])))

    def contact_parameters(self) -> ContactParameters:
        return ContactParameters(self['contact.restitution'], self['contact.static_friction'],
                                 self['contact.kinetic_friction'],
                                 self['contact.rolling_friction'])

    def build_spheres(self) -> Spheres:
        """The initial state as arrays (every sphere starts inside the pool: checked)."""
        arrays = self._arrays
        normal = arrays['lift_normal'].T
        return Spheres(
            names=self.sphere_names, position=arrays['position'].T.copy(),
            velocity=arrays['velocity'].T.copy(), mass=arrays['mass'].copy(),
            radius=arrays['radius'].copy(),
            drag_coefficient=arrays['drag_coefficient'].copy(),
            lift_area=arrays['lift_area'].copy(),
            lift_normal=np.ascontiguousarray(normal / np.linalg.norm(normal, axis=0)),
            lift_coefficient=arrays['lift_coefficient'].copy(),
            external_force=np.zeros((3, len(self.sphere_names))),
            lift_area_follows_radius=~self.lift_area_given,
            lift_slope=arrays['lift_slope'].copy(), stall_angle=arrays['stall_angle'].copy())
