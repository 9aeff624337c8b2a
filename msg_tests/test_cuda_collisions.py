"""Collisions on the GPU without a GPU: the soft step's solve stage (physics/cuda/
contact_kernels.py, device_solve.py), contact detection (detect_kernels.py,
device_detect.py), the rows (rows_kernels.py, device_rows.py) and the sweep's orders
(order_kernels.py, device_order.py). Their kernels compile to PTX for compute capability
9.0; in numba's CUDA simulator both ways of launching the solve leave the rows and
velocities the CPU's substeps and restitution pass leave, detection finds the CPU's
contacts, the rows are the CPU's, and the orders are the CPU functions', bit for bit."""
import importlib
import importlib.util
import subprocess
import sys
import types
from unittest import mock

from hypothesis import given, settings, strategies as st
import numba
import numpy as np
import pytest

from cuda_solve_session import cpu_detect, cpu_orders, cpu_resolve, cpu_solve, \
    ends_and_ground, OUTPUTS, read_cases, resolve_inputs, ROWS_FILLED, THREAD_ORDERS, \
    write_cases
from pool_sim.physics.contacts.colouring import colour_by_priority, colour_priority, COLOURS
from pool_sim.physics.contacts.detection import _bounding_spheres, END_VELOCITY, RADIUS, \
    START_VELOCITY
from pool_sim.physics.contacts.soft_contact import NORMAL
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

AXES, AXES_WHOLE = np.zeros((3, 2)), np.zeros((3, 2), np.int64)
LEVELS, LEVELS_WHOLE = np.zeros((2, 3)), np.zeros((2, 3), np.int64)
GRIDS = (np.zeros((2, 4), np.int64), WHOLE, LEVELS_WHOLE, WHOLE, WHOLE, np.zeros((2, 4)), REAL,
         LEVELS, REAL)
DETECT_SAMPLES = {
    'bounds_kernel': (AXES, AXES, REAL, AXES, REAL, REAL),
    'levels_kernel': (REAL, REAL, WHOLE, WHOLE),
    'extents_kernel': (AXES, REAL, WHOLE, WHOLE, REAL, LEVELS, LEVELS),
    'grids_kernel': (WHOLE, REAL, LEVELS, LEVELS, REAL, LEVELS_WHOLE, WHOLE),
    'homes_kernel': (AXES, WHOLE, LEVELS, REAL, LEVELS_WHOLE, WHOLE, AXES_WHOLE, WHOLE),
    'place_kernel': (AXES, AXES, AXES, AXES, REAL, AXES, REAL, WHOLE, AXES_WHOLE, WHOLE,
                     np.zeros((2, 4)), np.zeros((2, 4), np.int64), ROWS),
    'count_kernel': GRIDS + (WHOLE, PAIRS),
    'write_kernel': GRIDS + (WHOLE, WHOLE, PAIRS, WHOLE),
    'narrow_kernel': (ROWS, PAIRS, 0.005, np.zeros((6, 2))),
}
FACES, CONTACT, SETTINGS = (0.0,) * 6, (0.0,) * 4, (4.0, 120.0, 10.0, 0.5)
ROWS_SAMPLES = {
    'mark_members_kernel': (PAIRS, WHOLE),
    'flag_members_kernel': (WHOLE, WHOLE),
    'place_members_kernel': (WHOLE, WHOLE, WHOLE, WHOLE, WHOLE),
    'faces_kernel': (WHOLE, ROWS, FACES, WHOLE, WHOLE, PAIRS),
    'keys_kernel': (PAIRS, PAIRS, WHOLE, WHOLE, WHOLE, PAIRS, WHOLE, WHOLE),
    'body_kernel': (WHOLE, WHOLE, ROWS, REAL, 4.0, BODIES, BODIES, REAL),
    'fill_kernel': (ROWS, WHOLE, PAIRS, PAIRS, AXES, ROWS, PAIRS, WHOLE, REAL, REAL, WHOLE,
                    FACES, CONTACT, True, SETTINGS, 0.005, 0.1, FLAG),
    'warm_kernel': (ROWS, WHOLE, WHOLE, WHOLE, WHOLE, np.zeros((2, 8), np.int64),
                    np.zeros((2, 8, 4)), WHOLE, PAIRS, WHOLE, REAL, SETTINGS, 0.005),
    'crossings_kernel': (BODIES, PAIRS, WHOLE, WHOLE, AXES, AXES, AXES, AXES, REAL, FACES,
                         4.0, 0.005),
    'order_kernel': (WHOLE, PAIRS, PAIRS),
}
ORDER_SAMPLES = {
    'incidence_keys_kernel': (PAIRS, WHOLE),
    'colour_round_kernel': (PAIRS, 2, WHOLE, WHOLE, WHOLE, WHOLE),
    'slot_kernel': (WHOLE, WHOLE),
    'floor_flags_kernel': (PAIRS, WHOLE),
    'floor_place_kernel': (PAIRS, WHOLE, WHOLE, ROWS, WHOLE, 0, WHOLE, REAL),
    'heights_kernel': (WHOLE, AXES, REAL, REAL, REAL, REAL),
    'layer_kernel': (PAIRS, REAL, REAL, WHOLE),
    'bearing_flags_kernel': (ROWS, WHOLE, WHOLE, WHOLE),
    'bearing_place_kernel': (ROWS, WHOLE, PAIRS, WHOLE, WHOLE, WHOLE, PAIRS, BODIES),
    'wave_round_kernel': (PAIRS, WHOLE, WHOLE, WHOLE, WHOLE, WHOLE),
    'gather_kernel': (WHOLE, PAIRS, BODIES, PAIRS, BODIES),
}
SETTLE_SAMPLES = {
    'remember_kernel': (ROWS, WHOLE, WHOLE, WHOLE, WHOLE, WHOLE, np.zeros((2, 8), np.int64),
                        np.zeros((2, 8, 4)), WHOLE, 800.0),
    'forget_kernel': (WHOLE,),
    'write_back_kernel': (WHOLE, BODIES, BODIES, AXES, AXES, AXES, np.zeros(2, np.uint8),
                          np.zeros(2, np.uint8), WHOLE),
}
# Kernels whose atomics are minima, maxima or integer counts (the same in any order).
ATOMIC = ('fastest_kernel', 'substeps_kernel', 'bounds_kernel', 'levels_kernel',
          'extents_kernel', 'write_kernel', 'colour_round_kernel', 'heights_kernel',
          'wave_round_kernel', 'write_back_kernel')


