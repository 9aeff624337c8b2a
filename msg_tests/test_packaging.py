"""What a user installs: package.xml depends on every package the code imports, setup.py's
install_requires covers the core's imports, the requirements files split into running and
testing, each refusal for a missing library names its pinned install command, the LICENSE;
and `pip install` of this checkout into a fresh venv gives a core that runs and a pytest
plugin a user's own test file can use."""
import ast
import os
from pathlib import Path
import re
import shutil
import subprocess
import sys
import textwrap
import time
import xml.etree.ElementTree as ElementTree

import pytest

import pool_sim.testing
from pool_sim import picture
from pool_sim.physics import cuda
from pool_sim.ros import foxglove_view, mcap_file

REPO = Path(__file__).resolve().parents[1]
PACKAGE = REPO / 'pool_sim'
# Imported top-level modules that are ROS packages: their rosdep key is their own name.
ROS_PACKAGES = {'rclpy', 'builtin_interfaces', 'std_msgs', 'geometry_msgs', 'nav_msgs',
                'visualization_msgs', 'std_srvs', 'rcl_interfaces', 'rosgraph_msgs',
                'ament_index_python'}
# The other imported modules, by their rosdep key (the -pip keys: from PyPI).
ROSDEP_KEYS = {'numpy': 'python3-numpy', 'yaml': 'python3-yaml', 'numba': 'python3-numba',
               'mcap': 'python3-mcap-pip', 'foxglove': 'python3-foxglove-sdk-pip',
               'matplotlib': 'python3-matplotlib', 'pytest': 'python3-pytest',
               'hypothesis': 'python3-hypothesis', 'scipy': 'python3-scipy',
               'PIL': 'python3-pil', 'mcap_ros2': 'python3-mcap-ros2-support-pip',
               'rosbags': 'python3-rosbags-pip', 'websockets': 'python3-websockets',
               'packaging': 'python3-packaging'}
# The core's imported modules by their distribution's name on PyPI.
DISTRIBUTIONS = {'numpy': 'numpy', 'numba': 'numba', 'yaml': 'PyYAML'}
# Imported only on a machine with a GPU, by the collision pass there (physics/cuda/
# device_detect.py: CuPy's sorts), and only for `backend: cuda` with collisions, which is
# refused with the install command where CuPy is missing. Not in the cuda extra: an extra's
# every line is pinned by requirements-test.txt, which a machine without a GPU installs.
GPU_ONLY = {'cupy'}
# Modules of this repository that tests import as top-level names (msg_tests/, scripts/).
LOCAL_MODULES = {path.stem for folder in ('msg_tests', 'scripts', 'benchmarks')
                 for path in (REPO / folder).glob('*.py')} | {'pool_sim', 'benchmarks', 'scripts'}


def imports(path, module_level_only=False):
    """Full names of the modules `path` imports absolutely (relative imports are ours)."""
    tree = ast.parse(path.read_text())
    for node in (tree.body if module_level_only else ast.walk(tree)):
        if isinstance(node, ast.Import):
            yield from (alias.name for alias in node.names)
        elif isinstance(node, ast.ImportFrom) and node.level == 0:
            yield node.module


def third_party(names):
    """The top-level modules among `names` that are neither the standard library's nor ours."""
    tops = {name.split('.')[0] for name in names}
    return tops - set(sys.stdlib_module_names) - LOCAL_MODULES


def imports_of_tests(paths):
    """Every module the tests import, with the benchmark modules they import and theirs."""
    seen, todo, found = set(), list(paths), set()
    while todo:
        path = todo.pop()
        if path in seen:
            continue
        seen.add(path)
        for name in imports(path):
            found.add(name)
            if name.startswith('benchmarks.'):
                todo.append(REPO / (name.replace('.', '/') + '.py'))
    return found


def depends(*tags):
    root = ElementTree.parse(REPO / 'package.xml').getroot()
    return {element.text.strip() for tag in tags for element in root.iter(tag)}


def rosdep_keys(modules):
    modules = modules - GPU_ONLY
    unknown = sorted(modules - ROS_PACKAGES - set(ROSDEP_KEYS))
    assert not unknown, f'no rosdep key known for {unknown}: add them to ROSDEP_KEYS'
    return {module: ROSDEP_KEYS.get(module, module) for module in modules}


def test_package_xml_runs_with_every_package_pool_sim_imports():
    modules = third_party(name for path in PACKAGE.rglob('*.py') for name in imports(path))
    assert {'rclpy', 'numpy', 'numba', 'yaml', 'mcap', 'foxglove'} <= modules  # it looks
    # pytest loads pool_sim.testing as its plugin: it is there whenever that module is.
    needed = rosdep_keys(modules - {'pytest'})
    missing = {module: key for module, key in needed.items()
               if key not in depends('exec_depend', 'depend')}
    assert not missing, f'package.xml lacks <exec_depend> for {missing}'
    assert 'python3-pytest' in depends('test_depend', 'depend')


