"""Out of process, as a user runs it: colcon build, find the executable the way `ros2 run`
does (ament index, then lib/<package>/<executable>), start it, talk to it, stop it."""
import os
from pathlib import Path
import signal
import subprocess
import sys
import time

from ament_index_python.packages import get_package_prefix
from geometry_msgs.msg import PoseArray
import pytest
import rclpy
from rclpy.context import Context
from rclpy.executors import SingleThreadedExecutor

REPO = Path(__file__).resolve().parents[1]


@pytest.fixture(scope='module')
def workspace(tmp_path_factory):
    """A colcon install of this checkout; returns the environment a sourced workspace has."""
    root = tmp_path_factory.mktemp('workspace')
    colcon = Path(sys.executable).with_name('colcon')
    build = subprocess.run(
        [str(colcon), '--log-base', str(root / 'log'), 'build', '--base-paths', str(REPO),
         '--packages-select', 'pool_sim', '--build-base', str(root / 'build'),
         '--install-base', str(root / 'install')],
        cwd=root, capture_output=True, text=True, timeout=180)
    assert build.returncode == 0, build.stdout + build.stderr
    prefix = root / 'install' / 'pool_sim'
    site_packages = next(prefix.glob('lib/python3*/site-packages'))
    env = dict(os.environ)
    env['AMENT_PREFIX_PATH'] = os.pathsep.join(
        [str(prefix)] + [p for p in [env.get('AMENT_PREFIX_PATH')] if p])
    # Only the install, not this checkout: the executable must run from what colcon installed.
    env['PYTHONPATH'] = str(site_packages)
    return env


def ros2_run_path(env, package, executable):
    """What `ros2 run` resolves: the package's prefix from the ament index, then lib/<pkg>/."""
    saved = os.environ.get('AMENT_PREFIX_PATH')
    os.environ['AMENT_PREFIX_PATH'] = env['AMENT_PREFIX_PATH']
    try:
        prefix = Path(get_package_prefix(package))
    finally:
        os.environ['AMENT_PREFIX_PATH'] = saved or ''
    path = prefix / 'lib' / package / executable
    assert path.is_file() and os.access(path, os.X_OK), path
    return path


def test_ros2_run_finds_the_executables_the_default_scene_and_the_rviz_config(workspace):
    for executable in ('pool_sim', 'depth_keeper', 'pool_sim_headless'):
        ros2_run_path(workspace, 'pool_sim', executable)
    prefix = Path(workspace['AMENT_PREFIX_PATH'].split(os.pathsep)[0])
    assert (prefix / 'share' / 'pool_sim' / 'LICENSE').is_file()
    assert (prefix / 'share' / 'pool_sim' / 'config' / 'pool.yaml').is_file()
    # The README's `rviz2 -d $(ros2 pkg prefix pool_sim)/share/pool_sim/config/pool_sim.rviz`.
    assert (prefix / 'share' / 'pool_sim' / 'config' / 'pool_sim.rviz').is_file()
    assert (prefix.parent / 'pool_sim' / 'share' / 'ament_index' / 'resource_index' /
            'packages' / 'pool_sim').is_file()


def test_installed_node_publishes_poses_and_exits_cleanly_on_sigint(workspace, tmp_path):
    params = tmp_path / 'params.yaml'
    # Under a namespace, a section named pool_sim means /pool_sim: match any namespace.
    params.write_text('/**/pool_sim:\n  ros__parameters:\n    real_time_factor: 2.0\n'
                      '    frame_id: tank\n')
    namespace = f'/installed{os.getpid()}'
    process = subprocess.Popen(
        [str(ros2_run_path(workspace, 'pool_sim', 'pool_sim')), '--ros-args',
         '--params-file', str(params), '-r', f'__ns:={namespace}'],
        env=workspace, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
    try:
        context = Context()
        rclpy.init(context=context)
        try:
            node = rclpy.create_node('installed_client', context=context)
            executor = SingleThreadedExecutor(context=context)
            executor.add_node(node)
            received = []
            node.create_subscription(PoseArray, f'{namespace}/pool_sim/poses', received.append,
                                     10)
            deadline = time.monotonic() + 30.0
            while len(received) < 5 and time.monotonic() < deadline:
                executor.spin_once(timeout_sec=0.05)
            executor.shutdown()
            node.destroy_node()
        finally:
            rclpy.shutdown(context=context)
        assert len(received) >= 5, 'no poses from the installed node'
        assert received[-1].header.frame_id == 'tank' and len(received[-1].poses) == 3
    finally:
        process.send_signal(signal.SIGINT)
        output, _ = process.communicate(timeout=20)
    assert process.returncode == 0, output
    assert 'Traceback' not in output, output


def test_installed_node_with_a_bad_params_file_exits_non_zero_naming_the_key(workspace,
                                                                            tmp_path):
    params = tmp_path / 'bad.yaml'
    params.write_text('pool_sim:\n  ros__parameters:\n    sphere_names: [buoy]\n'
                      '    buoy:\n      mass: -3.0\n')
    result = subprocess.run(
        [str(ros2_run_path(workspace, 'pool_sim', 'pool_sim')), '--ros-args',
         '--params-file', str(params)],
        env=workspace, capture_output=True, text=True, timeout=30)
    assert result.returncode != 0
    assert 'buoy.mass: must be within' in result.stdout + result.stderr
    assert 'Traceback' not in result.stdout + result.stderr


def readme_example() -> str:
    """The README's example test of depth_keeper (the python block that starts with
    `# test_depth_keeper.py`)."""
    text = (REPO / 'README.md').read_text()
    start = text.index('```python\n# test_depth_keeper.py') + len('```python\n')
    return text[start:text.index('```', start)]


def test_the_readme_example_runs_with_an_installed_pool_sim(workspace, tmp_path):
    # A user's own suite, elsewhere: pytest finds the fixture through the installed entry
    # point (no conftest, nothing of this checkout on the path).
    (tmp_path / 'test_depth_keeper.py').write_text(readme_example())
    result = subprocess.run(
        [sys.executable, '-m', 'pytest', '-q', '-p', 'no:cacheprovider', str(tmp_path)],
        cwd=tmp_path, env=workspace, capture_output=True, text=True, timeout=120)
    assert result.returncode == 0, result.stdout + result.stderr
    assert '1 passed' in result.stdout
