"""`backend: cuda` without a GPU: the kernels compile to PTX for an H100/H200 (compute
capability 9.0), run in numba's CUDA simulator and agree with the CPU backend through every
kind of change the node makes, and a scene asking for a GPU where there is none is refused
with the reason."""
import os
import pathlib
import subprocess
import sys
import types
from unittest import mock

import numpy as np
import pytest

from cuda_session import CASES, COLLIDING, colliding_session, scene, sessions
from pool_sim.physics import InvalidInput, Scene, Simulation
from pool_sim.physics.cuda import load_cuda, simulated, unavailable
from pool_sim.physics.effects import DEFAULT_EFFECTS, effect_flags
from pool_sim.physics.integrators import INTEGRATORS
from pool_sim.physics.stepper import INTEGRATOR_CODES

ROOT = pathlib.Path(__file__).resolve().parents[1]


def ptx_of(integrator, effects, has_contact=True, has_friction=True):
    """The PTX of one configuration's kernel for compute capability 9.0, compiled here,
    where no GPU is. numba-cuda asks the current device for its compute capability when it
    compiles an @njit function a kernel calls (dispatcher.compile_device), even when
    compile_ptx was told the target: that question is answered with 9.0 while compiling."""
    cuda = load_cuda()
    from numba.core import types as nb
    from numba.cuda import dispatcher
    from pool_sim.physics.cuda.kernels import advance_source
    vector, matrix = nb.Array(nb.float64, 1, 'C'), nb.Array(nb.float64, 2, 'C')
    properties = nb.Tuple((vector,) * 7 + (matrix, matrix, vector, vector))
    signature = (matrix, matrix, properties, vector, nb.Array(nb.float64, 3, 'C'), vector,
                 vector, nb.Array(nb.uint8, 1, 'C'), nb.Array(nb.int64, 1, 'C'), nb.int64,
                 nb.float64)
    source = advance_source(INTEGRATOR_CODES[integrator],
                            effect_flags(effects, 'cap', scalar=True), has_contact,
                            has_friction)
    hopper = types.SimpleNamespace(compute_capability=(9, 0))
    with mock.patch.object(dispatcher, 'get_current_device', lambda: hopper):
        ptx, _ = cuda.compile_ptx(source, signature, cc=(9, 0))
    return ptx


@pytest.mark.skipif(simulated(), reason='the simulator has no compiler')
@pytest.mark.parametrize('integrator', INTEGRATORS)
def test_every_integrator_with_the_default_effects_compiles_to_ptx_for_compute_capability_9(
        integrator):
    ptx = ptx_of(integrator, DEFAULT_EFFECTS)
    assert '.target sm_90' in ptx
    assert '.entry' in ptx
    # The wave table is an argument: a module constant would be embedded in the 64 kB of
    # constant memory, which ptxas refuses past its size (0x3b190 bytes, measured).
    assert '.const' not in ptx


@pytest.mark.skipif(simulated(), reason='the simulator has no compiler')
@pytest.mark.parametrize('which', ['smooth', 'faces'])
def test_the_colliding_step_s_kernels_compile_to_ptx_for_compute_capability_9(which):
    # With collisions a step is the smooth kernel, the collision pass (test_cuda_collisions)
    # and the faces' kernel: those two, for the default effects.
    cuda = load_cuda()
    from numba.core import types as nb
    from numba.cuda import dispatcher
    from pool_sim.physics.cuda.kernels import faces_source, smooth_source
    vector, matrix = nb.Array(nb.float64, 1, 'C'), nb.Array(nb.float64, 2, 'C')
    flags = nb.Array(nb.uint8, 1, 'C')
    properties = nb.Tuple((vector,) * 7 + (matrix, matrix, vector, vector))
    world = (properties, vector, nb.Array(nb.float64, 3, 'C'), vector)
    listed = effect_flags(DEFAULT_EFFECTS, 'cap', scalar=True)
    if which == 'smooth':
        source = smooth_source(INTEGRATOR_CODES['linearly_implicit_euler'], listed, True)
        signature = (matrix,) * 4 + world + (flags, nb.float64)
    else:
        source = faces_source(listed, True, True)
        signature = ((matrix,) * 4 + world
                     + (vector, flags, flags, nb.Array(nb.int64, 1, 'C'), nb.float64))
    hopper = types.SimpleNamespace(compute_capability=(9, 0))
    with mock.patch.object(dispatcher, 'get_current_device', lambda: hopper):
        ptx, _ = cuda.compile_ptx(source, signature, cc=(9, 0))
    assert '.target sm_90' in ptx and '.entry' in ptx and '.const' not in ptx
    assert ('atom' in ptx) == (which == 'faces')  # the guard's integer count only


