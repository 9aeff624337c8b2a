"""The scene as ROS parameters: declared from the core's schema, read back as a Scene.

A params file's keys arrive as the node's parameter overrides; they are checked by the same
Scene validation the core uses, so a wrong key, type or value stops the node with the key's
name.

Per-sphere keys take one of two forms, chosen with the per-sphere topics:
- `per_sphere_topics: true` (the default, small scenes): `<sphere>.<key>`, one parameter
  per sphere and key, as `ros2 param set /pool_sim cork.mass 9` expects;
- `false`: `spheres.<key>`, one array over `sphere_names` per key (a vector key as three,
  `spheres.<key>.x`, `.y`, `.z`), so the parameter count and memory do not grow per sphere.
A params file may use either form in either case.

Types are fixed, as `ros2 param describe` shows them: a number is a double, a vector a
double array. An integer given for either becomes a double before rclpy's type check (the
pre-set callback), on every path. Keys that cannot change while running are read_only, so
rclpy refuses them with its standard reason.
"""
import array

import numpy as np
from rcl_interfaces.msg import FloatingPointRange, IntegerRange, ParameterDescriptor, \
    ParameterEvent
from rclpy.parameter import Parameter

from pool_sim.physics.scene import Scene
from pool_sim.physics.schema import (check_some_sphere_names, COMPONENTS, GLOBAL_KEYS,
                                     SPHERE_KEYS)
from pool_sim.physics.spheres import LIVE_KEYS as LIVE_SPHERE_KEYS, range_words
from pool_sim.ros.node_keys import (LOCKSTEP_KEYS, NODE_KEYS, NODE_SCENE, RESERVED_NAMES,
                                    ROS_OWN_PARAMETERS)

# Every global key of the node's scene: the physics' and the node's own.
SCENE_KEYS = {**GLOBAL_KEYS, **NODE_KEYS}
# What may change while the node runs: the per-sphere LIVE_SPHERE_KEYS, sphere_names (spawn and
# remove, with the new spheres' keys in the same request), and the lockstep settings.
LIVE_GLOBAL_KEYS = ('sphere_names',) + LOCKSTEP_KEYS
ARRAY_PREFIX = 'spheres.'


def is_ros_own(name: str) -> bool:
    return name in ROS_OWN_PARAMETERS or name.startswith('qos_overrides.')


def array_parameter(name: str):
    """(key, component index or None) of a `spheres.<key>` or `spheres.<key>.x|y|z` name,
    or None for any other name."""
    if not name.startswith(ARRAY_PREFIX):
        return None
    key, _, component = name[len(ARRAY_PREFIX):].partition('.')
    spec = SPHERE_KEYS.get(key)
    if spec is None:
        return None
    if spec.kind == 'vector':
        return (key, COMPONENTS.index(component)) if component in COMPONENTS else None
    return None if component else (key, None)


def array_parameter_names():
    return [f'{ARRAY_PREFIX}{key}.{c}' if spec.kind == 'vector' else f'{ARRAY_PREFIX}{key}'
            for key, spec in SPHERE_KEYS.items()
            for c in (COMPONENTS if spec.kind == 'vector' else ('',))]


def scene_from_overrides(overrides: dict, default: Scene) -> Scene:
    """The default scene with a params file's values laid over it.

    overrides: {name: python value}. Spheres of the default scene keep their values when the
    file keeps their names (for the keys the file does not give in either form); spheres it
    adds start from the schema's defaults.
    """
    overrides = {name: value for name, value in overrides.items() if not is_ros_own(name)}
    # An empty YAML list arrives as a parameter that is not set (None): refused as [].
    names = check_some_sphere_names(overrides.get('sphere_names', default.sphere_names),
                                    RESERVED_NAMES)
    params = dict(default.global_values())
    as_arrays = {name[len(ARRAY_PREFIX):].partition('.')[0] for name in overrides
                 if name.startswith(ARRAY_PREFIX)}
    for name in names:
        if name not in default.sphere_names:
            continue
        for key in SPHERE_KEYS:
            dotted = f'{name}.{key}'
            if dotted in overrides or key in as_arrays:
                continue
            if key == 'lift_area' and not default.lift_area_given[
                    default.sphere_names.index(name)]:
                continue  # it follows the radius, which the file may change
            params[dotted] = default[dotted]
    params.update(overrides)
    return Scene(params, extension=NODE_SCENE)


