"""The house's bounds, measured from the files: no file under pool_sim/ over 450 lines, no
class over 300, no function over 120 (compiled loops included), the node's own file at most
300; the physics core imports nothing from ROS, and no layer imports one above it."""
import ast
from pathlib import Path

import pytest

PACKAGE = Path(__file__).resolve().parents[1] / 'pool_sim'
SOURCES = sorted(PACKAGE.rglob('*.py'))
MOST_LINES = {'file': 450, 'class': 300, 'function': 120}
NODE_FILE_MOST_LINES = 300
# Imports a physics file may not make: the ROS side, rclpy and the message packages.
ROS_MODULES = ('pool_sim.ros', 'pool_sim.testing', 'rclpy', 'rosidl', 'builtin_interfaces',
               'geometry_msgs', 'nav_msgs', 'std_msgs', 'std_srvs', 'visualization_msgs',
               'rcl_interfaces', 'rosgraph_msgs')


def relative(path):
    return path.relative_to(PACKAGE.parent).as_posix()


def imported_modules(path):
    """Absolute names of every module `path` imports (relative imports resolved)."""
    package = relative(path)[:-3].replace('/', '.').rsplit('.', 1)[0]
    for node in ast.walk(ast.parse(path.read_text())):
        if isinstance(node, ast.Import):
            yield from (alias.name for alias in node.names)
        elif isinstance(node, ast.ImportFrom):
            base = package.rsplit('.', node.level - 1)[0] if node.level > 1 else package
            yield (f'{base}.{node.module}' if node.module else base) if node.level else \
                node.module


def test_the_bounds_are_measured_from_every_file():
    assert len(SOURCES) > 20 and PACKAGE / 'ros' / 'simulator_node.py' in SOURCES


@pytest.mark.parametrize('path', SOURCES, ids=relative)
def test_no_file_class_or_function_is_larger_than_its_bound(path):
    text = path.read_text()
    too_large = []
    lines = text.count('\n')
    most = NODE_FILE_MOST_LINES if path.name == 'simulator_node.py' else MOST_LINES['file']
    if lines > most:
        too_large.append(f'the file: {lines} lines > {most}')
    for node in ast.walk(ast.parse(text)):
        kind = ('class' if isinstance(node, ast.ClassDef) else 'function'
                if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef)) else None)
        if kind is None:
            continue
        first = min([node.lineno] + [d.lineno for d in node.decorator_list])
        size = node.end_lineno - first + 1
        if size > MOST_LINES[kind]:
            too_large.append(f'{kind} {node.name}: {size} lines > {MOST_LINES[kind]}')
    assert not too_large, f'{relative(path)}: {"; ".join(too_large)}'


@pytest.mark.parametrize('path', [p for p in SOURCES if 'physics' in p.parts], ids=relative)
def test_the_physics_core_imports_nothing_from_ros(path):
    found = [name for name in imported_modules(path)
             if any(name == ros or name.startswith(ros + '.') for ros in ROS_MODULES)]
    assert not found, f'{relative(path)} imports {found}'


def test_imports_run_down_the_layers_only():
    """physics <- ros <- testing: a module imports from its own layer or one below."""
    layer = {'physics': 0, 'ros': 1, 'testing': 2}
    for path in SOURCES:
        parts = relative(path)[:-3].split('/')
        mine = layer.get(parts[1], 1)  # headless and __main__ sit with the ROS side
        for name in imported_modules(path):
            pieces = name.split('.')
            if pieces[0] != 'pool_sim' or len(pieces) < 2 or pieces[1] not in layer:
                continue
            assert layer[pieces[1]] <= mine, f'{relative(path)} imports {name}'
