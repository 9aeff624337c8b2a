"""The scene as ROS parameters: declared from the core's schema, read back as a Scene.

A params file's keys arrive as the node's parameter overrides; they are checked by the same
Scene validation the core uses, so a wrong key, type or value stops the node with the key's
name. Every key is declared with dynamic typing so that `ros2 param set ... 9` (an integer)
reaches our checks instead of rclpy's type lock.
"""
from rcl_interfaces.msg import FloatingPointRange, ParameterDescriptor

from pool_sim.physics.scene import GLOBAL_KEYS, InvalidInput, Scene, SPHERE_KEYS
from pool_sim.physics.spheres import range_words

# Parameters rclpy itself declares or reads; they are not part of the scene.
ROS_OWN_PARAMETERS = ('use_sim_time', 'start_type_description_service')
LIVE_SPHERE_KEYS = ('mass', 'radius')


def scene_from_overrides(overrides: dict, default: Scene) -> Scene:
    """The default scene with a params file's values laid over it.

    overrides: {name: python value}. Spheres of the default scene keep their values when the
    file keeps their names; spheres it adds start from the schema's defaults.
    """
    overrides = {name: value for name, value in overrides.items()
                 if name not in ROS_OWN_PARAMETERS and not name.startswith('qos_overrides.')}
    names = overrides.get('sphere_names', default.sphere_names)
    if names is None:  # an empty YAML list arrives as a parameter that is not set
        raise InvalidInput('sphere_names: the node needs at least one sphere, got []')
    # A wrong type is left for Scene to refuse, naming the key.
    names = tuple(names) if isinstance(names, (list, tuple)) else ()
    params = {key: default[key] for key in GLOBAL_KEYS}
    for name in names:
        for key in SPHERE_KEYS:
            dotted = f'{name}.{key}'
            if name in default.sphere_names and dotted not in overrides:
                params[dotted] = default[dotted]
    params.update(overrides)
    return Scene(params)


def describe(name: str) -> ParameterDescriptor:
    """Description, unit and range, as `ros2 param describe` shows them. The range is a
    FloatingPointRange for numbers and for each component of a vector (rclpy enforces it
    on doubles only; the scene's own checks enforce every range)."""
    key = GLOBAL_KEYS.get(name) or SPHERE_KEYS[name.rsplit('.', 1)[1]]
    descriptor = ParameterDescriptor(description=key.description, dynamic_typing=True)
    if key.low is not None:  # numbers and vectors
        descriptor.floating_point_range = [
            FloatingPointRange(from_value=float(key.low), to_value=float(key.high), step=0.0)]
        scope = 'each component ' if key.kind == 'vector' else ''
        descriptor.additional_constraints = (
            f'{scope}{range_words(key.low, key.high, key.unit)}')
    return descriptor


def declare_scene(node, scene: Scene) -> None:
    """Declare every key of the scene on the node, with its value and description."""
    node.declare_parameters('', [
        (name, ros_value(value), describe(name)) for name, value in scene.values.items()])


def ros_value(value):
    """Python value as rclpy declares it: tuples as lists, an empty list as 'not set'."""
    if isinstance(value, tuple):
        return list(value) if value else None
    return value


def live_key(name: str, sphere_names) -> str:
    """'mass' or 'radius' for a live-changeable '<sphere>.<key>' name, else ''."""
    sphere, _, key = name.rpartition('.')
    return key if sphere in sphere_names and key in LIVE_SPHERE_KEYS else ''


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
