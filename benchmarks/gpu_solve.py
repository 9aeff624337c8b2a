"""Collisions on the GPU against the CPU: contact detection (physics/cuda/device_detect.py)
and the soft step's solve stage (device_solve.py: a step's substeps and restitution pass
on the rows soft_step.contact_rows makes), at rest and landing, by size. benchmarks/gpu.py
runs it (--solve-sizes); alone:

    python3 -m benchmarks.gpu_solve [--sizes 100000 1000000] [--out results/gpu]

10 M spheres (--sizes 10000000) are left to be asked for: preparing their step on one CPU
core (the Simulation, a step, detection, the rows) takes minutes (1 M: 18-50 s here, 6.7 GB).

The scene: equal spheres (radius RADIUS, density DENSITY) on a square lattice, touching, in
layers from the default pool's floor up, with the default effects and `collisions`
(soft_step); at rest, or landing (layer k falling at (k + 1) x LANDING_SPEED, so that every
layer closes on the one below and the bottom one on the floor). From that state, as the
step would: detection, on the GPU and on the CPU (one thread), timed, and whether the two
found the same pairs; then contact_rows on the CPU (one run, timed with detection), and the
rows filled on the GPU from its indices (DeviceRows), timed, against the CPU's; the GPU's
colouring (DeviceOrder.colour: its colours and rounds) and support order (support(), from
the CPU's rows, against the CPU's), timed; and the whole collision pass on the GPU
(DeviceCollisions.resolve), timed.
Then, every figure a median of --repeats, each from the same rows (copied on the device):
the GPU's solve in each of DeviceSolve's modes (a launch per pass and colour, or one
cooperative launch) and the CPU's (soft_step._substeps and restitution_pass, one thread, up
to --cpu-max spheres), and how far the GPU's velocities and moves are from the CPU's.
"""
import argparse
import pathlib
import statistics
import time

import numpy as np

from benchmarks.common import provenance, write_csv
from benchmarks.solve_passes import rows_of, step_inputs
from pool_sim.physics import DEFAULT_EFFECTS, Scene, Spheres
from pool_sim.physics.contacts import soft_step
from pool_sim.physics.contacts.detection import detect_contacts
from pool_sim.physics.contacts.layers import sweep_waves
from pool_sim.physics.cuda.device_collisions import DeviceCollisions, pass_constants
from pool_sim.physics.cuda.device_detect import DeviceDetect
from pool_sim.physics.cuda.device_order import DeviceOrder
from pool_sim.physics.cuda.device_rows import DeviceRows
from pool_sim.physics.cuda.device_solve import DeviceSolve, MODES, colour_bounds

RADIUS = 0.01  # m
DENSITY = 2000.0  # kg/m^3
LANDING_SPEED = 0.5  # m/s, the closing speed of each layer on the one below
SCENES = ('at rest', 'landing')
CPU_MAX = 1_000_000  # spheres: the CPU's solve is timed up to this many
POOL_SIDE = 8.0  # m: the default pool's floor is 8 m square


