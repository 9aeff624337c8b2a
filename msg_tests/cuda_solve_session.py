"""The soft step's solve stage on the GPU (physics/cuda/device_solve.py) against the CPU's,
on the rows soft_step.contact_rows makes from a colliding column of spheres: landing (the
support sweep and the restitution pass at work) and at rest.

    python -m cuda_solve_session CASES.npz OUT.npz   # in numba's CUDA simulator

reads the cases the test wrote (write_cases) and writes what DeviceSolve leaves, in each of
its modes, and what DeviceDetect finds. cpu_solve is what soft_step.resolve_collisions runs
on the same rows; cpu_detect, its detection.
"""
import sys
import types

import numpy as np

FIELDS = ('rows', 'solve_order', 'velocity', 'moved', 'change', 'inverse_mass', 'bounces',
          'colour_start')
SUPPORT = ('ends', 'facts', 'floor_member', 'floor_gap')
SCALARS = ('settings', 'dt', 'threshold', 'restitution')
OUTPUTS = ('rows', 'velocity', 'moved')
DETECTION = ('old_position', 'old_velocity', 'position', 'velocity', 'radius')


def column_scene(count=48, smallest_radius=0.03):
    """count spheres (radii smallest_radius m to 5 cm, 400-3000 kg/m^3, some lighter than
    water) dropped in a 0.5 m square column from 0.3-0.6 m up through air into 12 cm of
    water: they land at about 3 m/s, and then lie in a pile on the floor."""
    from pool_sim.physics import Scene
    from pool_sim.physics.effects import DEFAULT_EFFECTS
    rng = np.random.default_rng(5)
    radius = rng.uniform(smallest_radius, 0.05, count).round(4)
    mass = (rng.uniform(400.0, 3000.0, count) * 4.0 / 3.0 * np.pi * radius**3).round(6)
    layer = np.array([(x, y) for x in (-0.15, -0.05, 0.05, 0.15) for y in (-0.15, -0.05,
                                                                            0.05, 0.15)])
    position = np.array([(*layer[i % 16] + rng.uniform(-0.01, 0.01, 2), 0.3 + 0.11 * (i // 16))
                         for i in range(count)]).round(4)
    return Scene({'sphere_names': [f's{i}' for i in range(count)],
                  'effects': [*DEFAULT_EFFECTS, 'collisions'], 'contact_solver': 'soft_step',
                  'pool.min': [-0.25, -0.25, -0.12], 'pool.max': [0.25, 0.25, 1.0],
                  'contact.restitution': 0.5, 'spheres.position': position.ravel().tolist(),
                  'spheres.radius': radius.tolist(), 'spheres.mass': mass.tolist()})


def case_of(ready, settings, dt, threshold, restitution):
    """A Prepared's arrays (and the step's scalars) by name."""
    case = {name: np.asarray(getattr(ready, name)) for name in FIELDS}
    case.update(zip(SUPPORT, ready.support))
    case.update(settings=np.asarray(settings, dtype=float), dt=np.float64(dt),
                threshold=np.float64(threshold), restitution=np.float64(restitution))
    return case


def cases():
    """{label: case}: the column landing (0.3 s) and at rest (4 s), and the landing swept
    as one last colour (every contact by one thread, in slot order: the serial path)."""
    from benchmarks import solve_passes
    from pool_sim.physics.contacts.colouring import COLOURS
    chosen = {'landing': case_of(*solve_passes.prepared_from(column_scene(), 0.3)),
              'rest': case_of(*solve_passes.prepared_from(column_scene(), 4.0))}
    serial = dict(chosen['landing'])
    serial['colour_start'] = np.zeros(COLOURS + 1, dtype=np.int64)
    serial['colour_start'][-1] = serial['rows'].shape[0]
    chosen['serial'] = serial
    return chosen


def detection_input(scene, seconds):
    """{old_position, old_velocity, position, velocity, radius, dt}: what soft_step's
    detection takes in the scene's step after `seconds` (the smooth step's end)."""
    from benchmarks import solve_passes
    colliding, _, (old_position, old_velocity), (position, velocity), _, _ = (
        solve_passes.step_inputs(scene, seconds))
    return {'old_position': old_position, 'old_velocity': old_velocity, 'position': position,
            'velocity': velocity, 'radius': colliding.spheres.radius.copy(),
            'dt': np.float64(colliding.max_step)}


def detection_cases():
    """{label: detection_input}: the column landing and at rest, landing with radii from
    8 mm (bounding spheres in more than one level), and ten spheres far apart (no pairs)."""
    apart = np.stack([np.arange(10.0) * 0.5 - 2.0, np.zeros(10), np.zeros(10)])
    return {'detect_landing': detection_input(column_scene(), 0.3),
            'detect_rest': detection_input(column_scene(), 4.0),
            'detect_levels': detection_input(column_scene(smallest_radius=0.008), 0.3),
            'detect_apart': {'old_position': apart, 'old_velocity': np.zeros((3, 10)),
                             'position': apart.copy(), 'velocity': np.zeros((3, 10)),
                             'radius': np.full(10, 0.1), 'dt': np.float64(0.005)}}


ROWS_INDICES = ('sphere', 'state_row', 'faces_of', 'slot', 'keys', 'homes', 'by_home')
ROWS_FILLED = ('rows', 'velocity', 'moved', 'change', 'inverse_mass', 'bounces',
               'solve_order')
STEP = ('old_position', 'old_velocity', 'position', 'velocity')


def rows_case(scene, seconds):
    """What DeviceRows.fill takes in the scene's step after `seconds` (detection's arrays,
    contact_rows' indices, the spheres, last step's memory, the step, the constants), and
    what contact_rows filled (expected.*)."""
    import math
    from benchmarks import solve_passes
    from pool_sim.physics.contacts.detection import detect_contacts
    colliding, memory, state, after, reals, wholes = solve_passes.step_inputs(scene, seconds)
    spheres, dt = colliding.spheres, colliding.max_step
    contacts, _, _ = detect_contacts(*state, *after, spheres.radius, dt, reals, wholes)
    case = {'pairs': contacts.pairs.copy(), 'normal': contacts.normal.copy(),
            'state': contacts.state.copy(), 'order': contacts.order.copy(),
            'identity': colliding._identity.copy(),
            'has_faces': np.bool_('contact' in scene['effects'])}
    ready, settings, _, threshold, _ = solve_passes.rows_of(colliding, memory, state, after,
                                                            reals, wholes)
    case.update({name: np.array(getattr(ready, name)) for name in ROWS_INDICES})
    case.update({f'expected.{name}': np.array(getattr(ready, name)) for name in ROWS_FILLED})
    case.update(zip(STEP, (*state, *after)))
    case.update(zip(('memory_keys', 'memory_forces', 'memory_held'), memory))
    _, _, pool, contact, _ = colliding._constants
    case.update(mass=spheres.mass.copy(), radius=spheres.radius.copy(), faces=np.array(pool),
                contact=np.array(contact), settings=np.array(settings, dtype=float),
                has_friction=np.bool_('friction' in scene['effects']), dt=np.float64(dt),
                threshold=np.float64(threshold))
    assert math.isfinite(threshold)
    return case


def rows_cases():
    """{label: rows_case}: the column landing (a sphere's smooth path crossing the floor)
    and at rest, warm-started from the steps before, and the landing with radii from 8 mm."""
    return {'rows_landing': rows_case(column_scene(), 0.28),
            'rows_rest': rows_case(column_scene(), 4.0),
            'rows_levels': rows_case(column_scene(smallest_radius=0.008), 0.32)}


def resolve_cases():
    """{label: rows_case}: the collision pass's edges, from the landing column: a member's
    smooth end at an infinite speed (the guard puts spheres back), radii a thousand times
    smaller (no pairs: the memory is emptied), and one sphere alone."""
    landing = rows_case(column_scene(), 0.28)
    hostile = {name: value.copy() for name, value in landing.items()}
    hostile['velocity'][2, hostile['sphere'][0]] = -np.inf
    apart = {**landing, 'radius': landing['radius'] * 1e-3}
    single = dict(landing)
    for name in ('old_position', 'old_velocity', 'position', 'velocity'):
        single[name] = landing[name][:, :1]
    for name in ('memory_keys', 'memory_forces', 'memory_held', 'identity', 'mass', 'radius'):
        single[name] = landing[name][:1]
    return {'resolve_hostile': hostile, 'resolve_apart': apart, 'resolve_single': single}


def gpu_rows(case):
    """DeviceRows.indices, then fill from them and the CPU's slots, on a rows_case: their
    results on the host (the indices' as index_*)."""
    from pool_sim.physics.cuda import load_cuda
    from pool_sim.physics.cuda.device_rows import DeviceRows
    cuda = load_cuda()

    def up(name):
        return cuda.to_device(np.ascontiguousarray(case[name]))
    maker = DeviceRows()
    made = maker.indices(up('pairs'), up('order'), up('state'), up('identity'),
                         tuple(map(float, case['faces'])), bool(case['has_faces']))
    filled = maker.fill(
        tuple(up(name) for name in ('pairs', 'normal', 'state')), made, case['slot'],
        (up('mass'), up('radius')),
        tuple(up(name) for name in ('memory_keys', 'memory_forces', 'memory_held')),
        tuple(up(name) for name in STEP),
        (tuple(map(float, case['faces'])), tuple(map(float, case['contact'])),
         bool(case['has_friction']), tuple(map(float, case['settings'])), float(case['dt']),
         float(case['threshold'])))
    return {**{name: value.copy_to_host() for name, value in filled.items()},
            **{f'index_{name}': value.copy_to_host() for name, value in made.items()}}


def ends_and_ground(case):
    """(ends (m, 2), the ground's row) of an order case, or of a rows_case's contacts, in
    the order contact_rows found them."""
    if 'ends' in case:
        return case['ends'], int(case['ground'])
    return case['expected.solve_order'][case['slot']], case['sphere'].size


def order_cases():
    """{label: {ends, ground, facts}}: random contacts for DeviceOrder's rounds: many
    sharing a few spheres (and the ground), one sphere in 70 (so the last colour takes
    some), and support contacts in long chains (many waves)."""
    rng = np.random.default_rng(11)
    crowd = np.stack([rng.integers(0, 12, 150), rng.integers(0, 13, 150)], axis=1)
    crowd[crowd[:, 0] == crowd[:, 1], 1] = 12  # row 12: the ground, only ever second
    star = np.stack([np.zeros(70, np.int64), rng.permutation(70) + 1], axis=1)
    chains = rng.integers(0, 9, (120, 2))
    chains[chains[:, 0] == chains[:, 1], 1] = (chains[chains[:, 0] == chains[:, 1], 0] + 1) % 9
    return {'order_crowd': {'ends': crowd, 'ground': np.int64(12)},
            'order_star': {'ends': star, 'ground': np.int64(71)},
            'order_chains': {'ends': chains, 'ground': np.int64(9),
                             'facts': rng.normal(size=(120, 4))}}


def gpu_orders(case, up):
    """DeviceOrder.colour on an order case or a rows_case's contacts, and on a rows_case
    its support(), or on an order case with facts its waves alone: host arrays."""
    from pool_sim.physics.cuda.device_order import DeviceOrder
    maker = DeviceOrder()
    ends, ground = ends_and_ground(case)
    ends = up(ends)
    slot, colour_start = maker.colour(ends, ground)
    made = {'slot': slot.copy_to_host(), 'colour_start': colour_start}
    if 'facts' in case:
        waves = maker._waves(ends, up(case['facts']), ground)
        made.update({f'support_{name}': value.copy_to_host() for name, value in waves.items()})
    elif 'ends' not in case:
        support = maker.support(up(case['expected.rows']), ends, case['pairs'].shape[1],
                                *(up(case[name]) for name in ('faces_of', 'slot', 'sphere',
                                                              'old_position', 'radius')))
        made.update({f'support_{name}': value.copy_to_host()
                     for name, value in support.items()})
    made.update({f'rounds_{name}': np.int64(taken) for name, taken in maker.rounds.items()})
    return {f'order_{name}': value for name, value in made.items()}


def cpu_orders(case):
    """What gpu_orders should find, made by the CPU's functions: colouring.colour_by_priority
    and soft_step._support_order, then layers.sweep_waves."""
    from pool_sim.physics.contacts import soft_step
    from pool_sim.physics.contacts.colouring import colour_by_priority
    from pool_sim.physics.contacts.layers import sweep_waves
    ends, ground = ends_and_ground(case)
    slot, colour_start = colour_by_priority(ends, ground)
    made = {'slot': slot, 'colour_start': colour_start}
    if 'facts' in case:
        support = (ends, case['facts'], None, None)
    elif 'ends' not in case:
        support = soft_step._support_order(
            case['expected.rows'], ends[:case['pairs'].shape[1]], case['faces_of'],
            case['slot'], case['sphere'], case['old_position'], case['radius'])
    else:
        return {f'order_{name}': value for name, value in made.items()}
    order, bounds = sweep_waves(support[0], ground)
    made.update(support_ends=support[0][order], support_facts=support[1][order],
                support_wave_bounds=bounds)
    if support[2] is not None:
        made.update(support_floor_member=support[2], support_floor_gap=support[3])
    return {f'order_{name}': value for name, value in made.items()}


RESOLVED = ('old_position', 'position', 'velocity', 'flagged', 'failed', 'memory_keys',
            'memory_forces', 'memory_held')


def resolve_inputs(case):
    """Copies of what a rows_case's step gives soft_step.resolve_collisions (every sphere
    flagged, none failed: the write-back clears the members' flags) and its constants."""
    from pool_sim.physics.contacts.soft_step import RESTING_FACTOR
    arrays = {name: case[name].copy() for name in (*STEP, 'memory_keys', 'memory_forces',
                                                    'memory_held')}
    count = case['radius'].size
    arrays.update(flagged=np.ones(count, dtype=np.uint8), failed=np.zeros(count, np.uint8))
    constants = (tuple(map(float, case['faces'])), bool(case['has_faces']),
                 tuple(map(float, case['contact'])), bool(case['has_friction']),
                 float(case['threshold']) / RESTING_FACTOR, tuple(map(float, case['settings'])),
                 float(case['dt']))
    return arrays, constants


def gpu_resolve(case, up):
    """DeviceCollisions.resolve on a rows_case's step: what it leaves, on the host."""
    from pool_sim.physics.cuda.device_collisions import DeviceCollisions
    arrays, constants = resolve_inputs(case)
    device = {name: up(value) for name, value in arrays.items()}
    put_back = DeviceCollisions().resolve(
        tuple(device[name] for name in STEP), (up(case['mass']), up(case['radius'])),
        up(case['identity']), tuple(device[name] for name in ('memory_keys', 'memory_forces',
                                                              'memory_held')),
        device['flagged'], device['failed'], constants)
    return {**{f'resolved_{name}': device[name].copy_to_host() for name in RESOLVED},
            'resolved_put_back': np.int64(put_back)}


def cpu_resolve(case):
    """soft_step.resolve_collisions on the CPU, coloured as the GPU colours (its settings'
    last entry 1): what gpu_resolve should leave."""
    from pool_sim.physics.contacts import soft_step
    arrays, constants = resolve_inputs(case)
    faces, has_faces, contact, has_friction, resting_speed, settings, dt = constants
    none = np.empty(0), np.empty(0, dtype=np.int64)
    put_back = soft_step.resolve_collisions(
        *(arrays[name] for name in STEP), case['mass'], case['radius'], faces, has_faces,
        contact, has_friction, resting_speed, (0.0, 0.0, 0.0), True, arrays['failed'], *none,
        dt, arrays['flagged'], case['identity'],
        *(arrays[name] for name in ('memory_keys', 'memory_forces', 'memory_held')),
        np.array([*settings[:4], 1.0]))
    return {**{f'resolved_{name}': arrays[name] for name in RESOLVED},
            'resolved_put_back': np.int64(put_back)}


def cpu_detect(case):
    """detect_contacts' Contacts on the CPU, as DeviceDetect's dict."""
    from pool_sim.physics.contacts.detection import detect_contacts
    none = np.empty(0), np.empty(0, dtype=np.int64)
    contacts, _, _ = detect_contacts(*(case[name] for name in DETECTION), float(case['dt']),
                                     *none)
    facts = np.vstack([contacts.normal, contacts.excess, contacts.added, contacts.closing])
    return {'pairs': contacts.pairs, 'facts': facts, 'order': contacts.order,
            'state': contacts.state}


def ready_of(case):
    """A stand-in for soft_step.Prepared with the case's arrays (copies)."""
    ready = types.SimpleNamespace(**{name: case[name].copy() for name in FIELDS})
    ready.support = tuple(case[name].copy() for name in SUPPORT)
    ready.sphere = np.arange(case['velocity'].shape[0] - 1)
    return ready


def cpu_solve(case):
    """(rows, velocity, moved) after soft_step's substeps and restitution pass on the CPU,
    as resolve_collisions runs them."""
    from pool_sim.physics.contacts import soft_step
    ready = ready_of(case)
    supported = np.zeros(ready.sphere.size, dtype=np.bool_)
    soft_step._substeps(ready.rows, ready.solve_order, ready.velocity, ready.moved,
                        ready.change, ready.inverse_mass, case['settings'], float(case['dt']),
                        ready.support, float(case['threshold']), supported)
    soft_step.restitution_pass(ready.rows, ready.solve_order, ready.velocity,
                               ready.inverse_mass, float(case['threshold']),
                               float(case['restitution']), ready.bounces)
    return ready.rows, ready.velocity, ready.moved


def write_cases(path):
    """cases() and detection_cases() into an npz, each array as label.name."""
    every = {**cases(), **detection_cases(), **rows_cases(), **order_cases(),
             **resolve_cases()}
    np.savez(path, **{f'{label}.{name}': value for label, case in every.items()
                      for name, value in case.items()})


def read_cases(path):
    """write_cases' file back as {label: case}."""
    chosen = {}
    with np.load(path) as kept:
        for key in kept.files:
            label, name = key.split('.', 1)
            chosen.setdefault(label, {})[name] = kept[key]
    return chosen


# The orders the simulator's threads take their indices in: the simulator runs a block's
# threads much as in index order, which is also the CPU's order, so a kernel racing two
# threads of a colour (or a wave) would still give the CPU's numbers; numbered backwards,
# it would not (a review's mutations: all contacts in one launch, all waves in one).
THREAD_ORDERS = ('forward', 'backward')


def numbered(order):
    """The simulator's cuda.grid, numbering threads in order ('forward' or 'backward')."""
    from numba.cuda.simulator import kernelapi
    module = kernelapi.FakeCUDAModule
    forward = module.forward_grid = getattr(module, 'forward_grid', module.grid)

    def backward(cuda_module, dimensions):
        return cuda_module.gridsize(dimensions) - 1 - forward(cuda_module, dimensions)
    module.grid = forward if order == 'forward' else backward


def main(cases_path, out_path):
    from pool_sim.physics.cuda import load_cuda
    from pool_sim.physics.cuda.device_detect import DeviceDetect
    from pool_sim.physics.cuda.device_solve import DeviceSolve, MODES
    results = {}
    cuda = load_cuda()

    def up(array):
        return cuda.to_device(np.ascontiguousarray(array))
    for order in THREAD_ORDERS:
        numbered(order)
        for label, case in read_cases(cases_path).items():
            if label.startswith('resolve'):
                results.update({f'{label}.{order}.{name}': value
                                for name, value in gpu_resolve(case, up).items()})
                continue
            if label.startswith(('rows', 'order')):
                made = gpu_orders(case, up)
                if label.startswith('rows'):
                    made.update(gpu_rows(case))
                    made.update(gpu_resolve(case, up))
                results.update({f'{label}.{order}.{name}': value
                                for name, value in made.items()})
                continue
            if label.startswith('detect'):
                found = DeviceDetect().detect(
                    *(cuda.to_device(np.ascontiguousarray(case[name])) for name in DETECTION),
                    float(case['dt']))
                results.update({f'{label}.{order}.{name}': value.copy_to_host()
                                for name, value in found.items()})
                continue
            for mode in MODES:
                left = DeviceSolve(mode).run(ready_of(case), case['settings'],
                                             float(case['dt']), float(case['threshold']),
                                             float(case['restitution']))
                results.update({f'{label}.{mode}.{order}.{name}': value
                                for name, value in zip(OUTPUTS, left)})
    np.savez(out_path, **results)


if __name__ == '__main__':
    main(*sys.argv[1:3])
