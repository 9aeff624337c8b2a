"""Writes docs/parameters.md from the code: every key of the scene and of the node, with its
ROS type, default, unit, range, description and whether it changes while the node runs.

    .venv/bin/python -m scripts.parameters_page           write docs/parameters.md
    .venv/bin/python scripts/parameters_page.py --check   exit 1 when the page is stale

The sources: pool_sim/physics/schema.py (GLOBAL_KEYS, SPHERE_KEYS), pool_sim/ros/node_keys.py
(NODE_KEYS), what may change live from pool_sim/ros/parameters.py (is_read_only), and the
defaults the node declares: the default scene (config/pool.yaml laid over the schema).
"""
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
if str(ROOT) not in sys.path:  # run as a file, not with -m
    sys.path.insert(0, str(ROOT))

from pool_sim.physics.scene import Scene  # noqa: E402
from pool_sim.physics.schema import ARRAY_PREFIX, GLOBAL_KEYS, SPHERE_KEYS  # noqa: E402
from pool_sim.physics.spheres import range_words  # noqa: E402
from pool_sim.ros.node_keys import NODE_KEYS, NODE_SCENE, RESERVED_NAMES  # noqa: E402
from pool_sim.ros.parameters import is_read_only  # noqa: E402

PAGE = ROOT / 'docs' / 'parameters.md'
COMMAND = '.venv/bin/python -m scripts.parameters_page'
ROS_TYPES = {'number': 'double', 'integer': 'integer', 'vector': 'double array',
             'string': 'string', 'strings': 'string array', 'bool': 'bool'}
# The node's keys, by what they set; every key of NODE_KEYS is in exactly one group.
NODE_GROUPS = {
    'Publishing': ('publish_rate_hz', 'publish_clock', 'per_sphere_topics', 'frame_id'),
    'Pacing and inputs': ('real_time_factor', 'wrench_timeout'),
    'Lockstep': ('lockstep', 'lockstep_inputs', 'lockstep_timeout'),
    'Recording': ('record',),
    'Live view (Foxglove)': ('foxglove_port', 'foxglove_host'),
}
HEADER = ('| Key | Type | Default | Unit | Range or allowed | Live | Description |\n'
          '|---|---|---|---|---|---|---|')


def shown_default(value) -> str:
    """A default as a params file writes it."""
    if isinstance(value, bool):
        return 'true' if value else 'false'
    if isinstance(value, (tuple, list)):
        return '[' + ', '.join(shown_default(v) for v in value) + ']'
    if isinstance(value, str):
        return f"'{value}'" if value == '' else value
    return repr(value)


def allowed_words(name: str, key) -> str:
    if key.low is not None:
        words = range_words(key.low, key.high, key.unit)
        words = f'each component {words}' if key.kind == 'vector' else words
        return f'{words}; {key.allowed[1]}' if key.allowed[1] else words
    if name == 'sphere_names':
        return ('unique ROS names; none may be '
                + ', '.join(sorted(RESERVED_NAMES)))
    return key.allowed[1] or 'any'


def cell(text: str) -> str:
    return text.replace('|', '\\|').replace('\n', ' ')


def row(name: str, key, ros_type: str, default: str, live: str) -> str:
    cells = [f'`{name}`', ros_type, f'`{default}`', key.unit or '-',
             allowed_words(name, key), live, key.description]
    return '| ' + ' | '.join(cell(c) for c in cells) + ' |'


def live_words(read_only: bool, sphere: bool = False) -> str:
    if not read_only:
        return 'yes'
    return 'no (given for a sphere spawned)' if sphere else 'no'


def global_rows(keys, defaults) -> list:
    return [row(name, keys[name], ROS_TYPES[keys[name].kind], shown_default(defaults[name]),
                live_words(is_read_only(name)))
            for name in keys]