@pytest.mark.skipif(simulated(), reason='the simulator has no compiler')
@pytest.mark.parametrize('module, name', [('contact_kernels', name) for name in sorted(SAMPLES)]
                         + [('detect_kernels', name) for name in sorted(DETECT_SAMPLES)]
                         + [('rows_kernels', name) for name in sorted(ROWS_SAMPLES)]
                         + [('order_kernels', name) for name in sorted(ORDER_SAMPLES)]
                         + [('settle_kernels', name) for name in sorted(SETTLE_SAMPLES)])
def test_every_collision_kernel_compiles_to_ptx_for_compute_capability_9(module, name):
    # As test_cuda_backend.ptx_of: the current device's compute capability is asked for
    # while an @njit function a kernel calls compiles; answered with 9.0.
    cuda = load_cuda()
    from numba.cuda import dispatcher
    kernel = getattr(importlib.import_module(f'pool_sim.physics.cuda.{module}'), name)
    samples = {**SAMPLES, **DETECT_SAMPLES, **ROWS_SAMPLES, **ORDER_SAMPLES,
               **SETTLE_SAMPLES}[name]
    signature = tuple(numba.typeof(value) for value in samples)
    hopper = types.SimpleNamespace(compute_capability=(9, 0))
    with mock.patch.object(dispatcher, 'get_current_device', lambda: hopper):
        ptx, _ = cuda.compile_ptx(kernel, signature, cc=(9, 0))
    assert '.target sm_90' in ptx and '.entry' in ptx and '.const' not in ptx
    # A colour's contacts share no sphere, a row writes only its own pairs: no atomics but
    # the minima, maxima and integer counts.
    assert ('atom' in ptx) == (name in ATOMIC)


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


@pytest.mark.parametrize('order', THREAD_ORDERS)
@pytest.mark.parametrize('mode', ['launches', 'cooperative'])
@pytest.mark.parametrize('label', ['landing', 'rest', 'serial'])
def test_the_gpu_solve_leaves_what_the_cpu_solve_leaves_bit_for_bit(solved, label, mode,
                                                                     order):
    chosen, on_gpu = solved
    for name, value in zip(OUTPUTS, cpu_solve(chosen[label])):
        gpu = on_gpu[f'{label}.{mode}.{order}.{name}']
        assert gpu.shape == value.shape and np.all(np.isfinite(gpu)), name
        assert np.array_equal(gpu, value), (name, float(np.max(np.abs(gpu - value))))


