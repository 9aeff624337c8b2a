"""The node's own keys: how it publishes, paces and waits, which the physics never reads.

They sit in the same scene (a params file holds both) as a schema.SceneExtension: checked,
defaulted, described and ranged as the physics' keys are, and known only here.
"""
from pool_sim.physics.schema import Key, reserved_names, SceneExtension
from pool_sim.physics.spheres import InvalidInput, named_few

PUBLISH_RATE_RANGE = (0.01, 1e4)  # Hz of simulated time
REAL_TIME_FACTOR_RANGE = (0.0, 1e4)  # 0 = as fast as the machine goes
WRENCH_TIMEOUT_RANGE = (0.0, 1e6)  # s of simulated time; 0 = for ever
LOCKSTEP_TIMEOUT_RANGE = (1e-3, 1e4)  # wall s; a dead controller costs at most this once
FOXGLOVE_PORT_RANGE = (-1, 65535)  # -1: no server; 0: any free port
# The name of the ~/forces input (every sphere at once) in lockstep_inputs; no sphere takes it.
FORCES_INPUT = 'forces'

NODE_KEYS = {
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
    'record': Key('string', '', 'an MCAP file (rosbag2 conventions) the node records every '
                  'published instant and every applied input into; empty: no recording',
                  allowed=(lambda v: '\0' not in v and len(v) <= 4096,
                           'a file path (no NUL, at most 4096 characters), or empty')),
    'foxglove_port': Key('integer', -1, 'TCP port of the Foxglove WebSocket server showing '
                         'the pool live: -1 none, 0 any free port (logged)',
                         *FOXGLOVE_PORT_RANGE),
    'foxglove_host': Key('string', '127.0.0.1', 'the address the Foxglove server listens '
                         'on: 127.0.0.1 lets only this machine connect, 0.0.0.0 every one',
                         allowed=(lambda v: v != '' and len(v) <= 253 and '\0' not in v,
                                  'a host name or address')),
}
# The node's keys that may change while it runs (with sphere_names: they name spheres).
LOCKSTEP_KEYS = ('lockstep', 'lockstep_inputs', 'lockstep_timeout')
# Parameters rclpy itself declares or reads; they are not part of the scene.
ROS_OWN_PARAMETERS = ('use_sim_time', 'start_type_description_service')


def check_lockstep_inputs(scene):
    """Every entry of lockstep_inputs is a sphere of the scene or FORCES_INPUT."""
    unknown = [name for name in scene['lockstep_inputs']
               if name != FORCES_INPUT and not scene.has_sphere(name)]
    if unknown:
        raise InvalidInput(f'lockstep_inputs: {named_few(unknown)} not in sphere_names '
                           f'({named_few(scene.sphere_names)}) nor {FORCES_INPUT!r}: each '
                           'entry is a sphere whose force answers, or the ~/forces array')


# What the node adds to a scene. No sphere may be named after a parameter of rclpy's, nor
# 'forces' (lockstep_inputs names ~/forces so).
NODE_SCENE = SceneExtension(keys=NODE_KEYS,
                            reserved=frozenset({*ROS_OWN_PARAMETERS, 'qos_overrides',
                                                FORCES_INPUT}),
                            follow_spheres=LOCKSTEP_KEYS, check=check_lockstep_inputs)
# Every first name part a sphere may not take in the node.
RESERVED_NAMES = reserved_names(NODE_SCENE)