def sphere_rows() -> list:
    rows = []
    for name, key in SPHERE_KEYS.items():
        default = ('pi r^2 (follows the radius until set)' if key.default is None
                   else shown_default(key.default))
        rows.append(row(name, key, ROS_TYPES[key.kind], default,
                        live_words(is_read_only(f'sphere.{name}'), sphere=True)))
    return rows


def array_names() -> str:
    names = [f'`{ARRAY_PREFIX}{key}.x` `.y` `.z`' if spec.kind == 'vector'
             else f'`{ARRAY_PREFIX}{key}`' for key, spec in SPHERE_KEYS.items()]
    return ', '.join(names)


def page() -> str:
    """The whole page, as docs/parameters.md holds it."""
    scene = Scene.default(NODE_SCENE)
    defaults = scene.global_values()
    grouped = [key for keys in NODE_GROUPS.values() for key in keys]
    assert sorted(grouped) == sorted(NODE_KEYS), 'NODE_GROUPS must name every node key once'
    lines = [
        '<!-- Generated from the code by `' + COMMAND + '`; do not edit by hand. -->',
        '# Parameters',
        '',
        f'Generated from the code by `{COMMAND}` (pool_sim/physics/schema.py, '
        'pool_sim/ros/node_keys.py, pool_sim/ros/parameters.py); '
        '`msg_tests/test_parameters_page.py` fails when it is stale.',
        '',
        'Every key is a ROS parameter of the node `pool_sim`, set in a params file '
        '(`--params-file`, as config/pool.yaml) or with `-p`. Defaults are what the node '
        'declares when given no params file: config/pool.yaml (the default pool of '
        f'{len(scene.sphere_names)} spheres: {", ".join(scene.sphere_names)}) laid over the '
        'schema. Live: whether `ros2 param set` may change it while the node runs; the '
        'others are read-only and a change is refused.',
        '',
        '## Scene (physics)',
        '',
        'What the physics runs: pool_sim/physics/schema.py GLOBAL_KEYS.',
        '',
        HEADER, *global_rows(GLOBAL_KEYS, defaults), '',
        '## Node',
        '',
        'What the node adds to the scene, which the physics never reads: '
        'pool_sim/ros/node_keys.py NODE_KEYS.',
        '',
    ]
    for title, names in NODE_GROUPS.items():
        keys = {name: NODE_KEYS[name] for name in names}
        lines += [f'### {title}', '', HEADER, *global_rows(keys, defaults), '']
    lines += [
        '## Per sphere',
        '',
        'pool_sim/physics/schema.py SPHERE_KEYS, one value each per sphere of sphere_names. '
        'Their names depend on `per_sphere_topics`:',
        '',
        '- `per_sphere_topics: true` (the default): `<sphere>.<key>`, one parameter per '
        'sphere and key (`cork.mass`, a vector as one double array `cork.position`);',
        '- `per_sphere_topics: false`: `spheres.<key>`, one double array over sphere_names '
        'per key, a vector key as three arrays `.x`, `.y`, `.z`: ' + array_names() + '.',
        '',
        'A params file may use either form whichever is on. The default is what a sphere '
        'takes when given no value (a sphere spawned by adding its name to sphere_names); '
        'the default pool\'s spheres set their own in config/pool.yaml. Keys that are not '
        'live may still be given for the spheres of a spawn, in the same request.',
        '',
        HEADER, *sphere_rows(), '',
    ]
    return '\n'.join(lines)


def main(argv=None) -> int:
    argv = sys.argv[1:] if argv is None else argv
    text = page()
    if '--check' in argv:
        if not PAGE.is_file() or PAGE.read_text() != text:
            print(f'{PAGE.relative_to(ROOT)} is stale: run {COMMAND}', file=sys.stderr)
            return 1
        return 0
    PAGE.write_text(text)
    print(f'wrote {PAGE.relative_to(ROOT)}')
    return 0


if __name__ == '__main__':
    sys.exit(main())