@pytest.mark.parametrize('order', THREAD_ORDERS)
@pytest.mark.parametrize('label', ['detect_landing', 'detect_rest', 'detect_levels',
                                   'detect_apart'])
def test_detection_on_the_gpu_finds_the_cpu_s_contacts_bit_for_bit(solved, label, order):
    chosen, on_gpu = solved
    on_cpu = cpu_detect(chosen[label])
    pairs = on_cpu['pairs'].shape[1]
    assert (pairs == 0) if label == 'detect_apart' else (pairs >= 10)
    for name, value in on_cpu.items():
        gpu = on_gpu[f'{label}.{order}.{name}']
        if name == 'state':  # its columns past RADIUS are padding, never written
            gpu, value = gpu[:, :RADIUS + 1], value[:, :RADIUS + 1]
        assert gpu.shape == value.shape, name
        assert np.array_equal(gpu, value), name


@pytest.mark.parametrize('order', THREAD_ORDERS)
@pytest.mark.parametrize('label', ['rows_landing', 'rows_rest', 'rows_levels'])
def test_the_rows_filled_on_the_gpu_are_the_cpu_s_bit_for_bit(solved, label, order):
    chosen, on_gpu = solved
    for name in ROWS_FILLED:
        gpu, value = on_gpu[f'{label}.{order}.{name}'], chosen[label][f'expected.{name}']
        assert gpu.shape == value.shape and np.array_equal(gpu, value), name


@pytest.mark.parametrize('order', THREAD_ORDERS)
@pytest.mark.parametrize('label', ['rows_landing', 'rows_rest', 'rows_levels'])
def test_the_contacts_indices_made_on_the_gpu_are_the_cpu_s(solved, label, order):
    chosen, on_gpu = solved
    case = chosen[label]
    expected = {name: case[name] for name in ('sphere', 'state_row', 'faces_of', 'keys',
                                              'homes', 'by_home')}
    expected['ends'] = ends_and_ground(case)[0]
    expected['face_start'] = np.searchsorted(case['faces_of'][:, 0],
                                             np.arange(case['sphere'].size + 1))
    for name, value in expected.items():
        gpu = on_gpu[f'{label}.{order}.index_{name}']
        assert gpu.shape == value.shape and np.array_equal(gpu, value), name


@pytest.mark.parametrize('order', THREAD_ORDERS)
@pytest.mark.parametrize('label', ['rows_landing', 'rows_rest', 'rows_levels',
                                   'resolve_hostile', 'resolve_apart', 'resolve_single'])
def test_the_collision_pass_on_the_gpu_is_the_cpu_s_with_its_colouring_bit_for_bit(
        solved, label, order):
    # Detection, rows, orders, solve, memory and write-back: resolve_collisions' step with
    # the contacts coloured by colour_priority, as the CPU makes it.
    chosen, on_gpu = solved
    for name, value in cpu_resolve(chosen[label]).items():
        gpu = on_gpu[f'{label}.{order}.{name}']
        assert gpu.shape == value.shape and np.array_equal(gpu, value), name


def test_the_collision_pass_cases_exercise_what_they_claim(solved):
    chosen, on_gpu = solved
    for label in ('rows_landing', 'rows_rest', 'rows_levels'):
        case = chosen[label]
        arrays, _ = resolve_inputs(case)
        members = case['sphere']
        flagged = on_gpu[f'{label}.forward.resolved_flagged']
        assert np.all(flagged[members] == 0) and flagged.sum() == flagged.size - members.size
        held = on_gpu[f'{label}.forward.resolved_memory_held']
        assert held.sum() >= case['slot'].size // 2, label  # remembered, most of them
        moved = on_gpu[f'{label}.forward.resolved_position'] - arrays['position']
        assert np.max(np.abs(moved[:, members])) > 0.0, label  # the solve moved them
        # The GPU's colouring is not the CPU's, so neither is its step.
        slot = on_gpu[f'{label}.forward.order_slot']
        assert not np.array_equal(slot, case['slot']), label
    # The edges: the guard puts back spheres a non-finite member's row touched; with no
    # pairs, or one sphere, last step's memory is emptied.
    assert on_gpu['resolve_hostile.forward.resolved_put_back'] >= 2
    assert np.isfinite(on_gpu['resolve_hostile.forward.resolved_memory_forces']).all()
    for label in ('resolve_apart', 'resolve_single'):
        assert chosen[label]['memory_held'].sum() > 0, label
        assert on_gpu[f'{label}.forward.resolved_memory_held'].sum() == 0, label


