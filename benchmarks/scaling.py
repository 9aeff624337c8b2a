"""How cost grows with the number of spheres, beside what users would pick instead.

    .venv/bin/python -m benchmarks.scaling [--out results/scaling] [--largest 1000000]

Writes scaling.csv, scaling.md and scaling.png. All figures come from one run on one
machine: ns per sphere-step (median of repeats) for
  - pool_sim's default step (the compiled step, one thread, as the node runs it; and on
    every core), many steps per call (as Simulation.advance and the node's tick run it) and
    one step per call (Simulation.step from Python);
  - the price of each effect: gravity only, gravity + drag;
  - the seed-style object-per-sphere port (benchmarks/seed_port.py);
  - MuJoCo stepping N free spheres, fluid model on (density 1000, viscosity 1e-3 Pa*s)
    and off, contacts off, many steps per call (mj_step's nstep) and, with fluid, one;
  - a memory-bandwidth bound: the bytes the default step must read and write per sphere,
    divided by a copy bandwidth measured in the same run.
"""
import argparse
import os
from pathlib import Path
import platform

import numpy as np

from benchmarks.common import provenance, timed, write_csv
from benchmarks.seed_port import Environment, PointMass
from pool_sim.physics import DEFAULT_EFFECTS, Scene, Simulation, Spheres, stepper

DEFAULT = 'pool_sim default'
COUNTS = (1, 10, 100, 1_000, 10_000, 100_000, 1_000_000)
SEED_PORT_LARGEST = 10_000  # beyond, one step takes seconds
CORES = os.cpu_count()
MUJOCO_LARGEST = 10_000  # a model holds at most 65 534 bodies; 10 000 load in ~13 s
# The default step reads position, velocity, external force (3 doubles each), mass, radius,
# volume, cross-section, drag coefficient (1 each) and writes position and velocity (into
# the other pair of state arrays) and a byte that marks a sphere for the contact pass.
BYTES_PER_SPHERE_STEP = 8 * ((3 + 3 + 3 + 5) + (3 + 3)) + 1


def random_spheres(count, seed=0):
    """`count` spheres of random size and density through air and water, as arrays."""
    rng = np.random.default_rng(seed)
    radius = rng.uniform(0.02, 0.2, count)
    density = rng.uniform(100.0, 8000.0, count)
    return Spheres(
        names=tuple(f's{i}' for i in range(count)),
        position=np.ascontiguousarray(rng.uniform(-3.5, 3.5, (3, count))),
        velocity=np.zeros((3, count)), mass=density * 4.0 / 3.0 * np.pi * radius**3,
        radius=radius, drag_coefficient=np.full(count, 0.47), lift_area=np.pi * radius**2,
        lift_normal=np.tile([[0.0], [0.0], [1.0]], count), lift_coefficient=np.zeros(count),
        external_force=np.zeros((3, count)))


# Steps per call: a call of about 10^5 sphere-steps (a few ms), one step from 10^5 spheres.
SPHERE_STEPS_PER_CALL = 100_000


