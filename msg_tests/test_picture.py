"""pool_sim.picture and `python -m pool_sim.headless --animate`: the GIF read back with Pillow
(frames, size, delay), each sphere in its marker colour where the simulation has it, and a
bad path refused in one line naming it before any simulating."""
import os
from pathlib import Path
import subprocess
import sys

import numpy as np
import pytest
from PIL import Image

from pool_sim import picture
from pool_sim.physics import Scene
from pool_sim.ros.messages import sphere_colours

REPO = Path(__file__).resolve().parents[1]
ENV = {**os.environ, 'PYTHONPATH': str(REPO)}
# Short and coarse: 11 frames, 200 ms apart (a GIF's delays are whole 1/100 s).
SECONDS, FPS = 2.0, 5.0
COLOUR_TOLERANCE = 12  # of 255: the GIF's palette may round a colour a little


@pytest.fixture(scope='module')
def animation(tmp_path_factory):
    """(path of the GIF of the default pool, its scene, the simulation at its last frame)."""
    path = tmp_path_factory.mktemp('picture') / 'pool.gif'
    scene = Scene.default()
    sim = picture.write_gif(scene, path, SECONDS, FPS)
    return path, scene, sim


def frame_rgb(path, index) -> np.ndarray:
    with Image.open(path) as gif:
        gif.seek(index % gif.n_frames)
        return np.asarray(gif.convert('RGB'), dtype=int)


def test_the_gif_has_a_frame_every_1_over_fps_simulated_seconds_both_ends_drawn(animation):
    path, _, sim = animation
    assert sim.time == pytest.approx(SECONDS)
    with Image.open(path) as gif:
        assert gif.n_frames == round(SECONDS * FPS) + 1 == len(
            picture.frame_times(SECONDS, FPS))
        assert gif.size[0] == picture.WIDTH_PX and 300 < gif.size[1] < 700
        assert gif.info.get('loop') == 0  # plays forever
        for index in range(gif.n_frames):
            gif.seek(index)
            assert gif.info['duration'] == 1000 / FPS, index


def test_each_sphere_is_drawn_in_its_marker_colour_where_the_simulation_has_it(animation):
    path, scene, sim = animation
    first, last = frame_rgb(path, 0), frame_rgb(path, -1)
    count = sim.spheres.count
    view = picture.SideView(scene, count)  # the same figure, so the same projection
    colours = 255 * sphere_colours(count)[:, :3]
    for index, name in enumerate(sim.spheres.names):
        x, _, z = sim.spheres.position[:, index]
        column, row = view.pixel_of(x, z)
        assert np.abs(last[row, column] - colours[index]).max() <= COLOUR_TOLERANCE, name
        # It fell there: at t = 0 the sphere was elsewhere, and the pixel showed another
        # colour (water or air).
        assert np.abs(first[row, column] - colours[index]).max() > 60, name
        column, row = view.pixel_of(*scene[f'{name}.position'][::2])
        assert np.abs(first[row, column] - colours[index]).max() <= COLOUR_TOLERANCE, name


def animate(path, *extra):
    return subprocess.run([sys.executable, '-m', 'pool_sim.headless', '--animate', str(path),
                           '--seconds', '0.2', '--fps', '5', *extra],
                          env=ENV, capture_output=True, text=True, timeout=60)


def assert_refused_naming(done, path, *words):
    assert done.returncode == 1 and 'Traceback' not in done.stderr, done.stderr
    lines = done.stderr.strip().splitlines()
    assert len(lines) == 1 and str(path) in lines[0], done.stderr
    assert all(word in lines[0] for word in words), done.stderr
    assert not done.stdout  # refused before simulating: nothing written, nothing said


def test_the_cli_writes_the_gif_it_names(tmp_path):
    path = tmp_path / 'pool.gif'
    done = animate(path)
    assert done.returncode == 0, done.stderr
    assert str(path) in done.stdout
    with Image.open(path) as gif:
        assert gif.n_frames == 2


@pytest.mark.parametrize('name, words', [('pool.png', ['must end in .gif']),
                                         ('pool', ['must end in .gif']),
                                         ('missing/pool.gif', ['no folder'])])
def test_a_path_that_is_not_a_gif_in_a_folder_is_refused(tmp_path, name, words):
    path = tmp_path / name
    assert_refused_naming(animate(path), path, *words)
    assert not path.exists()


@pytest.mark.skipif(os.geteuid() == 0, reason='root writes through a chmod')
def test_a_folder_without_write_permission_is_refused(tmp_path):
    folder = tmp_path / 'locked'
    folder.mkdir()
    folder.chmod(0o500)
    try:
        path = folder / 'pool.gif'
        assert_refused_naming(animate(path), path, 'cannot write')
    finally:
        folder.chmod(0o700)


@pytest.mark.skipif(not Path('/sys/kernel').is_dir(), reason='needs Linux sysfs')
def test_a_folder_even_root_cannot_write_is_refused():
    path = Path('/sys/pool_sim.gif')  # sysfs: no new files, whoever asks
    assert_refused_naming(animate(path), path, 'cannot write')


@pytest.mark.parametrize('extra, words', [(['--fps', '0'], ['--fps', '> 0']),
                                          (['--seconds', 'nan'], ['--seconds'])])
def test_a_bad_rate_or_duration_is_refused(tmp_path, extra, words):
    done = animate(tmp_path / 'pool.gif', *extra)
    assert done.returncode == 1 and 'Traceback' not in done.stderr, done.stderr
    assert all(word in done.stderr for word in words), done.stderr
    assert not (tmp_path / 'pool.gif').exists()


def test_without_matplotlib_animate_is_refused_in_one_line_naming_the_install(tmp_path):
    path = tmp_path / 'pool.gif'
    # None in sys.modules: `import matplotlib` fails as it does where it is not installed.
    hide_matplotlib = ("import sys; sys.modules['matplotlib'] = None; "
                       "from pool_sim.headless import main; sys.exit(main(sys.argv[1:]))")
    done = subprocess.run([sys.executable, '-c', hide_matplotlib, '--animate', str(path)],
                          env=ENV, capture_output=True, text=True, timeout=60)
    assert done.returncode == 1 and 'Traceback' not in done.stderr, done.stderr
    lines = done.stderr.strip().splitlines()
    assert len(lines) == 1 and picture.INSTALL_COMMAND in lines[0], done.stderr
    assert 'pip install matplotlib==3.11.2' in lines[0]
    assert not done.stdout and not path.exists()
