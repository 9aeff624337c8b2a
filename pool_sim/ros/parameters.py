"""The scene as ROS parameters: declared from the core's schema, read back as a Scene.

A params file's keys arrive as the node's parameter overrides; they are checked by the same
Scene validation the core uses, so a wrong key, type or value stops the node with the key's
name. Every key is declared with dynamic typing so that `ros2 param set ... 9` (an integer)
reaches our checks instead of rclpy's type lock.
"""
from rcl_interfaces.msg import ParameterDescriptor

from pool_sim.physics.scene import GLOBAL_KEYS, Scene, SPHERE_KEYS

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
    key = GLOBAL_KEYS.get(name) or SPHERE_KEYS[name.rsplit('.', 1)[1]]
    return ParameterDescriptor(description=key.description, dynamic_typing=True)


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