ORDER_LABELS = ['rows_landing', 'rows_rest', 'rows_levels', 'order_crowd', 'order_star',
                'order_chains']


@pytest.mark.parametrize('order', THREAD_ORDERS)
@pytest.mark.parametrize('label', ORDER_LABELS)
def test_the_orders_made_on_the_gpu_are_the_cpu_functions_bit_for_bit(solved, label, order):
    # The colouring: colour_by_priority's; the support order and waves: the CPU's own.
    chosen, on_gpu = solved
    expected = cpu_orders(chosen[label])
    for name, value in expected.items():
        gpu = on_gpu[f'{label}.{order}.{name}']
        assert gpu.shape == value.shape and np.array_equal(gpu, value), name
    made = {key.split('.', 2)[2] for key in on_gpu if key.startswith(f'{label}.{order}.')
            and key.split('.', 2)[2].startswith('order_support')}
    assert made == {name for name in expected if name.startswith('order_support')}


@pytest.mark.parametrize('label', ORDER_LABELS)
def test_the_gpu_colouring_keeps_a_colour_s_contacts_apart(solved, label):
    chosen, on_gpu = solved
    case = chosen[label]
    ends, ground = ends_and_ground(case)
    slot = on_gpu[f'{label}.forward.order_slot']
    start = on_gpu[f'{label}.forward.order_colour_start']
    assert np.array_equal(np.sort(slot), np.arange(ends.shape[0]))
    colour = np.searchsorted(start, slot, side='right') - 1
    for k in range(COLOURS - 1):  # the last takes what is left
        rows = ends[colour == k].ravel()
        rows = rows[rows != ground]
        assert np.unique(rows).size == rows.size, (label, k)


def priorities(ends):
    """colouring.colour_priority of each contact."""
    return np.array([colour_priority(c) for c in range(ends.shape[0])], dtype=np.int64)


def chain_of(ends, ground, order):
    """The longest chain of contacts, in the given order, each sharing a sphere (not the
    ground) with the one before: what colouring greedily in that order waits for."""
    longest = np.zeros(ground + 1, dtype=np.int64)
    for a, b in ends[order]:
        longest[a] = longest[b] = max(longest[a], longest[b] if b != ground else 0) + 1
    return int(longest[:ground].max())


def test_colour_priority_s_chains_are_short_on_a_pile_s_layer():
    # 10 000 spheres on a square lattice on the floor, each touching its four neighbours
    # and the floor, in the order detection finds them: the chains the CPU's order would
    # wait for are long; colour_priority's, as the GPU colours, short.
    side = 100
    index = np.arange(side * side).reshape(side, side)
    pairs = [np.stack([index[:, :-1].ravel(), index[:, 1:].ravel()], axis=1),
             np.stack([index[:-1].ravel(), index[1:].ravel()], axis=1)]
    ends = np.concatenate(pairs)
    ends = ends[np.argsort(ends[:, 0], kind='stable')]
    ends = np.concatenate([ends, np.stack([index.ravel(), np.full(side * side, side * side)],
                                          axis=1)])
    ground = side * side
    in_order = chain_of(ends, ground, np.arange(ends.shape[0]))
    by_priority = chain_of(ends, ground, np.argsort(priorities(ends), kind='stable'))
    assert in_order >= 150 and by_priority <= 30, (in_order, by_priority)
    _, start = colour_by_priority(ends, ground)
    assert np.count_nonzero(np.diff(start)) <= 10  # few colours still