def pile(count, landing):
    """count spheres on the lattice (see the module's docstring), a Spheres."""
    side = int(POOL_SIDE / (2.0 * RADIUS))
    index = np.arange(count)
    layer = index // (side * side)
    position = np.stack([-4.0 + RADIUS + 2.0 * RADIUS * (index % side),
                         -4.0 + RADIUS + 2.0 * RADIUS * (index // side % side),
                         -4.0 + RADIUS + 2.0 * RADIUS * layer])
    velocity = np.zeros((3, count))
    if landing:
        velocity[2] = -LANDING_SPEED * (layer + 1)
    radius = np.full(count, RADIUS)
    lift_normal = np.zeros((3, count))
    lift_normal[2] = 1.0
    return Spheres([f's{i}' for i in range(count)], position=position, velocity=velocity,
                   mass=DENSITY * 4.0 / 3.0 * np.pi * radius**3, radius=radius,
                   drag_coefficient=np.full(count, 0.47), lift_area=np.pi * radius**2,
                   lift_normal=lift_normal, lift_coefficient=np.zeros(count),
                   external_force=np.zeros((3, count)))


def pile_step(count, landing):
    """solve_passes.step_inputs of the pile's first step."""
    scene = Scene({'sphere_names': ['s0'], 'contact_solver': 'soft_step',
                   'effects': [*DEFAULT_EFFECTS, 'collisions']})
    return step_inputs(scene, 0.0, initial_spheres=pile(count, landing))


def detection_timing(inputs, repeats):
    """{gpu_detect_ms, cpu_detect_ms: the medians of DeviceDetect's and detect_contacts'
    (one thread) times; detect_same_pairs: whether they found the same pairs in the same
    order; detect_normal_gap: the largest difference of their normals} of a step."""
    colliding, _, state, after, reals, wholes = inputs
    radius, dt = colliding.spheres.radius, colliding.max_step
    detector = DeviceDetect()
    arrays = [detector.cuda.to_device(np.ascontiguousarray(array))
              for array in (*state, *after, radius)]
    found = {}

    def on_gpu():
        found.update(detector.detect(*arrays, dt))
        detector.cuda.synchronize()

    def on_cpu():
        found['cpu'] = detect_contacts(*state, *after, radius, dt, reals, wholes)[0]
    row = {}
    for name, run in (('gpu_detect_ms', on_gpu), ('cpu_detect_ms', on_cpu)):
        run()  # compiles
        row[name] = median_of((lambda: None, run), repeats) * 1e3
    pairs = found['pairs'].copy_to_host()
    row['detect_same_pairs'] = bool(np.array_equal(pairs, found['cpu'].pairs))
    if row['detect_same_pairs']:
        row['detect_normal_gap'] = float(np.max(np.abs(
            found['facts'].copy_to_host()[:3] - found['cpu'].normal), initial=0.0))
    return row


def rows_timing(inputs, ready, scalars, repeats):
    """{gpu_rows_ms: the median of DeviceRows' indices and fill (from the CPU's colour
    slots); rows_gap: the largest difference of the rows it fills from contact_rows';
    gpu_colour_ms, gpu_support_ms: DeviceOrder's colour() and support() (from the CPU's
    slots and rows), their medians; gpu_colours, colour_rounds, wave_rounds: what they took;
    support_same: whether support() made the CPU's support order and waves} of a step."""
    colliding, memory, state, after, reals, wholes = inputs
    spheres, dt = colliding.spheres, colliding.max_step
    contacts = detect_contacts(*state, *after, spheres.radius, dt, reals, wholes)[0]
    maker = DeviceRows()
    orders = DeviceOrder(maker.library)

    def up(array):
        return maker.cuda.to_device(np.ascontiguousarray(array))
    settings, _, threshold, _ = scalars
    _, _, pool, contact, _ = colliding._constants
    pool = tuple(map(float, pool))
    detected = tuple(map(up, (contacts.pairs, contacts.normal, contacts.state)))
    order, identity = up(contacts.order), up(colliding._identity)
    arguments = ((up(spheres.mass), up(spheres.radius)), tuple(map(up, memory)),
                 tuple(map(up, (*state, *after))),
                 (pool, tuple(map(float, contact)), 'friction' in colliding.scene['effects'],
                  tuple(map(float, settings)), dt, threshold))
    has_faces = 'contact' in colliding.scene['effects']
    made, filled, coloured, supported = {}, {}, [], {}

    def indices_and_fill():
        made.update(maker.indices(detected[0], order, detected[2], identity, pool, has_faces))
        filled.update(maker.fill(detected, made, ready.slot, *arguments))
        maker.cuda.synchronize()

    def colour():
        coloured[:] = orders.colour(made['ends'], made['sphere'].shape[0])
        maker.cuda.synchronize()
    cpu_slot = up(ready.slot)

    def support():
        supported.update(orders.support(
            filled['rows'], made['ends'], contacts.pairs.shape[1], made['faces_of'], cpu_slot,
            made['sphere'], arguments[2][0], arguments[0][1]))
        maker.cuda.synchronize()
    timed = {}
    for name, run in (('gpu_rows_ms', indices_and_fill), ('gpu_colour_ms', colour),
                      ('gpu_support_ms', support)):
        run()  # compiles
        timed[name] = median_of((lambda: None, run), repeats) * 1e3
    rows = filled['rows'].copy_to_host()
    ends, facts, floor_member, floor_gap = ready.support
    by_wave, wave_bounds = sweep_waves(ends, ready.sphere.size)
    expected = {'ends': ends[by_wave], 'facts': facts[by_wave], 'wave_bounds': wave_bounds,
                'floor_member': floor_member, 'floor_gap': floor_gap}
    same = all(np.array_equal(supported[name].copy_to_host(), value)
               for name, value in expected.items())
    return {**timed, 'rows_gap': float(np.max(np.abs(rows - ready.rows), initial=0.0)),
            'gpu_colours': int(np.count_nonzero(np.diff(coloured[1]))),
            'colour_rounds': orders.rounds['colour'],
            'wave_rounds': orders.rounds.get('waves', 0), 'support_same': same}


def pass_timing(inputs, repeats):
    """{gpu_pass_ms, gpu_pass_ns_per_sphere: the median of a whole collision pass on the
    GPU (DeviceCollisions.resolve: detection, rows, orders, solve, memory, write-back),
    each from the step's arrays afresh; pass_put_back: the spheres its guard put back} of
    a step."""
    colliding, memory, state, after, _, _ = inputs
    spheres, effects, dt = colliding.spheres, colliding.scene['effects'], colliding.max_step
    collisions = DeviceCollisions()
    cuda = collisions.cuda
    environment, _, pool, contact, settings = colliding._constants
    world = pass_constants(environment, pool, contact, settings,
                           ('contact' in effects, 'friction' in effects, 'gravity' in effects),
                           dt)
    count = spheres.count
    pristine = [*state, *after, *memory, np.ones(count, np.uint8), np.zeros(count, np.uint8)]
    device = [cuda.to_device(np.ascontiguousarray(array)) for array in pristine]
    fixed = (cuda.to_device(spheres.mass), cuda.to_device(spheres.radius))
    identity, put_back = cuda.to_device(colliding._identity), []

    def prepare():
        for array, kept in zip(device, pristine):
            array.copy_to_device(np.ascontiguousarray(kept))
        cuda.synchronize()

    def run():
        put_back[:] = [collisions.resolve(tuple(device[:4]), fixed, identity,
                                          tuple(device[4:7]), device[7], device[8], world)]
        cuda.synchronize()
    prepare()
    run()  # compiles
    seconds = median_of((prepare, run), repeats)
    return {'gpu_pass_ms': seconds * 1e3, 'gpu_pass_ns_per_sphere': seconds / count * 1e9,
            'pass_put_back': put_back[0]}


def median_of(function, repeats):
    """Median seconds of function() over repeats calls, each after prepare() (untimed)."""
    prepare, run = function
    samples = []
    for _ in range(repeats):
        prepare()
        start = time.perf_counter()
        run()
        samples.append(time.perf_counter() - start)
    return statistics.median(samples)


def gpu_timing(ready, mode, scalars, repeats):
    """(median seconds of mode's solve, what it leaves: rows, velocity, moved)."""
    solver = DeviceSolve(mode)
    pristine, arrays = solver.upload(ready), solver.upload(ready)

    def prepare():
        for name, array in pristine.items():
            arrays[name].copy_to_device(array)
        solver.cuda.synchronize()

    def run():
        solver.solve(arrays, ready.colour_start, *scalars)
        solver.cuda.synchronize()
    run()  # compiles
    seconds = median_of((prepare, run), repeats)
    prepare()
    run()
    return seconds, tuple(arrays[name].copy_to_host() for name in ('rows', 'velocity',
                                                                    'moved'))


def cpu_timing(ready, scalars, repeats):
    """(median seconds of the CPU's substeps and restitution pass, what they leave)."""
    settings, dt, threshold, restitution = scalars
    supported = np.zeros(ready.sphere.size, dtype=np.bool_)
    state = {}

    def prepare():
        state.update(rows=ready.rows.copy(), velocity=ready.velocity.copy(),
                     moved=ready.moved.copy())

    def run():
        soft_step._substeps(state['rows'], ready.solve_order, state['velocity'],
                            state['moved'], ready.change, ready.inverse_mass, settings, dt,
                            ready.support, threshold, supported)
        soft_step.restitution_pass(state['rows'], ready.solve_order, state['velocity'],
                                   ready.inverse_mass, threshold, restitution, ready.bounces)
    prepare()
    run()  # compiles
    seconds = median_of((prepare, run), repeats)
    prepare()
    run()
    return seconds, (state['rows'], state['velocity'], state['moved'])


def solve_row(count, landing, repeats, cpu_max):
    """The figures of one scene at one size (a dict: the CSV's row)."""
    inputs = pile_step(count, landing)
    try:
        detected = detection_timing(inputs, repeats)
    except Exception as error:  # noqa: BLE001 (one run on a lent GPU: keep the rest)
        detected = {'detect_failed': failure(error)}
    began = time.perf_counter()
    ready, *scalars = rows_of(*inputs)
    detected['cpu_detect_and_rows_ms'] = (time.perf_counter() - began) * 1e3  # one run
    try:
        detected.update(rows_timing(inputs, ready, scalars, repeats))
    except Exception as error:  # noqa: BLE001 (one run on a lent GPU: keep the rest)
        detected['rows_failed'] = failure(error)
    try:
        detected.update(pass_timing(inputs, repeats))
    except Exception as error:  # noqa: BLE001 (one run on a lent GPU: keep the rest)
        detected['pass_failed'] = failure(error)
    bounds, serial = colour_bounds(ready.colour_start)
    _, waves = sweep_waves(ready.support[0], ready.sphere.size)
    row = {'scene': SCENES[landing], 'spheres': count, 'contacts': ready.rows.shape[0],
           'colours': bounds.size - 1, 'serial_colour': serial >= 0,
           'support_waves': waves.size - 1, **detected}
    if not ready.rows.shape[0]:
        return row
    results = {}
    for mode in MODES:
        try:
            seconds, results[mode] = gpu_timing(ready, mode, scalars, repeats)
        except Exception as error:  # noqa: BLE001 (one run on a lent GPU: keep the rest)
            row[f'{mode}_failed'] = failure(error)
            continue
        row[f'{mode}_ms'] = seconds * 1e3
        row[f'{mode}_ns_per_sphere'] = seconds / count * 1e9
    if count <= cpu_max:
        seconds, on_cpu = cpu_timing(ready, scalars, max(1, repeats // 4))
        row['cpu_one_core_ms'] = seconds * 1e3
        for mode, left in results.items():
            row[f'{mode}_velocity_gap'] = float(np.max(np.abs(left[1] - on_cpu[1])))
            row[f'{mode}_moved_gap'] = float(np.max(np.abs(left[2] - on_cpu[2])))
    return row


def uniform(rows):
    """rows with every key any of them has ('-' where one has none), in one order: a
    mode that failed, or sizes past --cpu-max, leave some out."""
    columns = list(rows[0]) + sorted({c for row in rows for c in row} - set(rows[0]))
    return [{c: row.get(c, '-') for c in columns} for row in rows]


def table(rows):
    """The markdown table of solve_row's rows (floats to 4 significant figures)."""
    rows = uniform(rows)
    columns = list(rows[0])
    shown = [[f'{row[c]:.4g}' if isinstance(row.get(c), float) else str(row.get(c, '-'))
              for c in columns] for row in rows]
    return '\n'.join(['| ' + ' | '.join(columns) + ' |', '|' + '---:|' * len(columns)]
                     + ['| ' + ' | '.join(r) + ' |' for r in shown])


def failure(error):
    """An exception as a table cell: its type and message, on one line, no separators."""
    text = f'{type(error).__name__}: {error}'[:200]
    return ' '.join(text.split()).replace(',', ';').replace('|', '/')


def measure(sizes, repeats, cpu_max, out, command):
    """(rows, the section of gpu.md they make), written as they come (by_scene)."""
    return by_scene(sizes, lambda count, landing: solve_row(count, landing, repeats, cpu_max),
                    'gpu_solve', lambda rows: section(rows, repeats), out, command)


def by_scene(sizes, row_of, stem, section_of, out, command):
    """(rows: row_of(count, landing) of each size and scene, section_of(rows)). stem.csv
    and stem.md (command's provenance) are written into the folder out after each row, so
    that a run cut short (a lent GPU's time runs out) keeps what it measured; a row that
    fails says why."""
    out = pathlib.Path(out)
    out.mkdir(parents=True, exist_ok=True)
    rows = []
    for count in sizes:
        for landing in (False, True):
            try:
                rows.append(row_of(count, landing))
            except Exception as error:  # noqa: BLE001 (one run on a lent GPU: keep the rest)
                rows.append({'scene': SCENES[landing], 'spheres': count,
                             'failed': failure(error)})
            print(rows[-1], flush=True)
            write_csv(uniform(rows), out / f'{stem}.csv')
            (out / f'{stem}.md').write_text(
                provenance(command) + '\n\n' + section_of(rows) + '\n')
    return rows, section_of(rows)


def section(rows, repeats):
    """The markdown section of rows (solve_row's)."""
    return '\n\n'.join([
        '## Collisions on the GPU: detection and the solve stage (benchmarks/gpu_solve.py)',
        f'A step\'s substeps and restitution pass on the rows of a lattice pile (radius '
        f'{RADIUS} m, {DENSITY:g} kg/m^3, from the floor up; landing: layer k closing at '
        f'{LANDING_SPEED} m/s on the one below), its first step; medians of {repeats}. '
        'launches: a launch per pass and colour; cooperative: one launch, the grid synced '
        'between passes; cpu_one_core: soft_step._substeps and restitution_pass. The gaps '
        '(m/s, m): the largest difference of the GPU\'s velocities and moves from the '
        "CPU's. Detection: gpu_detect against cpu_detect (detect_contacts, one thread), "
        'whether the two found the same pairs in the same order, and the largest '
        'difference of their normals. cpu_detect_and_rows: detection and contact_rows on '
        "the CPU, one run (the first row's compiles them); gpu_rows: the contacts' indices "
        "made and the rows filled on the GPU (from the CPU's colour slots, sent up within "
        "the time), rows_gap their largest difference from the CPU's; gpu_colour and "
        'gpu_support: the colouring (its colours and rounds) and the support order '
        "(support_same: the CPU's, waves and all) made on the GPU; gpu_pass: the whole "
        'collision pass on the GPU (DeviceCollisions.resolve), from the step\'s arrays.',
        table(rows)])


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument('--sizes', type=int, nargs='+',
                        default=[100_000, 1_000_000])
    parser.add_argument('--repeats', type=int, default=11)
    parser.add_argument('--cpu-max', type=int, default=CPU_MAX)
    parser.add_argument('--out', default='results/gpu')
    arguments = parser.parse_args()
    command = 'python3 -m benchmarks.gpu_solve --sizes ' + ' '.join(map(str, arguments.sizes))
    _, text = measure(arguments.sizes, arguments.repeats, arguments.cpu_max, arguments.out,
                      command)
    print(text)


if __name__ == '__main__':
    main()