def test_package_xml_tests_with_every_package_the_tests_import():
    modules = third_party(imports_of_tests(sorted((REPO / 'msg_tests').glob('*.py'))))
    assert {'hypothesis', 'scipy', 'rosbags', 'websockets'} <= modules
    missing = {module: key for module, key in rosdep_keys(modules).items()
               if key not in depends('exec_depend', 'test_depend', 'depend')}
    assert not missing, f'package.xml lacks <test_depend> for {missing}'


def setup_keyword(name):
    """A keyword argument of setup() in setup.py, as the literal it is written as."""
    for node in ast.walk(ast.parse((REPO / 'setup.py').read_text())):
        if isinstance(node, ast.keyword) and node.arg == name:
            return ast.literal_eval(node.value)
    raise AssertionError(f'setup.py sets no {name}')


def requirement_name(line):
    return re.split(r'[=<>!~;\[ ]', line, maxsplit=1)[0].lower().replace('_', '-')


def test_only_the_gpu_backend_imports_what_only_a_gpu_machine_has():
    importers = {path.relative_to(REPO).as_posix()
                 for path in [*PACKAGE.rglob('*.py'), *(REPO / 'msg_tests').glob('*.py')]
                 if third_party(imports(path)) & GPU_ONLY}
    assert importers == {'pool_sim/physics/cuda/device_detect.py',
                         'msg_tests/test_cuda_collisions.py'}


def test_install_requires_covers_what_the_core_and_the_plugin_import():
    modules = third_party(name for path in (PACKAGE / 'physics').rglob('*.py')
                          for name in imports(path))
    # The plugin imports the ROS side only once a test asks for a simulator; pytest loads it.
    modules |= third_party(imports(Path(pool_sim.testing.__file__), module_level_only=True))
    modules -= {'pytest'} | GPU_ONLY
    assert modules == set(DISTRIBUTIONS), f'map these to a distribution: {modules}'
    declared = {requirement_name(line) for line in setup_keyword('install_requires')}
    missing = {DISTRIBUTIONS[module] for module in modules
               if DISTRIBUTIONS[module].lower() not in declared}
    assert not missing, f'setup.py install_requires lacks {missing}'


def pins(file_name):
    """{name: 'name==version'} of a requirements file's own lines."""
    lines = [line.split('#')[0].strip() for line in (REPO / file_name).read_text().splitlines()]
    return {requirement_name(line): line for line in lines if line and not line.startswith('-')}


def test_requirements_split_into_running_and_testing():
    run, test = pins('requirements.txt'), pins('requirements-test.txt')
    assert (REPO / 'requirements-test.txt').read_text().count('-r requirements.txt\n') == 1
    assert not set(run) & set(test), 'pinned in both files'
    assert {'ros-jazzy-rclpy', 'numpy', 'pyyaml', 'numba', 'mcap', 'foxglove-sdk'} <= set(run)
    assert not {'pytest', 'hypothesis', 'scipy', 'matplotlib', 'mujoco'} & set(run)
    assert all('==' in line for line in [*run.values(), *test.values()]), 'pin each'
    # install_requires and the extras admit the pinned versions the tests run.
    from packaging.requirements import Requirement
    declared = setup_keyword('install_requires') + [
        line for extra in setup_keyword('extras_require').values() for line in extra]
    for line in declared:
        requirement = Requirement(line)
        pinned = {**run, **test}[requirement_name(line)]
        assert requirement.specifier.contains(pinned.split('==')[1]), (line, pinned)


def test_each_refusal_for_a_missing_library_names_its_pinned_install_command():
    everything = {**pins('requirements.txt'), **pins('requirements-test.txt')}
    for command, name in ((mcap_file.INSTALL, 'mcap'),
                          (foxglove_view.INSTALL_COMMAND, 'foxglove-sdk'),
                          (picture.INSTALL_COMMAND, 'matplotlib'),
                          (cuda.INSTALL_COMMAND, 'numba-cuda')):
        assert command == f'pip install {everything[name]}'
    extras = setup_keyword('extras_require')
    assert {requirement_name(line) for lines in extras.values() for line in lines} == {
        'mcap', 'foxglove-sdk', 'matplotlib', 'numba-cuda'}


def test_the_license_is_the_apache_2_0_text_package_xml_and_setup_py_name():
    text = (REPO / 'LICENSE').read_text()
    assert text.split()[:4] == ['Apache', 'License', 'Version', '2.0,']
    assert 'END OF TERMS AND CONDITIONS' in text and len(text.splitlines()) == 202
    assert depends('license') == {'Apache-2.0'} == {setup_keyword('license')}
    assert setup_keyword('license_files') == ['LICENSE']


# What a user installs beside `pip install <checkout>`: the ROS 2 wheels the core and the
# plugin load (PyPI's ROS names differ from a ROS install's, so setup.py cannot ask for them)
# and pytest. Pinned as in the requirements files.
USER_INSTALLS = ('ros-jazzy-rclpy', 'ros-jazzy-common-interfaces', 'ros-rmw-fastrtps-cpp',
                 'pytest')