def describe(name: str, read_only: bool) -> ParameterDescriptor:
    """Description, unit, range and read_only, as `ros2 param describe` shows them. The
    range is a FloatingPointRange for numbers (rclpy enforces it on doubles) and for each
    component of a vector or array (shown; the scene's own checks enforce every range)."""
    if name.startswith(ARRAY_PREFIX):
        key, component = array_parameter(name)
        key = SPHERE_KEYS[key]
        which = '' if component is None else f'the {COMPONENTS[component]} component of the '
        description = f'{which}{key.description}; one per sphere, in sphere_names order'
        scope = 'each value '
    else:
        key = SCENE_KEYS.get(name) or SPHERE_KEYS[name.rsplit('.', 1)[1]]
        description = key.description
        scope = 'each component ' if key.kind == 'vector' else ''
    if name.endswith('lift_area'):
        description += '; follows the radius until set'
    descriptor = ParameterDescriptor(description=description, read_only=read_only)
    if key.kind == 'integer':
        descriptor.integer_range = [
            IntegerRange(from_value=int(key.low), to_value=int(key.high), step=1)]
        descriptor.additional_constraints = range_words(key.low, key.high, key.unit)
    elif key.low is not None:  # numbers and vectors
        descriptor.floating_point_range = [
            FloatingPointRange(from_value=float(key.low), to_value=float(key.high), step=0.0)]
        descriptor.additional_constraints = f'{scope}{range_words(key.low, key.high, key.unit)}'
    return descriptor


def is_read_only(name: str) -> bool:
    if name in SCENE_KEYS:
        return name not in LIVE_GLOBAL_KEYS
    if name.startswith(ARRAY_PREFIX):
        return False  # spawn requests carry the new spheres' entries; checked by the node
    return name.rsplit('.', 1)[1] not in LIVE_SPHERE_KEYS


def doubles(values):
    """A double array parameter value: array.array holds 8 bytes a number, a list 32."""
    packed = array.array('d')
    packed.frombytes(np.ascontiguousarray(values, dtype=float).tobytes())
    return packed


def sphere_parameters(scene: Scene, per_sphere: bool, live=None, names=None):
    """(name, value, descriptor) of every per-sphere parameter, in the chosen form.

    live: {key: (n,) array} of the current mass, radius and lift area to show instead of
    the scene's initial ones. names: only these spheres (per-sphere form).
    """
    live = live or {}
    if not per_sphere:
        declared = []
        for name in array_parameter_names():
            key, component = array_parameter(name)
            values = live.get(key, scene.sphere_array(key))
            values = values if component is None else values[:, component]
            declared.append((name, doubles(values), describe(name, False)))
        return declared
    index = {name: i for i, name in enumerate(scene.sphere_names)}
    chosen = scene.sphere_names if names is None else names
    arrays = {key: live.get(key, scene.sphere_array(key)).tolist() for key in SPHERE_KEYS}
    # A descriptor each: rclpy writes the parameter's name into it.
    return [(f'{name}.{key}', arrays[key][index[name]],
             describe(f'{name}.{key}', is_read_only(f'{name}.{key}')))
            for name in chosen for key in SPHERE_KEYS]


def declare_scene(node, scene: Scene, per_sphere: bool) -> None:
    """Declare every key of the scene on the node, with its value and descriptor."""
    declared = [(name, ros_value(value), describe(name, is_read_only(name)))
                for name, value in scene.global_values().items()]
    for name, value, descriptor in declared:
        if value is None:  # an empty list has no type of its own: keep it untyped
            descriptor.dynamic_typing = True
    declared += sphere_parameters(scene, per_sphere)
    node.declare_parameters('', declared, ignore_override=True)


