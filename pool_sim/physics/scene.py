"""A scene: the same keys as the node's ROS parameters (contract section 4), validated.

Built from a flat dict of dotted keys ('steel.mass'), a nested dict, or a ROS params YAML
file. Every refusal is an InvalidInput whose message starts with the key it is about.
"""
from dataclasses import dataclass
import math
from pathlib import Path

import numpy as np
import yaml

from .contact import ContactParameters
from .effects import DEFAULT_EFFECTS, EFFECTS
from .integrators import DEFAULT_INTEGRATOR, INTEGRATORS
from .media import Environment, Medium, Pool
from .spheres import (check_number, check_sphere_name, check_vector, InvalidInput,
                      MASS_RANGE_KG, named_few, RADIUS_RANGE_M, shortened, shown,
                      Spheres)

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
    other kinds a check (a predicate and the words for what is allowed)."""

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
LIFT_COEFFICIENT_RANGE = (-10.0, 10.0)  # wings reach ~3
LIFT_AREA_RANGE = (0.0, 1e6)  # m^2
PHYSICS_RATE_RANGE = (1.0, 1e5)  # Hz: steps from 1 s to 10 us
PUBLISH_RATE_RANGE = (0.01, 1e4)  # Hz of simulated time
REAL_TIME_FACTOR_RANGE = (0.0, 1e4)  # 0 = as fast as the machine goes
WRENCH_TIMEOUT_RANGE = (0.0, 1e6)  # s of simulated time; 0 = for ever


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
    'frame_id': Key('string', 'world', 'frame of every published pose',
                    allowed=(lambda v: v != '' and len(v) <= 256,
                             'a non-empty string of at most 256 characters')),
    'wrench_timeout': Key('number', 1.0, 'simulated seconds a wrench holds without a new '
                          'message, 0 = for ever', *WRENCH_TIMEOUT_RANGE, 's'),
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
                       (lambda v: float(np.linalg.norm(v)) >= 1e-6, 'a non-zero vector')),
    'lift_coefficient': Key('number', 0.0, 'lift coefficient C_l', *LIFT_COEFFICIENT_RANGE),
}
# First name parts a sphere may not take: its keys would clash with these parameters (or
# parameter groups) of the node or of rclpy in a params file.
RESERVED_NAMES = frozenset(
    {key.split('.')[0] for key in GLOBAL_KEYS}
    | {'use_sim_time', 'qos_overrides', 'start_type_description_service'})


def sphere_key_default(key: str, radius: float):
    """Default of a per-sphere key; lift_area's follows the sphere's radius."""
    if key == 'lift_area':
        return math.pi * radius * radius
    return SPHERE_KEYS[key].default


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
    flat = {}
    for name, value in params.items():
        if isinstance(value, dict):
            flat.update(flatten(value, f'{prefix}{name}.'))
        else:
            flat[f'{prefix}{name}'] = value
    return flat


def read_params_document(path) -> dict:
    """A ROS params file as a mapping (node name -> {ros__parameters: ...}), or
    InvalidInput naming the file and what is wrong with it."""
    try:
        with open(path, encoding='utf-8') as stream:
            document = yaml.safe_load(stream)
    except (OSError, UnicodeDecodeError, yaml.YAMLError) as error:
        first_line = (str(error).splitlines() or [type(error).__name__])[0]
        raise InvalidInput(f'{path}: cannot read it as YAML: {first_line}') from None
    document = {} if document is None else document
    if not isinstance(document, dict):
        raise InvalidInput(f'{path}: expected a mapping of node names to ros__parameters, '
                           f'got {shown(document)}')
    return document


class Scene:
    """A validated, fully defaulted set of parameters: `scene['steel.mass']`."""

    def __init__(self, params: dict):
        params = flatten(params)
        names = check_value('sphere_names', GLOBAL_KEYS['sphere_names'],
                            params.get('sphere_names', ()))
        for name in names:
            check_sphere_name(name)
            if name in RESERVED_NAMES:
                raise InvalidInput(f'sphere_names: {name!r} is taken by a parameter of the '
                                   f'node or of ROS; reserved: {sorted(RESERVED_NAMES)}')
        if len(set(names)) != len(names):
            repeated = sorted({name for name in names if names.count(name) > 1})
            raise InvalidInput(f'sphere_names: names must be unique; repeated: '
                               f'{named_few(repeated)}')
        allowed = dict(GLOBAL_KEYS)
        for name in names:
            allowed.update({f'{name}.{key}': spec for key, spec in SPHERE_KEYS.items()})
        for name in params:
            if name not in allowed:
                raise InvalidInput(f'{shortened(name)}: unknown key; spheres are '
                                   f'{named_few(names)}, global keys are {list(GLOBAL_KEYS)}')
        values = {}
        for name, spec in allowed.items():
            if name in params and not (spec.default is None and params[name] is None):
                values[name] = check_value(name, spec, params[name])
        for name, spec in GLOBAL_KEYS.items():
            values.setdefault(name, spec.default)
        for name in names:
            radius = values.setdefault(f'{name}.radius', SPHERE_KEYS['radius'].default)
            for key in SPHERE_KEYS:
                values.setdefault(f'{name}.{key}', sphere_key_default(key, radius))
        self.values = values
        self.sphere_names = names
        self._check_consistency()

    def __getitem__(self, name):
        return self.values[name]

    @classmethod
    def from_yaml(cls, path, node_name: str = NODE_NAME) -> 'Scene':
        """Read the `ros__parameters` for `node_name` from a ROS params file: the sections
        `/**`, `/**/<node_name>`, `<node_name>` and `/<node_name>`, later ones winning."""
        document = read_params_document(path)
        params = {}
        for section in ('/**', f'/**/{node_name}', node_name, f'/{node_name}'):
            entry = document.get(section)
            if entry is None:
                continue
            if not isinstance(entry, dict) or 'ros__parameters' not in entry:
                raise InvalidInput(f'{section}: expected a ros__parameters mapping')
            parameters = entry['ros__parameters']  # empty in the file: None
            if not isinstance(parameters, (dict, type(None))):
                raise InvalidInput(f'{section}: expected a ros__parameters mapping')
            params.update(flatten(parameters or {}))
        if not params:
            raise InvalidInput(f'{path}: no ros__parameters for node {node_name!r}')
        return cls(params)

    @classmethod
    def default(cls) -> 'Scene':
        """The seed's swimming pool, from config/pool.yaml."""
        return cls.from_yaml(default_scene_file())

    def with_values(self, **changes) -> 'Scene':
        """A copy with some keys changed (dotted keys may be given as a dict)."""
        return Scene({**self.values, **flatten(changes)})

    def _check_consistency(self):
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
        for name in self.sphere_names:
            radius = self[f'{name}.radius']
            if 2.0 * radius >= float(np.min(high - low)):
                raise InvalidInput(f'{name}.radius: {radius} m does not fit the pool')
            position = np.array(self[f'{name}.position'])
            if np.any(position < low + radius) or np.any(position > high - radius):
                raise InvalidInput(
                    f'{name}.position: the sphere (radius {radius:g} m) must start inside '
                    f'the pool: its centre within {(low + radius).tolist()} to '
                    f'{(high - radius).tolist()} m, got {position.tolist()}')

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
        names = self.sphere_names

        def scalars(key):
            return np.array([self[f'{n}.{key}'] for n in names], dtype=float)

        def vectors(key):
            return np.array([self[f'{n}.{key}'] for n in names], dtype=float).reshape(-1, 3).T

        radius = scalars('radius')
        normal = vectors('lift_normal')
        return Spheres(
            names=tuple(names), position=np.ascontiguousarray(vectors('position')),
            velocity=np.ascontiguousarray(vectors('velocity')), mass=scalars('mass'),
            radius=radius, drag_coefficient=scalars('drag_coefficient'),
            lift_area=scalars('lift_area'),
            lift_normal=np.ascontiguousarray(normal / np.linalg.norm(normal, axis=0)),
            lift_coefficient=scalars('lift_coefficient'),
            external_force=np.zeros((3, len(names))))
