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
from .spheres import InvalidInput, Spheres, check_positive, check_vector

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
    the check its value must pass (a predicate and the words for what is allowed), and a
    description with its unit."""

    kind: str
    default: object
    description: str
    allowed: tuple = (None, '')


def _at_least(bound):
    return (lambda v: v >= bound, f'>= {bound}')


def _greater(bound):
    return (lambda v: v > bound, f'> {bound}')


_POSITIVE = _greater(0.0)
_NON_NEGATIVE = _at_least(0.0)

GLOBAL_KEYS = {
    'sphere_names': Key('strings', (), 'names of the spheres, in publishing order'),
    'gravity': Key('vector', (0.0, 0.0, -9.81), 'gravitational acceleration, m/s^2'),
    'air.density': Key('number', 1.2, 'air density, kg/m^3', _POSITIVE),
    'air.wind': Key('vector', (0.0, 0.0, 0.0), 'air flow velocity, m/s'),
    'water.density': Key('number', 1000.0, 'water density, kg/m^3', _POSITIVE),
    'water.surface_z': Key('number', 0.0, 'height of the water surface, m'),
    'water.current': Key('vector', (0.0, 0.0, 0.0), 'water flow velocity, m/s'),
    'pool.min': Key('vector', (-4.0, -4.0, -4.0), 'pool corner with the floor, m'),
    'pool.max': Key('vector', (4.0, 4.0, 4.0), 'pool corner with the ceiling, m'),
    'contact.restitution': Key('number', ContactParameters.restitution,
                               'normal speed kept in a bounce, 0..1',
                               (lambda v: 0.0 <= v <= 1.0, 'between 0 and 1')),
    'contact.static_friction': Key('number', ContactParameters.static_friction,
                                   'static friction coefficient', _NON_NEGATIVE),
    'contact.kinetic_friction': Key('number', ContactParameters.kinetic_friction,
                                    'kinetic friction coefficient', _NON_NEGATIVE),
    'contact.rolling_friction': Key('number', ContactParameters.rolling_friction,
                                    'rolling resistance coefficient', _NON_NEGATIVE),
    'effects': Key('strings', DEFAULT_EFFECTS, 'the physics that runs; anything else costs '
                   'nothing', (lambda v: set(v) <= set(EFFECTS), f'a subset of {list(EFFECTS)}')),
    'integrator': Key('string', DEFAULT_INTEGRATOR, 'fixed-step integrator',
                      (lambda v: v in INTEGRATORS, f'one of {list(INTEGRATORS)}')),
    'physics_rate_hz': Key('number', 200.0, 'physics steps per simulated second', _POSITIVE),
    'publish_rate_hz': Key('number', 30.0, 'messages per simulated second', _POSITIVE),
    'real_time_factor': Key('number', 1.0, 'simulated seconds per wall second, 0 = as fast '
                            'as possible', _NON_NEGATIVE),
    'publish_clock': Key('bool', False, 'publish /clock with simulation time'),
    'frame_id': Key('string', 'world', 'frame of every published pose',
                    (lambda v: v != '', 'a non-empty string')),
    'wrench_timeout': Key('number', 1.0, 'simulated seconds a wrench holds without a new '
                          'message, 0 = for ever', _NON_NEGATIVE),
}

SPHERE_KEYS = {
    'mass': Key('number', 1.0, 'mass, kg', _POSITIVE),
    'radius': Key('number', 0.1, 'radius, m', _POSITIVE),
    'position': Key('vector', (0.0, 0.0, 0.0), 'initial position of the centre, m'),
    'velocity': Key('vector', (0.0, 0.0, 0.0), 'initial velocity, m/s'),
    'drag_coefficient': Key('number', 0.47, 'drag coefficient C_d', _NON_NEGATIVE),
    'lift_area': Key('number', None, 'lifting surface area, m^2 (default: the cross-section '
                     'pi*r^2)', _NON_NEGATIVE),
    'lift_normal': Key('vector', (0.0, 0.0, 1.0), 'normal of the lifting surface',
                       (lambda v: float(np.linalg.norm(v)) > 0.0, 'a non-zero vector')),
    'lift_coefficient': Key('number', 0.0, 'lift coefficient C_l'),
}


def sphere_key_default(key: str, radius: float):
    """Default of a per-sphere key; lift_area's follows the sphere's radius."""
    if key == 'lift_area':
        return math.pi * radius * radius
    return SPHERE_KEYS[key].default


def check_value(name: str, key: Key, value):
    """The value in its canonical Python type, or InvalidInput naming `name`."""
    if key.kind == 'number':
        if isinstance(value, bool) or not isinstance(value, (int, float)):
            raise InvalidInput(f'{name}: expected a number, got {value!r}')
        value = float(value)
        if not math.isfinite(value):
            raise InvalidInput(f'{name}: must be finite, got {value!r}')
    elif key.kind == 'vector':
        value = tuple(check_vector(name, value))
    elif key.kind == 'string':
        if not isinstance(value, str):
            raise InvalidInput(f'{name}: expected a string, got {value!r}')
    elif key.kind == 'strings':
        # rclpy hands an empty YAML list over as a parameter that is not set (None).
        value = () if value is None else value
        if isinstance(value, str) or not all(isinstance(v, str) for v in value):
            raise InvalidInput(f'{name}: expected a list of strings, got {value!r}')
        value = tuple(value)
    elif key.kind == 'bool':
        if not isinstance(value, bool):
            raise InvalidInput(f'{name}: expected true or false, got {value!r}')
    predicate, words = key.allowed
    if predicate is not None and not predicate(value):
        raise InvalidInput(f'{name}: must be {words}, got {value!r}')
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


class Scene:
    """A validated, fully defaulted set of parameters: `scene['steel.mass']`."""

    def __init__(self, params: dict):
        params = flatten(params)
        names = check_value('sphere_names', GLOBAL_KEYS['sphere_names'],
                            params.get('sphere_names', ()))
        if len(set(names)) != len(names):
            raise InvalidInput(f'sphere_names: names must be unique, got {list(names)}')
        for name in names:
            if not name or any(c in name for c in './ ') or name[0].isdigit():
                raise InvalidInput(f'sphere_names: {name!r} is not a valid ROS name part')
        allowed = dict(GLOBAL_KEYS)
        for name in names:
            allowed.update({f'{name}.{key}': spec for key, spec in SPHERE_KEYS.items()})
        for name in params:
            if name not in allowed:
                raise InvalidInput(f'{name}: unknown key; spheres are {list(names)}, global '
                                   f'keys are {list(GLOBAL_KEYS)}')
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
        with open(path, encoding='utf-8') as stream:
            document = yaml.safe_load(stream) or {}
        params = {}
        for section in ('/**', f'/**/{node_name}', node_name, f'/{node_name}'):
            entry = document.get(section)
            if entry is not None:
                if not isinstance(entry, dict) or 'ros__parameters' not in entry:
                    raise InvalidInput(f'{section}: expected a ros__parameters mapping')
                params.update(flatten(entry['ros__parameters'] or {}))
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
        if self['contact.kinetic_friction'] > self['contact.static_friction']:
            raise InvalidInput('contact.kinetic_friction: must not exceed '
                               'contact.static_friction')
        if 'friction' in self['effects'] and 'contact' not in self['effects']:
            raise InvalidInput('effects: friction acts through floor contact; list contact too')
        for name in self.sphere_names:
            radius = self[f'{name}.radius']
            if 2.0 * radius >= float(np.min(high - low)):
                raise InvalidInput(f'{name}.radius: {radius} m does not fit the pool')

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
        """The initial state as arrays; positions are put inside the pool if they overlap it."""
        names = self.sphere_names

        def scalars(key):
            return np.array([self[f'{n}.{key}'] for n in names], dtype=float)

        def vectors(key):
            return np.array([self[f'{n}.{key}'] for n in names], dtype=float).reshape(-1, 3).T

        radius = scalars('radius')
        normal = vectors('lift_normal')
        position = np.clip(vectors('position'), np.array(self['pool.min'])[:, None] + radius,
                           np.array(self['pool.max'])[:, None] - radius)
        return Spheres(
            names=tuple(names), position=np.ascontiguousarray(position),
            velocity=np.ascontiguousarray(vectors('velocity')), mass=scalars('mass'),
            radius=radius, drag_coefficient=scalars('drag_coefficient'),
            lift_area=scalars('lift_area'),
            lift_normal=np.ascontiguousarray(normal / np.linalg.norm(normal, axis=0)),
            lift_coefficient=scalars('lift_coefficient'),
            external_force=np.zeros((3, len(names))))
