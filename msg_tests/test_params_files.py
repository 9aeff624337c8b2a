"""Params files as rclpy reads them: which sections reach which node (our reader against
rclpy itself), and a file that sets nothing, or holds a list rcl refuses, is said aloud."""
import subprocess
import sys
import threading
import time

import pytest
import rclpy
from rclpy.context import Context
from rclpy.node import Node

from pool_sim.physics import InvalidInput, Scene
from pool_sim.physics.params_file import (applying_parameters, read_params_document,
                                          section_applies)
from pool_sim.physics.params_file import default_scene_file
from pool_sim.physics.schema import flatten
from test_process_exit import ENV, PARALLEL, section, start

# Section forms an attacker (or a launch file) writes, and the nodes they may meet.
SECTIONS = ['/**', '/**/pool', 'pool', '/pool', '/ns/pool', '/*/pool', '/**/pool_sim', '/*',
            '/ns/*', '/ns/**', '/**/ns/pool', '/*/*', 'ns/pool', '/ns/**/pool', '/**/*',
            'pool_sim', '/a/**/pool']
NODES = [('pool', '/'), ('pool_sim', '/'), ('pool', '/ns'), ('pool_sim', '/ns'),
         ('pool', '/ns/b'), ('pool', '/a/ns/b')]
# Whole files: nesting (rcl joins `ns: {pool: ...}` into ns/pool) and precedence (the
# file's order, key by key).
FILES = [f"'{name}':\n  ros__parameters:\n    x: 1.5\n" for name in SECTIONS] + [
    'ns:\n  pool:\n    ros__parameters:\n      x: 1.5\n',
    '/ns:\n  pool:\n    ros__parameters:\n      x: 1.5\n',
    '/**:\n  pool:\n    ros__parameters:\n      x: 1.5\n',
    '/**:\n  ros__parameters: {x: 1.5, y: 1.0}\n/**/pool:\n  ros__parameters: {x: 2.5}\n'
    '/pool:\n  ros__parameters: {x: 3.5}\n',
    '/pool:\n  ros__parameters: {x: 3.5}\n/**:\n  ros__parameters: {x: 1.5, y: 1.0}\n',
    '/**:\n  ros__parameters:\n    cork: {mass: 2.0}\n/**/pool_sim:\n  ros__parameters:\n'
    '    cork: {radius: 0.3}\n',
]
ROS_OWN = ('use_sim_time', 'start_type_description_service')


def rclpy_parameters(path, name, namespace) -> dict:
    """What rclpy gives the node `name` in `namespace` from the params file `path`."""
    context = Context()
    rclpy.init(args=['--ros-args', '--params-file', str(path)], context=context)
    try:
        node = Node(name, namespace=namespace, context=context,
                    automatically_declare_parameters_from_overrides=True)
        try:
            return {key: parameter.value
                    for key, parameter in node.get_parameters_by_prefix('').items()
                    if key not in ROS_OWN}
        finally:
            node.destroy_node()
    finally:
        rclpy.shutdown(context=context)


def our_parameters(path, name, namespace) -> dict:
    merged = {}
    fqn = f'{namespace.rstrip("/")}/{name}'
    for _, parameters in applying_parameters(read_params_document(path), fqn):
        merged.update(flatten(parameters))
    return merged


@pytest.mark.parametrize('text', FILES)
def test_a_section_reaches_the_nodes_rclpy_gives_it_to(tmp_path, text):
    path = tmp_path / 'params.yaml'
    path.write_text(text)
    for name, namespace in NODES:
        assert our_parameters(path, name, namespace) == rclpy_parameters(
            path, name, namespace), (text, name, namespace)


def test_the_matching_rule_in_words():
    assert all(section_applies('/**', fqn) for fqn in ('/pool', '/pool_sim', '/a/b/pool'))
    assert section_applies('/**/pool_sim', '/ns/pool_sim')
    assert not section_applies('/**/pool_sim', '/pool')  # launch's Node(name='pool')
    assert section_applies('pool', '/pool') and not section_applies('pool', '/ns/pool')
    assert section_applies('/*/pool', '/ns/pool') and not section_applies('/*/pool', '/pool')


def test_the_shipped_scene_applies_under_any_node_name():
    scene = Scene.from_yaml(default_scene_file(), 'pool', '/ns')
    assert scene.values == Scene.default().values and scene.sphere_names == (
        'cork', 'steel', 'ice')


