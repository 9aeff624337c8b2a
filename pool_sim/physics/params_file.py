"""ROS params files: read as YAML, and the ros__parameters that apply to a node name.

The node's own reader of the file it is started with, before rcl's (which gives a line
number but no key), and the core's way to a scene from a file (Scene.from_yaml).
"""
from pathlib import Path

import yaml

from .schema import flatten
from .spheres import InvalidInput, shown

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


def read_params_document(path) -> dict:
    """A ROS params file as a mapping (node name -> {ros__parameters: ...}), or
    InvalidInput naming the file and what is wrong with it."""
    try:
        with open(path, encoding='utf-8') as stream:
            # libyaml's loader where PyYAML has it: 100 000 spheres in 1 s, not 18.
            document = yaml.load(stream, Loader=getattr(yaml, 'CSafeLoader', yaml.SafeLoader))
    except (OSError, UnicodeDecodeError, yaml.YAMLError) as error:
        first_line = (str(error).splitlines() or [type(error).__name__])[0]
        raise InvalidInput(f'{path}: cannot read it as YAML: {first_line}') from None
    document = {} if document is None else document
    if not isinstance(document, dict):
        raise InvalidInput(f'{path}: expected a mapping of node names to ros__parameters, '
                           f'got {shown(document)}')
    return document


def ros_parameters(path, node_name: str = NODE_NAME) -> dict:
    """The flat `ros__parameters` for `node_name` in a ROS params file: the sections `/**`,
    `/**/<node_name>`, `<node_name>` and `/<node_name>`, later ones winning."""
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
    return params