@pytest.mark.skipif(simulated(), reason='the simulator has no compiler')
def test_every_effect_without_contact_compiles_to_ptx():
    ptx = ptx_of('rk4', ['gravity', 'buoyancy', 'drag', 'lift', 'added_mass',
                         'wave_radiation'], has_contact=False, has_friction=False)
    assert '.target sm_90' in ptx and '.const' not in ptx


def simulator_environment():
    """The environment of a child process that runs `backend: cuda` in numba's CUDA
    simulator. The per-sphere functions run there as Python (NUMBA_DISABLE_JIT): the
    simulator runs a kernel's code as Python, so what the kernel calls must be Python too."""
    return {**os.environ, 'NUMBA_ENABLE_CUDASIM': '1', 'NUMBA_DISABLE_JIT': '1',
            'PYTHONPATH': os.pathsep.join([str(ROOT), str(ROOT / 'msg_tests'),
                                           os.environ.get('PYTHONPATH', '')])}


@pytest.fixture(scope='module')
def simulated_sessions(tmp_path_factory):
    """cuda_session's sessions on `backend: cuda`, in numba's CUDA simulator."""
    return session_in_simulator(tmp_path_factory.mktemp('cuda') / 'sessions.npz')


def session_in_simulator(out, *arguments):
    """What `python -m cuda_session OUT ARGUMENTS...` keeps, run in numba's CUDA simulator
    in a child process (the simulator replaces numba.cuda for the whole process)."""
    child = subprocess.run([sys.executable, '-m', 'cuda_session', str(out), *arguments],
                           cwd=ROOT / 'msg_tests', env=simulator_environment(),
                           capture_output=True, text=True, timeout=300)
    assert child.returncode == 0, child.stderr[-4000:]
    with np.load(out) as kept:
        return dict(kept)


def test_the_simulated_gpu_agrees_with_the_cpu_backend_through_every_change(
        simulated_sessions):
    # Bit for bit: the same functions, the same order of operations (a real GPU fuses
    # multiplies and adds, which the simulator does not: docs/gpu.md).
    assert_the_same(sessions('cpu'), simulated_sessions)


def assert_the_same(on_cpu, on_gpu):
    """Every array a session kept, the same on both backends (and finite), bit for bit."""
    assert sorted(on_cpu) == sorted(on_gpu)
    for label, value in on_cpu.items():
        gpu = on_gpu[label]
        assert gpu.shape == value.shape and np.all(np.isfinite(gpu)), label
        assert np.array_equal(gpu, value), label


def test_the_sessions_exercise_what_they_claim(simulated_sessions):
    # The guard put s7 back (index 7) in each case (and, before it, light spheres that
    # explicit integrators cannot hold at 5 ms).
    for number in range(len(CASES)):
        assert 7 in simulated_sessions[f'{number}.guard.recovered']
        assert simulated_sessions[f'{number}.guard.recoveries'] >= 1
        # Something crossed the surface and something touched a face.
        z = simulated_sessions[f'{number}.one.position'][2]
        assert np.any(np.abs(z) < 0.1)
        # Thrown at the floor and the ceiling (+-4 m) from against them, 0.1 m in radius:
        # bounced back, not through.
        assert -3.9 <= z[0] < -3.85 and 3.85 < z[1] <= 3.9


@pytest.mark.skipif(simulated(), reason='the simulator stands in for a GPU')
def test_a_scene_asking_for_a_gpu_where_there_is_none_is_refused_with_the_reason():
    reason = unavailable()
    assert reason is not None  # this machine has no GPU
    with pytest.raises(InvalidInput, match='backend: cuda cannot run here: no'):
        Simulation(Scene({'sphere_names': ['a'], 'backend': 'cuda'}))


@pytest.mark.parametrize('name', ['colour', '', 'Position', None, 3])
def test_marking_an_array_the_spheres_do_not_have_is_refused(name):
    sim = Simulation(Scene({'sphere_names': ['a']}))
    with pytest.raises(InvalidInput, match='mark_written: the spheres have no array'):
        sim.mark_written('velocity', name)