def test_the_order_cases_exercise_what_they_claim(solved):
    chosen, on_gpu = solved
    assert on_gpu['order_star.forward.order_colour_start'][COLOURS - 1] < 70  # the last colour
    for label in ORDER_LABELS:
        # A round per link of the longest chain in colour_priority's order, and one more
        # that finds none waiting.
        ends, ground = ends_and_ground(chosen[label])
        rounds = int(on_gpu[f'{label}.forward.order_rounds_colour'])
        by_priority = np.argsort(priorities(ends), kind='stable')
        assert 2 <= rounds <= chain_of(ends, ground, by_priority) + 1, label
    assert on_gpu['order_chains.forward.order_support_wave_bounds'].size >= 12  # many waves
    # Threads numbered backwards wait a round for each wave (forwards, the simulator runs
    # a thread after those before it: one round may settle them all).
    assert on_gpu['order_chains.backward.order_rounds_waves'] >= 11
    rest = {name: on_gpu[f'rows_rest.forward.order_support_{name}']
            for name in ('ends', 'floor_member', 'wave_bounds')}
    assert rest['ends'].shape[0] >= 10 and rest['floor_member'].size >= 10
    assert rest['wave_bounds'].size >= 3  # more than one wave
    crowd = chosen['order_crowd']['ends']
    assert np.any(crowd == 12)  # contacts with the ground


def test_the_rows_cases_exercise_what_they_claim(solved):
    chosen, _ = solved
    for label in ('rows_landing', 'rows_rest', 'rows_levels'):
        case = chosen[label]
        rows = case['expected.rows']
        assert case['slot'].size >= 20 and case['faces_of'].shape[0] >= 10, label
        assert np.count_nonzero(rows[:, NORMAL]) >= 2, label  # warm-started from memory
        # A smooth path that crossed a face: its change is not the smooth step's share.
        state = case['state'][case['state_row']]
        share = (state[:, END_VELOCITY:END_VELOCITY + 3]
                 - state[:, START_VELOCITY:START_VELOCITY + 3]) / case['settings'][0]
        crossed = np.any(share != case['expected.change'][:-1, :3], axis=1)
        assert crossed.any() == (label != 'rows_rest'), label
    assert chosen['rows_landing']['expected.bounces'].any()


def test_the_detection_cases_exercise_what_they_claim(solved):
    chosen, _ = solved
    for label, levels in (('detect_landing', 1), ('detect_rest', 1), ('detect_levels', 2)):
        case = chosen[label]
        _, _, level, level_count, _, _ = _bounding_spheres(
            case['old_position'], case['position'], case['radius'], np.empty(0),
            np.empty(0, dtype=np.int64))
        assert level_count == levels and np.all(np.bincount(level) >= 10), label
        if levels == 2:  # pairs across the levels: a finer level's cells are searched
            on_cpu = cpu_detect(case)
            spheres = on_cpu['order'][on_cpu['pairs']]
            assert np.any(level[spheres[0]] != level[spheres[1]])
    # Landing: spheres swept far in the step (bounding spheres larger than at rest).
    speed = np.linalg.norm(chosen['detect_landing']['velocity'], axis=0)
    assert speed.max() > 1.0


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


@pytest.mark.skipif(simulated(), reason='the simulator sorts with numpy')
def test_detection_on_a_gpu_without_cupy_is_refused_with_the_install_command():
    pytest.importorskip('numba.cuda')
    try:
        import cupy  # noqa: F401
        pytest.skip('CuPy is installed here')
    except ImportError:
        pass
    from pool_sim.physics.cuda.device_detect import CUPY_COMMAND, DeviceDetect
    with pytest.raises(ImportError, match='sorts with CuPy') as refused:
        DeviceDetect()
    assert CUPY_COMMAND in str(refused.value)


def test_collisions_on_a_gpu_without_cupy_are_refused_at_start_with_the_install_command(
        monkeypatch):
    # As if a GPU were here (unavailable() says none is): the scene is refused as invalid
    # input, which the node reports and exits on, not with a traceback.
    pytest.importorskip('numba.cuda')
    if simulated() or importlib.util.find_spec('cupy') is not None:
        pytest.skip('the simulator sorts with numpy; or CuPy is installed here')
    from pool_sim.physics import DEFAULT_EFFECTS, InvalidInput, Scene
    from pool_sim.physics.cuda import device
    from pool_sim.physics.cuda.device_detect import CUPY_COMMAND
    monkeypatch.setattr(device, 'unavailable', lambda: None)
    scene = Scene({'sphere_names': ['a', 'b'], 'backend': 'cuda', 'contact_solver': 'soft_step',
                   'effects': [*DEFAULT_EFFECTS, 'collisions']})
    with pytest.raises(InvalidInput, match='cannot run collisions here') as refused:
        device.DeviceState.for_scene(scene)
    assert CUPY_COMMAND in str(refused.value)
