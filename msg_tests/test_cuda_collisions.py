"""The soft step's solve stage on the GPU (physics/cuda/contact_kernels.py and
device_solve.py) without a GPU: its kernels compile to PTX for compute capability 9.0, and
in numba's CUDA simulator both ways of launching them leave the rows and velocities the
CPU's substeps and restitution pass leave, bit for bit."""
import subprocess
import sys
import types
from unittest import mock

from hypothesis import given, settings, strategies as st
import numba
import numpy as np
import pytest

from cuda_solve_session import OUTPUTS, cpu_solve, read_cases, write_cases
from pool_sim.physics.contacts.colouring import COLOURS
from pool_sim.physics.contacts.layers import sweep_waves
from pool_sim.physics.contacts.soft_step import hold_up, may_land
from pool_sim.physics.cuda import load_cuda, simulated
from test_cuda_backend import ROOT, simulator_environment

REAL, WHOLE, FLAG = np.zeros(2), np.zeros(2, np.int64), np.zeros(2, np.bool_)
ROWS, PAIRS, BODIES = np.zeros((2, 16)), np.zeros((2, 2), np.int64), np.zeros((2, 4))
SCALARS = (0.5, 800.0, 0.1, 0.5)
# Arguments of each kernel's types, for compile_ptx (contact_kernels' docstrings).
SAMPLES = {
    'contacts_kernel': (0, ROWS, PAIRS, BODIES, BODIES, REAL, FLAG, 0, 1, False, True, True,
                        SCALARS),
    'members_kernel': (False, BODIES, BODIES, BODIES, 0.1),
    'fastest_kernel': (BODIES, REAL, 0),
    'support_kernel': (2, PAIRS, BODIES, WHOLE, REAL, BODIES, BODIES, 1.0, 1.0, FLAG, REAL, 0,
                       0, 1),
    'substeps_kernel': (ROWS, PAIRS, BODIES, BODIES, BODIES, REAL, FLAG, WHOLE, 0, PAIRS,
                        BODIES, WHOLE, WHOLE, REAL, FLAG, REAL, 4, 0.1, SCALARS),
}


@pytest.mark.skipif(simulated(), reason='the simulator has no compiler')
@pytest.mark.parametrize('name', sorted(SAMPLES))
def test_every_contact_kernel_compiles_to_ptx_for_compute_capability_9(name):
    # As test_cuda_backend.ptx_of: the current device's compute capability is asked for
    # while an @njit function a kernel calls compiles; answered with 9.0.
    cuda = load_cuda()
    from numba.cuda import dispatcher
    from pool_sim.physics.cuda import contact_kernels
    kernel = getattr(contact_kernels, name)
    signature = tuple(numba.typeof(value) for value in SAMPLES[name])
    hopper = types.SimpleNamespace(compute_capability=(9, 0))
    with mock.patch.object(dispatcher, 'get_current_device', lambda: hopper):
        ptx, _ = cuda.compile_ptx(kernel, signature, cc=(9, 0))
    assert '.target sm_90' in ptx and '.entry' in ptx and '.const' not in ptx
    if name in ('fastest_kernel', 'substeps_kernel'):
        assert 'atom' in ptx  # the maximum speed: the only atomic, and a maximum
    else:
        assert 'atom' not in ptx  # a colour's contacts share no sphere: no atomics


@pytest.fixture(scope='module')
def solved(tmp_path_factory):
    """(the cases, what DeviceSolve left in each mode, in the simulator)."""
    folder = tmp_path_factory.mktemp('cuda_solve')
    write_cases(folder / 'cases.npz')
    child = subprocess.run([sys.executable, '-m', 'cuda_solve_session',
                            str(folder / 'cases.npz'), str(folder / 'out.npz')],
                           cwd=ROOT / 'msg_tests', env=simulator_environment(),
                           capture_output=True, text=True, timeout=300)
    assert child.returncode == 0, child.stderr[-4000:]
    with np.load(folder / 'out.npz') as kept:
        return read_cases(folder / 'cases.npz'), dict(kept)


@pytest.mark.parametrize('mode', ['launches', 'cooperative'])
@pytest.mark.parametrize('label', ['landing', 'rest', 'serial'])
def test_the_gpu_solve_leaves_what_the_cpu_solve_leaves_bit_for_bit(solved, label, mode):
    chosen, on_gpu = solved
    for name, value in zip(OUTPUTS, cpu_solve(chosen[label])):
        gpu = on_gpu[f'{label}.{mode}.{name}']
        assert gpu.shape == value.shape and np.all(np.isfinite(gpu)), name
        assert np.array_equal(gpu, value), (name, float(np.max(np.abs(gpu - value))))


