"""A scene: a validated, fully defaulted set of the keys of schema.py (the node's ROS
parameters, contract section 4, less those only the node reads, which it adds).

Built from a flat dict of dotted keys ('steel.mass'), a nested dict, or a ROS params YAML
file. Every refusal is an InvalidInput whose message starts with the key it is about. The
scene keeps per-sphere keys as arrays over sphere_names, whichever form they came in.
"""
from functools import cached_property

import numpy as np

from .contact import ContactParameters
from .media import Environment, Medium, Pool
from .params_file import default_scene_file, NODE_NAME, ros_parameters
from .schema import (_checked_sphere_array, _default_column, _plain_sphere_values,
                     ARRAY_PREFIX, check_sphere_names, check_some_sphere_names, check_value,
                     flatten, GLOBAL_KEYS, join_components, NO_EXTENSION, reserved_names,
                     SceneExtension, SPHERE_KEYS)
from .spheres import InvalidInput, named_few, shortened, shown, Spheres


class Scene:
    """A validated, fully defaulted set of parameters: `scene['steel.mass']`.

    Per-sphere values are kept as arrays over sphere_names (sphere_array); `values` gives
    every key in the `<name>.<key>` form, for small scenes. lift_area_given: (n,) bool,
    True where the params gave the lift area; elsewhere it is pi r^2 and follows the radius.
    extension: keys the scene carries for whoever runs it (schema.SceneExtension); every
    scene derived from this one carries them too.
    """

    def __init__(self, params: dict, *, extension: SceneExtension = NO_EXTENSION,
                 _sphere_start=None):
        """params: flat or nested keys, per-sphere keys in either form (each key one way).
        _sphere_start: for with_spheres: validated per-sphere arrays (and lift_area_given)
        the spheres start from instead of the schema defaults."""
        self.extension = extension
        self.global_keys = {**GLOBAL_KEYS, **extension.keys}
        self.reserved_names = reserved_names(extension)
        params = join_components(flatten(params))
        names = check_sphere_names(params.get('sphere_names', ()), self.reserved_names)
        self.sphere_names = names
        # Sort the keys: as arrays {key: value}, one by one {key: {sphere index: value}}.
        as_arrays, one_by_one = {}, {key: {} for key in SPHERE_KEYS}
        for name, value in params.items():
            if name in self.global_keys:
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
                                   f'{named_few(names)}, global keys are {list(self.global_keys)}')
            if not (key == 'lift_area' and value is None):  # None: not given
                one_by_one[key][index] = value
        for key in as_arrays:
            if one_by_one[key]:
                sphere = names[next(iter(one_by_one[key]))]
                raise InvalidInput(f'{ARRAY_PREFIX}{key}: given both as {ARRAY_PREFIX}{key} '
                                   f'and as {sphere}.{key}; give each key one way')
        self._globals = {'sphere_names': names}
        for name, spec in self.global_keys.items():
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
    def from_yaml(cls, path, node_name: str = NODE_NAME, namespace: str = '/',
                  extension: SceneExtension = NO_EXTENSION) -> 'Scene':
        """The `ros__parameters` a ROS params file gives the node `node_name` in `namespace`,
        as rclpy matches sections (params_file.py)."""
        return cls(ros_parameters(path, node_name, namespace), extension=extension)

    @classmethod
    def default(cls, extension: SceneExtension = NO_EXTENSION) -> 'Scene':
        """The seed's swimming pool, from config/pool.yaml."""
        return cls.from_yaml(default_scene_file(), extension=extension)

    def with_values(self, **changes) -> 'Scene':
        """A copy with some keys changed (dotted keys may be given as a dict). A changed
        sphere_names keeps the spheres this scene has, with their values; new spheres take
        the schema defaults."""
        changes = flatten(changes)
        names = (check_sphere_names(changes['sphere_names'], self.reserved_names)
                 if 'sphere_names' in changes else self.sphere_names)
        return self._derived(names, changes)

    def with_spheres(self, names, given=None) -> 'Scene':
        """A new scene of the spheres `names`, in that order, for spawn and remove.

        A sphere this scene has keeps its values but for the keys `given` gives; a new one
        takes the given values or the schema defaults. given: per-sphere keys in either form
        ('cork.mass', or 'spheres.mass' over `names`), flat or nested; sphere_names only if
        it is `names`. The global keys stay this scene's (with_values changes those) but for
        the extension's keys that name spheres, which may change with them.
        """
        given = flatten(given or {})
        names = check_some_sphere_names(names, self.reserved_names)
        follow = self.extension.follow_spheres
        for key, value in given.items():
            if key == 'sphere_names':
                if check_sphere_names(value, self.reserved_names) != names:
                    raise InvalidInput(f'sphere_names: {shown(value)} is not the names '
                                       f'given to with_spheres ({named_few(names)})')
            elif key in self.global_keys and key not in follow:
                naming = f'and {", ".join(follow)}, which name them, ' if follow else ''
                raise InvalidInput(f'{key}: a global key; with_spheres changes the spheres '
                                   f'{naming}only (with_values changes the rest)')
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
        return Scene({**self._globals, 'sphere_names': names, **changes},
                     extension=self.extension, _sphere_start=start)

    def has_sphere(self, name) -> bool:
        return name in self._index

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
        if self.extension.check is not None:
            self.extension.check(self)
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
