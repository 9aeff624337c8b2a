"""ROS params files, read as rcl and rclpy read them.

A file maps node names to `ros__parameters`. rcl parses the whole file (a list must hold one
type: `[1, 0.5]` refuses the file) and joins nested names (`ns: {pool: ...}` is `ns/pool`);
rclpy gives a node the sections whose name matches its fully qualified name, in the file's
order, later ones winning: a name without a leading `/` gets one, and each `/*` matches one
name token and `/**` any number of them. So `/**` applies to every node, `/**/pool_sim` to a
node named pool_sim in any namespace, `pool_sim` and `/pool_sim` only to /pool_sim.
"""
import os
from pathlib import Path
import re

import yaml

from .schema import flatten
from .spheres import InvalidInput, named_few, shown

NODE_NAME = 'pool_sim'
PARAMETERS = 'ros__parameters'
ANY_NODE = '/**'
# What the files read last held: their sections and whether each sets something, so the
# node can say which of its files set nothing without parsing them again (a scene of
# 100 000 spheres takes a second to parse).
_SECTIONS_READ = {}
_SECTIONS_KEPT = 16


def read_params_document(path) -> dict:
    """A ROS params file as a mapping (node name -> {ros__parameters: ...}), or
    InvalidInput naming the file and what is wrong with it (rcl's parser would refuse it
    too, but naming neither the file nor the key)."""
    try:
        with open(path, encoding='utf-8') as stream:
            stamp = _stamp(stream.fileno())
            # libyaml's loader where PyYAML has it: 100 000 spheres in 1 s, not 18.
            document = yaml.load(stream, Loader=getattr(yaml, 'CSafeLoader', yaml.SafeLoader))
    except (OSError, UnicodeDecodeError, yaml.YAMLError) as error:
        first_line = (str(error).splitlines() or [type(error).__name__])[0]
        raise InvalidInput(f'{path}: cannot read it as YAML: {first_line}') from None
    document = {} if document is None else document
    if not isinstance(document, dict):
        raise InvalidInput(f'{path}: expected a mapping of node names to ros__parameters, '
                           f'got {shown(document)}')
    sections = node_sections(document)
    for section, entry in sections:
        if isinstance(entry, dict) and isinstance(entry.get(PARAMETERS), dict):
            _check_lists(path, entry[PARAMETERS], '')
    if len(_SECTIONS_READ) >= _SECTIONS_KEPT:
        _SECTIONS_READ.clear()
    _SECTIONS_READ[(os.fspath(path), stamp)] = [
        (section, isinstance(entry, dict) and bool(entry.get(PARAMETERS)))
        for section, entry in sections]
    return document


def node_sections(document: dict) -> list:
    """[(section name, its entry)] in the file's order, as rcl joins them: a mapping without
    ros__parameters is a namespace over the sections it holds."""
    sections = []
    for key, entry in document.items():
        name = str(key)
        if (isinstance(entry, dict) and entry and PARAMETERS not in entry
                and all(isinstance(inner, dict) for inner in entry.values())):
            sections += [(f'{name.rstrip("/")}/{inner}', inner_entry)
                         for inner, inner_entry in node_sections(entry)]
        else:
            sections.append((name, entry))
    return sections


def section_applies(section: str, node_fqn: str) -> bool:
    """Whether rclpy gives the node `node_fqn` (/namespace/name) the section `section`."""
    name = section if section.startswith('/') else '/' + section
    token = r'(/\w+)'
    pattern = re.escape(name).replace(r'/\*\*', token + '*').replace(r'/\*', token)
    return re.fullmatch(pattern, node_fqn, flags=re.ASCII) is not None


def applying_parameters(document: dict, node_fqn: str) -> list:
    """[(section name, its ros__parameters mapping)] of the sections that apply to
    `node_fqn`, in the file's order (a later one wins, key by key); InvalidInput for one
    that is not a ros__parameters mapping."""
    applying = []
    for section, entry in node_sections(document):
        if not section_applies(section, node_fqn):
            continue
        parameters = entry.get(PARAMETERS) if isinstance(entry, dict) else None
        if (not isinstance(entry, dict) or PARAMETERS not in entry
                or not isinstance(parameters, (dict, type(None)))):
            raise InvalidInput(f'{section}: expected a ros__parameters mapping')
        applying.append((section, parameters or {}))  # empty in the file: None
    return applying


def sets_nothing_reason(path, node_fqn: str):
    """Why the params file `path` sets no parameter of the node `node_fqn`, in words naming
    the file, its sections and the node; None when it sets some (or cannot be read now:
    whoever read it first said so)."""
    try:
        with open(path, 'rb') as stream:
            stamp = _stamp(stream.fileno())
        sections = _SECTIONS_READ.get((os.fspath(path), stamp))
        if sections is None:
            read_params_document(path)
            sections = _SECTIONS_READ.get((os.fspath(path), stamp), [])
    except (OSError, InvalidInput):
        return None
    if not sections:
        return f'params file {path} sets nothing: it holds no section'
    applying = [(name, holds) for name, holds in sections if section_applies(name, node_fqn)]
    if any(holds for _, holds in applying):
        return None
    if not applying:
        names = [name for name, _ in sections]
        return (f'params file {path} sets nothing for node {node_fqn}: none of its sections '
                f'({named_few(names)}) applies to that name; a section `{ANY_NODE}:` applies '
                'to every node name and namespace')
    return (f'params file {path} sets nothing for node {node_fqn}: the sections that apply '
            f'({named_few([name for name, _ in applying])}) hold no parameters')


def _stamp(descriptor) -> tuple:
    status = os.fstat(descriptor)
    return status.st_ino, status.st_size, status.st_mtime_ns


def _check_lists(path, parameters: dict, prefix: str):
    """Refuses, naming the key, a list of more than one type (rcl's parser refuses the file
    naming only a line)."""
    for key, value in parameters.items():
        name = f'{prefix}{key}'
        if isinstance(value, dict):
            _check_lists(path, value, name + '.')
        elif isinstance(value, list) and len(types := set(map(type, value))) > 1:
            if types == {int, float}:
                raise InvalidInput(
                    f'{path}: {name}: a list mixing integers and decimals ({shown(value)}); '
                    "rcl's params-file parser wants one type per list: write every number "
                    'as a decimal (1.0, not 1)')
            raise InvalidInput(f'{path}: {name}: a list mixing types ({shown(value)}); '
                               "rcl's params-file parser wants one type per list")


def ros_parameters(path, node_name: str = NODE_NAME, namespace: str = '/') -> dict:
    """The flat `ros__parameters` a ROS params file gives the node `node_name` in
    `namespace`, as rclpy matches sections (`/**`, `/**/<node_name>`, `<node_name>`, ...),
    later sections winning. InvalidInput when the file sets nothing for that node."""
    document = read_params_document(path)
    node_fqn = f'{namespace.rstrip("/")}/{node_name}'
    params = {}
    for _, parameters in applying_parameters(document, node_fqn):
        params.update(flatten(parameters))
    if not params:
        raise InvalidInput(sets_nothing_reason(path, node_fqn)
                           or f'{path}: no ros__parameters for node {node_fqn}')
    return params


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