def test_the_cases_exercise_what_they_claim(solved):
    chosen, _ = solved
    landing, rest, serial = chosen['landing'], chosen['rest'], chosen['serial']
    for case in (landing, rest):
        colours = np.flatnonzero(np.diff(case['colour_start']))
        assert colours.size >= 3 and colours[-1] < COLOURS - 1  # several, none lumped
        assert np.any(case['solve_order'][:, 1] == case['velocity'].shape[0] - 1)  # faces
    # Landing: spheres fast enough for the support sweep, contacts that bounce, and the
    # solve changes the velocities by more than a substep's gravity.
    fastest = np.max(np.sum(landing['velocity'][:-1, :3] ** 2, axis=1))
    assert may_land(fastest, float(landing['threshold'])) and landing['bounces'].sum() >= 1
    assert landing['ends'].shape[0] >= 5 and landing['floor_member'].size >= 3
    _, velocity, _ = cpu_solve(landing)
    assert np.max(np.abs(velocity - landing['velocity'])) > 0.05
    # The support sweep acts (without it the velocities differ), over more than one wave.
    unsupported = {**landing, 'ends': landing['ends'][:0], 'facts': landing['facts'][:0],
                   'floor_member': landing['floor_member'][:0],
                   'floor_gap': landing['floor_gap'][:0]}
    assert np.max(np.abs(cpu_solve(unsupported)[1] - velocity)) > 0.05
    _, waves = sweep_waves(landing['ends'], landing['velocity'].shape[0] - 1)
    assert waves.size >= 3
    # At rest: nothing bounces, nothing is fast enough for the sweep.
    fastest = np.max(np.sum(rest['velocity'][:-1, :3] ** 2, axis=1))
    assert rest['bounces'].sum() == 0 and not may_land(fastest, float(rest['threshold']))
    # The serial case is the landing with every contact in the last colour.
    assert np.flatnonzero(np.diff(serial['colour_start'])).tolist() == [COLOURS - 1]


def test_colour_bounds_keep_the_non_empty_colours_and_name_the_serial_one():
    from pool_sim.physics.cuda.device_solve import colour_bounds
    start = np.zeros(COLOURS + 1, dtype=np.int64)
    start[2:] = 3  # colour 1: slots 0..2
    start[5:] = 7  # colour 4: slots 3..6
    bounds, serial = colour_bounds(start)
    assert bounds.tolist() == [0, 3, 7] and serial == -1
    start[COLOURS] = 9  # the last colour: slots 7, 8
    bounds, serial = colour_bounds(start)
    assert bounds.tolist() == [0, 3, 7, 9] and serial == 2
    bounds, serial = colour_bounds(np.zeros(COLOURS + 1, dtype=np.int64))
    assert bounds.tolist() == [0] and serial == -1  # no contacts: no launches


@pytest.mark.parametrize('mode', ['jacobi', '', None, 'Cooperative'])
def test_an_unknown_launch_mode_is_refused(mode):
    from pool_sim.physics.cuda.device_solve import DeviceSolve
    with pytest.raises(ValueError, match='mode must be one of'):
        DeviceSolve(mode)



@settings(deadline=None)  # the first example compiles hold_up
@given(st.integers(2, 12), st.integers(0, 40), st.integers(0, 2**32 - 1))
def test_the_support_sweep_wave_by_wave_is_the_serial_sweep_to_the_bit(members, found, seed):
    # Any sweep order: contacts between random spheres (some chained, some sharing an
    # upper or a lower sphere), random normals that bear weight, gaps, velocities, moves
    # and floor contacts; fast enough that approaches stop.
    rng = np.random.default_rng(seed)
    ends = np.empty((found, 2), dtype=np.int64)
    ends[:, 0] = rng.integers(0, members, found)
    ends[:, 1] = (ends[:, 0] + rng.integers(1, members, found)) % members  # not the upper
    normal = rng.normal(size=(found, 3))
    normal[:, 2] = np.abs(normal[:, 2]) + 0.5
    facts = np.column_stack([normal / np.linalg.norm(normal, axis=1)[:, None],
                             rng.uniform(-1e-3, 1e-3, found)])
    floor_member = rng.permutation(members)[:rng.integers(0, members + 1)]
    floor_gap = rng.uniform(-1e-3, 1e-3, floor_member.size)
    velocity = np.zeros((members + 1, 4))
    velocity[:members, :3] = rng.normal(0.0, 2.0, (members, 3))
    moved = np.zeros((members + 1, 4))
    moved[:members, :3] = rng.normal(0.0, 1e-3, (members, 3))
    order, bounds = sweep_waves(ends, members)
    assert sorted(order.tolist()) == list(range(found)) and bounds[-1] == found
    for w in range(bounds.size - 1):  # within a wave, a written sphere is touched once
        wave = ends[order[bounds[w]:bounds[w + 1]]]
        written, touched = wave[:, 0].tolist(), wave.ravel().tolist()
        assert all(touched.count(k) == 1 for k in written)
        assert list(order[bounds[w]:bounds[w + 1]]) == sorted(order[bounds[w]:bounds[w + 1]])
    left = []
    for chosen in (np.arange(found), order):
        v, supported = velocity.copy(), np.zeros(members, dtype=np.bool_)
        hold_up(ends[chosen], facts[chosen], floor_member, floor_gap, v, moved, 200.0, 0.05,
                supported)
        left.append((v, supported))
    assert np.array_equal(left[0][0], left[1][0]) and np.array_equal(left[0][1], left[1][1])


def test_no_contacts_make_no_waves():
    order, bounds = sweep_waves(np.empty((0, 2), dtype=np.int64), 5)
    assert order.size == 0 and bounds.tolist() == [0]