def run_until_started(arguments, timeout_s=60.0):
    """Start `python -m pool_sim` with arguments, wait for its start-up line (spheres ...),
    stop it with SIGINT; (exit code, output)."""
    process = start(*arguments)
    lines = []
    reader = threading.Thread(target=lambda: lines.extend(process.stdout), daemon=True)
    reader.start()
    deadline = time.monotonic() + timeout_s
    while time.monotonic() < deadline and process.poll() is None and \
            not any('first state published' in line for line in lines):
        time.sleep(0.05)
    time.sleep(0.2)  # the warnings come just after the start-up lines
    process.send_signal(2)
    try:
        process.wait(timeout=30.0)
    except subprocess.TimeoutExpired:
        process.kill()
        process.wait()
    reader.join(timeout=5.0)
    return process.returncode, ''.join(lines)


RTF_2 = '  ros__parameters:\n    real_time_factor: 2.0\n'
NODE_CASES = [
    # (file, ros arguments, words the warning must hold (None: no warning), rtf applied)
    ('/**/pool_sim:\n' + RTF_2, ['-r', '__node:=pool'], ['/**/pool_sim', '/pool', '/**:'], 1),
    ('pool_sim:\n' + RTF_2, ['-r', '__ns:=/ns'], ['pool_sim', '/ns/pool_sim'], 1),
    ('/**:\n' + RTF_2, ['-r', '__node:=pool'], None, 2),
    ('/**/pool:\n' + RTF_2, ['-r', '__node:=pool', '-r', '__ns:=/ns'], None, 2),
    ('/*/pool_sim:\n' + RTF_2, ['-r', '__ns:=/ns'], None, 2),
    ('', [], ['holds no section'], 1),
    ('# nothing here\n', [], ['holds no section'], 1),
    ('/**:\n  ros__parameters: {}\n', [], ['/**', 'hold no parameters'], 1),
]


def test_a_params_file_that_sets_nothing_for_the_node_is_warned_about(tmp_path):
    runs = []
    for i, (text, arguments, words, _) in enumerate(NODE_CASES):
        path = tmp_path / f'my_pool_{i}.yaml'
        path.write_text(text)
        runs.append(['--params-file', str(path), *arguments])
    failures = []
    for batch in range(0, len(runs), PARALLEL):
        results = [None] * len(runs[batch:batch + PARALLEL])
        threads = [threading.Thread(target=lambda j, a: results.__setitem__(
            j, run_until_started(a)), args=(j, arguments))
            for j, arguments in enumerate(runs[batch:batch + PARALLEL])]
        for thread in threads:
            thread.start()
        for thread in threads:
            thread.join()
        for (text, arguments, words, rtf), (code, output), run in zip(
                NODE_CASES[batch:batch + PARALLEL], results, runs[batch:batch + PARALLEL]):
            warnings = [line for line in output.splitlines() if '[WARN]' in line]
            said = (not warnings if words is None else len(warnings) == 1 and all(
                word in warnings[0] for word in [run[1], *words]))
            if code != 0 or not said or f'real_time_factor {rtf};' not in output:
                failures.append((text, arguments, code, output[-1200:]))
    assert not failures, failures


def headless(path):
    return subprocess.run([sys.executable, '-m', 'pool_sim.headless', str(path),
                           '--seconds', '0.1', '--every', '0.1'], env=ENV,
                          capture_output=True, text=True, timeout=60)


@pytest.mark.parametrize('text, words', [
    (section('cork:\n  position: [1, 0.5, 2]'), ['cork.position', 'decimal']),
    (section('spheres:\n  mass: [1.0, 2]'), ['spheres.mass', 'decimal']),
    (section("sphere_names: [a, 1]"), ['sphere_names', 'one type per list']),
    ('', ['bad.yaml', 'holds no section']),
    ('/**/pool:\n  ros__parameters:\n    gravity: [0.0, 0.0, -1.0]\n',
     ['bad.yaml', '/**/pool', '/pool_sim']),
])
def test_headless_refuses_such_a_file_in_one_line_naming_the_key_or_the_file(
        tmp_path, text, words):
    path = tmp_path / 'bad.yaml'
    path.write_text(text)
    done = headless(path)
    assert done.returncode == 1 and 'Traceback' not in done.stderr, done.stderr
    lines = done.stderr.strip().splitlines()
    assert len(lines) == 1 and all(word in lines[0] for word in words), done.stderr


def test_a_mixed_list_is_refused_by_our_reader_naming_the_key(tmp_path):
    path = tmp_path / 'mixed.yaml'
    path.write_text(section('cork:\n  position: [1, 0.5, 2]'))
    with pytest.raises(InvalidInput, match=r'mixed.yaml: cork.position: a list mixing '
                                           r'integers and decimals'):
        read_params_document(path)