def steps_per_call(count):
    return max(1, SPHERE_STEPS_PER_CALL // count)


def pool_sim_cost(count, effects, threads=1, one_per_call=False):
    scene = Scene({'effects': list(effects)})
    sim = Simulation(scene, initial_spheres=random_spheres(count))
    stepper.use_threads(threads)
    try:
        if one_per_call:
            return timed(sim.step) / count * 1e9
        steps = steps_per_call(count)
        return timed(lambda: sim.run(steps, sim.max_step)) / steps / count * 1e9
    finally:
        stepper.use_threads(1)


def seed_port_cost(count):
    spheres = random_spheres(count)
    environment = Environment()
    for i in range(count):
        environment.add(PointMass(spheres.mass[i], spheres.radius[i], spheres.position[:, i]))
    return timed(lambda: environment.step(0.005), budget_s=1.5, repeats=5) / count * 1e9


def mujoco_cost(count, fluid, one_per_call=False):
    import mujoco
    spheres = random_spheres(count)
    bodies = ''.join(
        f'<body pos="{x:.4f} {y:.4f} {z:.4f}"><freejoint/>'
        f'<geom type="sphere" size="{r:.4f}" mass="{m:.6g}"/></body>'
        for (x, y, z), r, m in zip(spheres.position.T, spheres.radius, spheres.mass))
    medium = 'density="1000" viscosity="0.001"' if fluid else 'density="0" viscosity="0"'
    memory = max(64, count // 50)
    xml = (f'<mujoco><option timestep="0.005" {medium}><flag contact="disable"/></option>'
           f'<size memory="{memory}M"/><worldbody>{bodies}</worldbody></mujoco>')
    model = mujoco.MjModel.from_xml_string(xml)
    data = mujoco.MjData(model)
    if one_per_call:
        return timed(lambda: mujoco.mj_step(model, data)) / count * 1e9
    steps = steps_per_call(count)
    return timed(lambda: mujoco.mj_step(model, data, nstep=steps)) / steps / count * 1e9


def copy_bandwidth_bytes_per_s():
    """Read + write bytes per second of a 256 MiB numpy copy (median of 7)."""
    source = np.ones(32 * 1024 * 1024)
    target = np.empty_like(source)
    seconds = timed(lambda: np.copyto(target, source), budget_s=2.0)
    return 2 * source.nbytes / seconds


def memory_per_sphere():
    """(bytes in the core's arrays, bytes including names and the name index) per sphere."""
    count = 100_000
    spheres = random_spheres(count)
    arrays = sum(getattr(spheres, f).nbytes for f in (
        'position', 'velocity', 'mass', 'radius', 'drag_coefficient', 'lift_area',
        'lift_normal', 'lift_coefficient', 'external_force', 'volume', 'cross_section',
        'lift_slope', 'stall_angle'))
    names = sum(len(n) + 49 for n in spheres.names) + 8 * count  # str objects + tuple slots
    index = (spheres.index.__sizeof__())
    return arrays / count, (arrays + names + index) / count


def measure(largest):
    counts = [n for n in COUNTS if n <= largest]
    bandwidth = copy_bandwidth_bytes_per_s()
    bound = BYTES_PER_SPHERE_STEP / bandwidth * 1e9
    rows = []
    series = {
        DEFAULT: lambda n: pool_sim_cost(n, DEFAULT_EFFECTS),
        f'pool_sim default ({CORES} threads)': lambda n: pool_sim_cost(
            n, DEFAULT_EFFECTS, threads=CORES),
        'pool_sim default, one step per call': lambda n: pool_sim_cost(
            n, DEFAULT_EFFECTS, one_per_call=True),
        'pool_sim gravity only': lambda n: pool_sim_cost(n, ['gravity']),
        'pool_sim gravity + drag': lambda n: pool_sim_cost(n, ['gravity', 'drag']),
        'seed-style port': lambda n: seed_port_cost(n) if n <= SEED_PORT_LARGEST else None,
        'MuJoCo, fluid on': lambda n: mujoco_cost(n, True) if n <= MUJOCO_LARGEST else None,
        'MuJoCo, fluid on, one step per call': lambda n: mujoco_cost(
            n, True, one_per_call=True) if n <= MUJOCO_LARGEST else None,
        'MuJoCo, fluid off': lambda n: mujoco_cost(n, False) if n <= MUJOCO_LARGEST else None,
    }
    # The first timing in a process runs slow (9.9 against 5.5 µs for the same one-sphere
    # step, measured): one untimed round first.
    pool_sim_cost(1, DEFAULT_EFFECTS)
    # Count by count, every series in turn: the figures behind a ratio at one N are taken
    # within a minute of each other, not at either end of the run.
    for count in counts:
        for label, cost in series.items():
            value = cost(count)
            if value is not None:
                rows.append({'series': label, 'spheres': count, 'ns_per_sphere_step': value})
                print(f'{label:40} {count:>9} {value:12.1f} ns', flush=True)
    for count in counts:
        rows.append({'series': 'bandwidth bound', 'spheres': count, 'ns_per_sphere_step': bound})
    return rows, bandwidth


def markdown(rows, bandwidth):
    labels = list(dict.fromkeys(r['series'] for r in rows))
    counts = sorted({r['spheres'] for r in rows})
    value = {(r['series'], r['spheres']): r['ns_per_sphere_step'] for r in rows}
    arrays, total = memory_per_sphere()
    lines = [f'Machine: {platform.machine()}, {os.cpu_count()} cores, Python '
             f'{platform.python_version()}, numpy {np.__version__}; copy bandwidth '
             f'{bandwidth / 1e9:.1f} GB/s (read + write); the default step moves '
             f'{BYTES_PER_SPHERE_STEP} B per sphere.', '',
             f'ns per sphere-step (median of repeats; {SPHERE_STEPS_PER_CALL:,} sphere-steps a '
             'call unless one step per call):', '',
             '| series | ' + ' | '.join(f'{n:,}' for n in counts) + ' |',
             '|---|' + '---:|' * len(counts)]
    for label in labels:
        cells = [f'{value[(label, n)]:.1f}' if (label, n) in value else '—' for n in counts]
        lines.append(f'| {label} | ' + ' | '.join(cells) + ' |')
    default = DEFAULT

    def ratio(a, b, n):
        return value[(a, n)] / value[(b, n)] if (a, n) in value and (b, n) in value else None
    lines += ['', 'Ratios from this run:', '']
    for n in counts:
        parts = []
        for label, against in (('seed-style port', default), ('MuJoCo, fluid on', default),
                               ('MuJoCo, fluid off', default),
                               ('MuJoCo, fluid on, one step per call',
                                'pool_sim default, one step per call'),
                               (default, 'bandwidth bound')):
            r = ratio(label, against, n)
            if r is not None:
                parts.append(f'{label} / {against}: {r:.1f}')
        if parts:
            lines.append(f'- {n:,} spheres: ' + '; '.join(parts))
    one = 'pool_sim default, one step per call'
    lines += ['', f'Per-step time at 1 sphere: {value[(default, 1)] / 1000:.3f} µs many steps '
              f'a call, {value[(one, 1)] / 1000:.2f} µs one step a call.',
              f'Memory per sphere in the core: {arrays:.0f} B of arrays, {total:.0f} B with '
              'its name and the name index.']
    return '\n'.join(lines) + '\n'


def plot(rows, path):
    import matplotlib
    matplotlib.use('Agg')
    import matplotlib.pyplot as plt
    figure, axis = plt.subplots(figsize=(9, 6))
    for label in dict.fromkeys(r['series'] for r in rows):
        mine = [r for r in rows if r['series'] == label]
        style = '--' if label == 'bandwidth bound' else '-'
        axis.loglog([r['spheres'] for r in mine], [r['ns_per_sphere_step'] for r in mine],
                    style, marker='o', label=label)
    axis.set_xlabel('spheres')
    axis.set_ylabel('ns per sphere-step')
    axis.grid(True, which='both', alpha=0.3)
    axis.legend(fontsize=8)
    axis.set_title('pool_sim: cost per sphere-step against the number of spheres')
    figure.tight_layout()
    figure.savefig(path, dpi=90)


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument('--out', default='results/scaling')
    parser.add_argument('--largest', type=int, default=COUNTS[-1])
    args = parser.parse_args()
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    rows, bandwidth = measure(args.largest)
    write_csv(rows, out / 'scaling.csv')
    table = markdown(rows, bandwidth)
    (out / 'scaling.md').write_text(
        provenance('.venv/bin/python -m benchmarks.scaling') + '\n\n' + table)
    plot(rows, out / 'scaling.png')
    print(table)


if __name__ == '__main__':
    main()