CORE_RUN = ('from pool_sim.physics import Scene, Simulation; import pool_sim; '
            'print(pool_sim.__file__); s = Simulation(Scene.default()); s.advance(1.0); '
            'print(s.spheres.position)')
# Set by dev.sh for this checkout's own venv; a fresh venv must do without them.
DEV_ENVIRONMENT = ('PYTHONPATH', 'LD_LIBRARY_PATH', '_ROS_WHEELS_BOOTSTRAP_COMPLETE',
                   'AMENT_PREFIX_PATH', 'VIRTUAL_ENV', 'PYTEST_ADDOPTS', 'PYTEST_PLUGINS')


def plugin_example() -> str:
    """The user's test file in pool_sim.testing's docstring (after 'fixture::')."""
    text = pool_sim.testing.__doc__
    start = text.index('fixture::\n') + len('fixture::\n')
    return textwrap.dedent(text[start:text.index('\n\n`pool_sim(', start)])


def checkout_copy(destination):
    """This checkout's files as git sees them (tracked, and new ones it does not ignore):
    what a clone of it would hold, without .venv, build outputs or caches."""
    listed = subprocess.run(['git', 'ls-files', '-z', '--cached', '--others',
                             '--exclude-standard'], cwd=REPO, capture_output=True, timeout=60)
    assert listed.returncode == 0, f'not a git checkout: {listed.stderr.decode()}'
    for name in filter(None, listed.stdout.decode().split('\0')):
        source = REPO / name
        if source.is_file():  # a file deleted but not yet committed is left out
            (destination / name).parent.mkdir(parents=True, exist_ok=True)
            shutil.copy2(source, destination / name)
    return destination


def run_or_fail(what, command, **kwargs):
    started = time.monotonic()
    done = subprocess.run(command, capture_output=True, text=True, **kwargs)
    assert done.returncode == 0, (
        f'{what} failed (exit {done.returncode}; pip installs from the index pip is '
        f'configured with: `pip config list`):\n{done.stdout[-3000:]}\n{done.stderr[-3000:]}')
    print(f'{what}: {time.monotonic() - started:.1f} s')
    return done


@pytest.fixture(scope='module')
def fresh_venv(tmp_path_factory):
    """A venv made with `python -m venv`, the user's installs and `pip install <checkout>`;
    returns (its python, the environment to run it in, a folder outside the checkout)."""
    root = tmp_path_factory.mktemp('fresh')
    venv, user = root / 'venv', root / 'user'
    user.mkdir()
    run_or_fail('python -m venv', [sys.executable, '-m', 'venv', str(venv)], timeout=120)
    python = venv / 'bin' / 'python'
    env = {name: value for name, value in os.environ.items() if name not in DEV_ENVIRONMENT}
    # ament_index_python finds the message packages through it; the wheels do not set it.
    env['AMENT_PREFIX_PATH'] = str(venv)
    pinned = {**pins('requirements.txt'), **pins('requirements-test.txt')}
    pip = [str(python), '-m', 'pip', 'install', '--quiet', '--disable-pip-version-check']
    run_or_fail('pip install the ROS wheels and pytest',
                pip + [pinned[name] for name in USER_INSTALLS], env=env, timeout=600)
    run_or_fail('pip install <checkout>', pip + [str(checkout_copy(root / 'checkout'))],
                env=env, timeout=600)
    return python, env, user


def test_pip_install_gives_a_core_that_runs(fresh_venv):
    python, env, user = fresh_venv
    done = run_or_fail('the core', [str(python), '-c', CORE_RUN], cwd=user, env=env,
                       timeout=300)
    installed_at, *position = done.stdout.splitlines()
    assert installed_at.startswith(str(python.parents[1])), installed_at  # not this checkout
    assert len(position) == 3 and 'nan' not in done.stdout, done.stdout
    # data_files land in the venv as in a colcon install: AMENT_PREFIX_PATH finds them.
    share = python.parents[1] / 'share'
    assert (share / 'pool_sim' / 'LICENSE').is_file()
    assert (share / 'ament_index' / 'resource_index' / 'packages' / 'pool_sim').is_file()


def test_pip_install_gives_the_headless_executable(fresh_venv):
    python, env, user = fresh_venv
    done = run_or_fail('pool_sim_headless', [str(python.with_name('pool_sim_headless')),
                                             '--seconds', '1'], cwd=user, env=env, timeout=300)
    assert done.stdout.splitlines()[-1].split()[0] == '1.00', done.stdout


def test_pip_install_gives_the_pytest_plugin_to_a_users_own_test(fresh_venv):
    python, env, user = fresh_venv
    (user / 'test_keeper.py').write_text(plugin_example())
    done = run_or_fail('a user\'s test with the pool_sim fixture',
                       [str(python), '-m', 'pytest', '-q', '-p', 'no:cacheprovider',
                        'test_keeper.py'], cwd=user, env=env, timeout=300)
    assert '1 passed' in done.stdout, done.stdout