@pytest.mark.parametrize('keys, reason', [
    ({'contact_solver': 'sequential_impulses'}, 'contact_solver: soft_step only'),
    ({'contact_solver': 'soft_step', 'soft_step.colouring': 'found'},
     'colours contacts by priority only')])
def test_collisions_on_the_gpu_other_than_soft_step_s_by_priority_are_refused(keys, reason):
    with pytest.raises(InvalidInput, match=reason):
        Simulation(Scene({'sphere_names': ['a'], 'backend': 'cuda',
                          'effects': [*DEFAULT_EFFECTS, 'collisions'], **keys}))


@pytest.fixture(scope='module')
def colliding_session_on_gpu(tmp_path_factory):
    """cuda_session's colliding session on `backend: cuda`, in numba's CUDA simulator."""
    return session_in_simulator(tmp_path_factory.mktemp('cuda_colliding') / 'session.npz',
                                'colliding')


def test_colliding_spheres_on_the_simulated_gpu_step_as_on_the_cpu_through_every_change(
        colliding_session_on_gpu):
    # The whole step with collisions (detection, rows, orders, solve, memory, write-back,
    # faces, guard) through set_mass, set_radius, forces, a put-back, a spawn and a remove,
    # a reset: the CPU backend's numbers when it colours as the GPU does.
    assert_the_same(colliding_session('cpu'), colliding_session_on_gpu)


def test_the_colliding_session_exercises_what_it_claims(colliding_session_on_gpu):
    kept = colliding_session_on_gpu
    for label in ('one', 'first', 'changed', 'respawned', 'reset'):
        assert kept[f'{label}.memory_held'].sum() >= 5, label  # contacts, remembered
    assert 7 in kept['guard.recovered']  # the guard put s7 back in a colliding step
    # The crowd on the floor (floor contacts among the pairs' spheres), some on others.
    radius = scene('cpu', *COLLIDING, [f's{i}' for i in range(12)]).build_spheres().radius
    gap = kept['first.position'][2, 3:] - radius[3:] + 4.0
    assert np.sum(gap < 0.002) >= 3 and np.sum(gap > 0.05) >= 2


@pytest.mark.parametrize('backend', ['gpu', 'CUDA', '', 'cuda ', 3, None])
def test_only_the_named_backends_are_taken(backend):
    with pytest.raises(InvalidInput, match='backend'):
        Scene({'sphere_names': ['a'], 'backend': backend})


@pytest.mark.parametrize('colouring', ['Priority', 'found ', '', 'gpu', 1, 0.5, float('nan'),
                                       float('inf'), 1e308, None, [], ['priority']])
def test_only_the_named_colourings_are_taken(colouring):
    with pytest.raises(InvalidInput, match='soft_step.colouring'):
        Scene({'sphere_names': ['a'], 'soft_step.colouring': colouring})


@pytest.mark.parametrize('colouring, backend, expected', [
    ('auto', 'cpu', 0.0), ('found', 'cpu', 0.0), ('priority', 'cpu', 1.0),
    ('auto', 'cuda', 1.0), ('priority', 'cuda', 1.0)])
def test_each_colouring_reaches_the_solver_s_settings(colouring, backend, expected):
    # The fifth solver setting (stepper.scene_constants) is what soft_step colours by.
    from pool_sim.physics.stepper import scene_constants
    settings = scene_constants(Scene({'sphere_names': ['a'], 'backend': backend,
                                      'soft_step.colouring': colouring}))[-1]
    assert settings.shape == (5,) and settings[4] == expected


def test_the_node_on_the_simulated_gpu_runs_a_closed_loop_as_on_the_cpu(tmp_path):
    # Through the node's own wiring: lockstep, odometry to the depth keeper, its forces
    # back, set_mass and set_radius services, a reset; each publish reads the GPU's state.
    from cuda_node import drive
    out = tmp_path / 'node.npz'
    child = subprocess.run([sys.executable, '-m', 'cuda_node', str(out)],
                           cwd=ROOT / 'msg_tests', env=simulator_environment(),
                           capture_output=True, text=True, timeout=300)
    assert child.returncode == 0, child.stderr[-4000:]
    on_cpu = drive('cpu')
    with np.load(out) as on_gpu:
        assert sorted(on_gpu.files) == sorted(on_cpu)
        for label, value in on_cpu.items():
            assert np.array_equal(on_gpu[label], value), label
    assert on_cpu['answers'].all()
    assert abs(on_cpu['changed'][2, 2] + 1.0) < 0.1  # the keeper holds ice near 1 m