def ros_value(value):
    """Python value as rclpy declares it: tuples as lists, an empty list as 'not set'."""
    if isinstance(value, tuple):
        return list(value) if value else None
    return value


def plain(value):
    """A parameter's value as the core takes it: rclpy hands arrays over as array.array."""
    return value.tolist() if isinstance(value, array.array) else value


def number_key(name: str):
    """The schema Key of a parameter name in any form ('gravity', 'cork.mass',
    'spheres.mass'), or None: for a name of a sphere not declared yet too."""
    if name in SCENE_KEYS:
        return SCENE_KEYS[name]
    if name.startswith(ARRAY_PREFIX):
        found = array_parameter(name)
        return None if found is None else SPHERE_KEYS[found[0]]
    return SPHERE_KEYS.get(name.rpartition('.')[2])


def as_declared_types(parameters):
    """Integers given for a double key (or integer arrays for a double-array key) as
    doubles: one stored type per key, whichever path the value came by."""
    converted = []
    for parameter in parameters:
        key = number_key(parameter.name)
        if key is not None and key.kind in ('number', 'vector'):
            is_array = key.kind == 'vector' or parameter.name.startswith(ARRAY_PREFIX)
            if not is_array and parameter.type_ == Parameter.Type.INTEGER:
                parameter = Parameter(parameter.name, Parameter.Type.DOUBLE,
                                      float(parameter.value))
            elif is_array and parameter.type_ == Parameter.Type.INTEGER_ARRAY:
                parameter = Parameter(parameter.name, Parameter.Type.DOUBLE_ARRAY,
                                      [float(v) for v in parameter.value])
        converted.append(parameter)
    return converted


def retable(node, removed=(), declared=(), changed=()):
    """Change the node's own parameter table: `removed` names, `declared` (name, value,
    descriptor) and `changed` (name, value), and publish the ParameterEvent of it.

    For spawn and remove: rclpy 7.1.6 has no public way for a node to undeclare its own
    read-only parameters or to set them (set_parameters refuses read_only, as it must for
    clients), so the node edits rclpy's tables directly, as rclpy itself does.
    """
    event = ParameterEvent(node=node.get_fully_qualified_name())
    table, descriptors = node._parameters, node._descriptors
    for name in removed:
        parameter = table.pop(name, None)
        descriptors.pop(name, None)
        if parameter is not None:
            event.deleted_parameters.append(parameter.to_parameter_msg())
    for name, value, descriptor in declared:
        parameter = Parameter(name, value=value)
        descriptor.name, descriptor.type = name, parameter.type_.value
        is_new = name not in table
        table[name] = parameter
        descriptors[name] = descriptor
        (event.new_parameters if is_new else event.changed_parameters).append(
            parameter.to_parameter_msg())
    for name, value in changed:
        table[name] = Parameter(name, value=value)
        event.changed_parameters.append(table[name].to_parameter_msg())
    event.stamp = node.get_clock().now().to_msg()
    node._parameter_event_publisher.publish(event)


def overrides_of(node) -> dict:
    """The node's parameter overrides (params files, -p) as {name: python value}."""
    # rclpy keeps them here; there is no public accessor in Jazzy.
    return {name: parameter.value
            for name, parameter in getattr(node, '_parameter_overrides', {}).items()}


def params_files(argv) -> list:
    """The paths given to --params-file in the --ros-args parts of a command line."""
    paths, in_ros_args = [], False
    for i, token in enumerate(argv):
        if token == '--ros-args':
            in_ros_args = True
        elif token == '--':
            in_ros_args = False
        elif in_ros_args and token == '--params-file' and i + 1 < len(argv):
            paths.append(argv[i + 1])
    return paths