HELD_ARRAYS = """
import numpy as np
from pool_sim.physics import Scene, Simulation
sim = Simulation(Scene({'sphere_names': ['a', 'b'], 'backend': 'cuda'}))
held = sim.spheres.velocity
sim.run(2, 0.005)
try:
    held[2, 0] = 0.0  # held from before the step: stale, so refused
    raise SystemExit('a write into a stale array went through')
except ValueError:
    pass
sim.spheres.velocity[2, 0] = 0.0  # read afresh: writable
sim.mark_written('velocity')
sim.run(1, 0.005)
sim.change_spheres(Scene({'sphere_names': ['a'], 'backend': 'cuda'}).with_values(
    sphere_names=[]))
sim.run(3, 0.005)
assert sim.spheres.count == 0 and sim.time > 0.0
print('ok')
"""


def test_arrays_held_from_before_a_step_on_the_gpu_refuse_writes_and_no_spheres_step():
    child = subprocess.run([sys.executable, '-c', HELD_ARRAYS], cwd=ROOT,
                           env=simulator_environment(), capture_output=True, text=True,
                           timeout=120)
    assert child.returncode == 0, child.stderr[-4000:]
    assert child.stdout.strip().endswith('ok')


def test_the_gpu_benchmark_runs_in_the_simulator_and_writes_its_tables(tmp_path):
    # benchmarks/gpu.py is run once on a GPU machine, prepared here: kept working here.
    child = subprocess.run(
        [sys.executable, '-m', 'benchmarks.gpu', '--sizes', '16', '40', '--repeats', '1',
         '--launch-spheres', '8', '--agreement-spheres', '12', '--agreement-steps', '4',
         '--solve-sizes', '12', '--solve-repeats', '1', '--colliding-sizes', '12',
         '--colliding-steps', '1', '--settle-s', '0.01', '--out', str(tmp_path)], cwd=ROOT,
        env=simulator_environment(),
        capture_output=True, text=True, timeout=300)
    assert child.returncode == 0, child.stderr[-4000:]
    text = (tmp_path / 'gpu.md').read_text()
    assert 'GPU: numba CUDA simulator.' in text
    assert '| 40 |' in text and 'a configuration made once' in text
    assert 'largest difference 0 m in position, 0 m/s in velocity' in text
    rows = (tmp_path / 'gpu.csv').read_text().splitlines()
    assert len(rows) == 3 and rows[0].startswith('spheres,one_step_per_launch_ns')
    # The solve stage: both scenes, both modes, the CPU's numbers to the bit (a simulator
    # does not fuse multiplies and adds).
    assert '## Collisions on the GPU: detection and the solve stage' in text
    assert '## Colliding spheres stepped on the GPU' in text
    colliding = (tmp_path / 'gpu_colliding.csv').read_text().splitlines()
    assert len(colliding) == 3 and colliding[1].startswith('at rest,12,')
    header = colliding[0].split(',')
    for line in colliding[1:]:
        row = dict(zip(header, line.split(',')))
        assert float(row['step_ms']) > 0.0 and row['finite'] == 'True'
        assert float(row['settled_s']) >= 0.01 and float(row['rms_speed']) >= 0.0
    solve = (tmp_path / 'gpu_solve.csv').read_text().splitlines()
    assert len(solve) == 3 and solve[1].startswith('at rest,12,') and solve[2].startswith(
        'landing,12,')
    header = solve[0].split(',')
    for line in solve[1:]:
        row = dict(zip(header, line.split(',')))
        assert int(row['contacts']) > 12 and float(row['cooperative_ms']) > 0.0
        assert row['detect_same_pairs'] == 'True' and float(row['detect_normal_gap']) == 0.0
        assert float(row['gpu_detect_ms']) > 0.0 and float(row['cpu_detect_ms']) > 0.0
        assert float(row['gpu_rows_ms']) > 0.0 and float(row['rows_gap']) == 0.0
        assert float(row['gpu_colour_ms']) > 0.0 and float(row['gpu_support_ms']) > 0.0
        assert row['support_same'] == 'True' and int(row['gpu_colours']) >= 2
        assert int(row['colour_rounds']) >= 2 and int(row['wave_rounds']) >= 1
        assert float(row['gpu_pass_ms']) > 0.0 and int(row['pass_put_back']) == 0
        assert all(float(row[f'{mode}_{what}_gap']) == 0.0 for mode in ('launches',
                   'cooperative') for what in ('velocity', 'moved'))
