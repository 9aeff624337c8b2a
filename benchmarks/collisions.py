"""Spheres dropped into the pool, colliding and settling: pool_sim with and without the
`collisions` effect (with each contact solver), beside MuJoCo (contacts and fluid on) and
PyBullet, same spheres, same step, in turns. results/collisions was written with `--seconds 2 --repeats 1` (PyBullet
takes ~5 min a run at 10 000).

    .venv/bin/python -m benchmarks.collisions [--out results/collisions] [--counts 1000 10000]
        [--seconds 3]

The scene: `count` spheres of radius 0.03-0.06 m and density 300-3000 kg/m^3 (some float,
most sink) in a lattice above the water of the default pool (8 m cube, surface at 0), at
rest, dropped at t = 0 and stepped at 200 Hz for `seconds` of simulated time. Cost is wall
time / (spheres x steps), the median of `--repeats` runs from the same start, each engine
in turn so the machine's slow spells fall on all alike, and of more runs of any engine
whose runs add up to under MIN_TIMED_S (one run of a few hundredths of a second is one
slow spell from double). pool_sim runs its default effects
(gravity, buoyancy, drag, wave_radiation, contact, friction), then the same plus
collisions; MuJoCo its fluid model (density 1000, viscosity 1e-3, everywhere: it has no
surface) with contacts against each other, the floor and the walls; PyBullet its contacts
(it has no fluid model). Writes collisions.md and collisions.csv, with the state pool_sim
ends in (the largest overlap left and how fast the spheres still move) and the deepest overlap
during a second, untimed run looked at every SAMPLE_STEPS steps.
"""
import argparse
from pathlib import Path
import platform
import statistics
import sys
import time

import numpy as np

from benchmarks.common import dropped_scene, dropped_spheres, provenance, write_csv
from pool_sim.physics import Simulation, stepper
from pool_sim.physics.contacts import overlaps

RATE_HZ = 200.0
RESTITUTION, FRICTION = 0.5, 0.6
POOL_MIN, POOL_MAX = (-4.0, -4.0, -4.0), (4.0, 4.0, 4.0)


def pool_sim_run(count, collisions, solver='sequential_impulses'):
    scene = dropped_scene(count, collisions, solver, RATE_HZ, RESTITUTION, FRICTION)
    simulation = Simulation(scene)
    simulation.prepare()

    def run(steps):
        simulation.reset()
        start = time.perf_counter()
        simulation.run(steps, 1.0 / RATE_HZ)
        return time.perf_counter() - start
    return run, simulation


def mujoco_run(count):
    import mujoco
    position, radius, mass = dropped_spheres(count)
    bodies = ''.join(
        f'<body pos="{x:.4f} {y:.4f} {z:.4f}"><freejoint/>'
        f'<geom type="sphere" size="{r:.4f}" mass="{m:.6g}"/></body>'
        for (x, y, z), r, m in zip(position, radius, mass))
    half = (POOL_MAX[0] - POOL_MIN[0]) / 2
    walls = ''.join(
        f'<geom type="box" size="{sx} {sy} {sz}" pos="{px} {py} {pz}"/>'
        for sx, sy, sz, px, py, pz in (
            (0.1, half, half, POOL_MIN[0] - 0.1, 0, 0), (0.1, half, half, POOL_MAX[0] + 0.1, 0, 0),
            (half, 0.1, half, 0, POOL_MIN[1] - 0.1, 0), (half, 0.1, half, 0, POOL_MAX[1] + 0.1, 0)))
    xml = (f'<mujoco><option timestep="{1 / RATE_HZ}" density="1000" viscosity="0.001"/>'
           f'<default><geom friction="{FRICTION} 0.005 0.0001"/></default>'
           f'<size memory="{max(256, count // 20)}M"/><worldbody>'
           f'<geom type="plane" size="{half} {half} 0.1" pos="0 0 {POOL_MIN[2]}"/>{walls}'
           f'{bodies}</worldbody></mujoco>')
    model = mujoco.MjModel.from_xml_string(xml)
    data = mujoco.MjData(model)

    def run(steps):
        mujoco.mj_resetData(model, data)
        start = time.perf_counter()
        mujoco.mj_step(model, data, nstep=steps)
        return time.perf_counter() - start
    return run, (model, data)


def pybullet_run(count):
    import pybullet
    position, radius, mass = dropped_spheres(count)
    client = pybullet.connect(pybullet.DIRECT)
    pybullet.setGravity(0, 0, -9.81, physicsClientId=client)
    pybullet.setTimeStep(1.0 / RATE_HZ, physicsClientId=client)
    plane = pybullet.createCollisionShape(pybullet.GEOM_PLANE, physicsClientId=client)
    pybullet.createMultiBody(0, plane, basePosition=[0, 0, POOL_MIN[2]],
                             physicsClientId=client)
    half = (POOL_MAX[0] - POOL_MIN[0]) / 2
    for extents, centre in (([0.1, half, half], [POOL_MIN[0] - 0.1, 0, 0]),
                            ([0.1, half, half], [POOL_MAX[0] + 0.1, 0, 0]),
                            ([half, 0.1, half], [0, POOL_MIN[1] - 0.1, 0]),
                            ([half, 0.1, half], [0, POOL_MAX[1] + 0.1, 0])):
        box = pybullet.createCollisionShape(pybullet.GEOM_BOX, halfExtents=extents,
                                            physicsClientId=client)
        pybullet.createMultiBody(0, box, basePosition=centre, physicsClientId=client)
    bodies = []
    for (x, y, z), r, m in zip(position, radius, mass):
        shape = pybullet.createCollisionShape(pybullet.GEOM_SPHERE, radius=float(r),
                                              physicsClientId=client)
        body = pybullet.createMultiBody(float(m), shape, basePosition=[x, y, z],
                                        physicsClientId=client)
        pybullet.changeDynamics(body, -1, restitution=RESTITUTION, lateralFriction=FRICTION,
                                physicsClientId=client)
        bodies.append(body)
    start_state = pybullet.saveState(physicsClientId=client)

    def run(steps):
        pybullet.restoreState(start_state, physicsClientId=client)
        start = time.perf_counter()
        for _ in range(steps):
            pybullet.stepSimulation(physicsClientId=client)
        return time.perf_counter() - start
    return run, client


SAMPLE_STEPS = 10
MIN_TIMED_S = 2.0  # each engine's runs add up to at least this, s
MAX_RUNS = 200  # or it has run this often (a run of no steps takes no time)


def deepest_overlap(simulation):
    """The deepest overlap of any pair of spheres now, / the smaller radius."""
    radius = simulation.spheres.radius
    pairs, depth = overlaps(simulation.spheres.position, radius)
    smaller = np.minimum(radius[pairs[0]], radius[pairs[1]])
    return float(np.max(depth / smaller)) if depth.size else 0.0


ENGINES = ('pool_sim', 'pool_sim + collisions', 'pool_sim + collisions (soft_step)',
           'MuJoCo (contacts + fluid)', 'PyBullet (contacts)')
OURS = {'pool_sim + collisions': 'sequential_impulses',
        'pool_sim + collisions (soft_step)': 'soft_step'}


def measure(count, seconds, repeats):
    stepper.use_threads(1)  # as MuJoCo and PyBullet step: one thread each
    steps = int(round(seconds * RATE_HZ))
    engines = dict(zip(ENGINES, (pool_sim_run(count, False), pool_sim_run(count, True),
                                 pool_sim_run(count, True, 'soft_step'), mujoco_run(count),
                                 pybullet_run(count))))
    times = {name: [] for name in engines}
    for _ in range(repeats):
        for name, (run, _) in engines.items():
            times[name].append(run(steps))
            print(f'{count} spheres, {name}: {times[name][-1]:.2f} s', flush=True)
    # A run of a few hundredths of a second is one slow spell away from double: the quick
    # engines run again, in turns, until each has MIN_TIMED_S of runs to take the median of.
    while True:
        short = [name for name in engines
                 if sum(times[name]) < MIN_TIMED_S and len(times[name]) < MAX_RUNS]
        if not short:
            break
        for name in short:
            times[name].append(engines[name][0](steps))
    row = {'spheres': count, 'steps': steps}
    for name in engines:
        row[name] = statistics.median(times[name]) / (count * steps) * 1e9
        row[f'{name} runs'] = len(times[name])
    for name, solver in OURS.items():
        row.update({f'{solver}: {key}': value
                    for key, value in end_and_landing(engines[name][1], steps).items()})
    import pybullet
    pybullet.disconnect(engines['PyBullet (contacts)'][1])
    return row


def end_and_landing(simulation, steps):
    """Where simulation ends (after the last timed run), and the deepest overlap in a run
    again, looked at every SAMPLE_STEPS steps (untimed: the landing in water, not the end, is
    where spheres are pressed deepest into each other)."""
    speed = np.linalg.norm(simulation.spheres.velocity, axis=0)
    found = {'largest overlap / smaller radius': deepest_overlap(simulation),
             'median speed m/s': float(np.median(speed)),
             'rms speed m/s': float(np.sqrt(np.mean(speed**2)))}
    simulation.reset()
    deepest = []
    for done in range(0, steps, SAMPLE_STEPS):
        simulation.run(min(SAMPLE_STEPS, steps - done), 1.0 / RATE_HZ)
        deepest.append(deepest_overlap(simulation))
    found['deepest overlap during the run'] = max(deepest)
    found['median of the sampled deepest'] = float(np.median(deepest))
    return found


def markdown(rows, seconds, repeats):
    lines = ['# Spheres dropped into the pool, colliding: ns per sphere-step',
             '', f'{platform.processor() or platform.machine()}, one thread, '
             f'{seconds:g} s simulated at {RATE_HZ:g} Hz from a lattice above the water '
             f'(benchmarks/collisions.py), median of {repeats} runs in turns, then more of '
             f'each engine whose runs added up to under {MIN_TIMED_S:g} s until they did or it '
             f'had run {MAX_RUNS} times '
             '(runs: ' + '; '.join(
                 f"{row['spheres']} spheres " + ', '.join(
                     f"{name} {row[name + ' runs']}" for name in ENGINES) for row in rows)
             + ').', '',
             '| spheres | pool_sim | pool_sim + collisions | collisions cost x | '
             'pool_sim + collisions (soft_step) | soft_step cost x | MuJoCo '
             '(contacts + fluid) | PyBullet (contacts) | MuJoCo / ours | PyBullet / ours | '
             'MuJoCo / soft_step | PyBullet / soft_step |',
             '|---:|' + '---:|' * 11]
    for row in rows:
        ours, soft = row['pool_sim + collisions'], row['pool_sim + collisions (soft_step)']
        mujoco, pybullet = row['MuJoCo (contacts + fluid)'], row['PyBullet (contacts)']
        lines.append(
            f"| {row['spheres']} | {row['pool_sim']:.0f} | {ours:.0f} | "
            f"{ours / row['pool_sim']:.2f} | {soft:.0f} | {soft / row['pool_sim']:.2f} | "
            f"{mujoco:.0f} | {pybullet:.0f} | {mujoco / ours:.1f} | {pybullet / ours:.1f} | "
            f"{mujoco / soft:.1f} | {pybullet / soft:.1f} |")
    lines += ['', 'pool_sim + collisions, each solver: where it ends (after the last run), '
              f'and the deepest overlap in a run looked at every {SAMPLE_STEPS} steps:', '',
              '| spheres | solver | largest overlap / smaller radius, at the end | '
              'median speed m/s | rms speed m/s | deepest overlap during the run | '
              'median of the sampled deepest |', '|---:|---|---:|---:|---:|---:|---:|']
    for row in rows:
        for solver in OURS.values():
            lines.append(
                f"| {row['spheres']} | {solver} | "
                f"{row[solver + ': largest overlap / smaller radius']:.4f} | "
                f"{row[solver + ': median speed m/s']:.2g} | "
                f"{row[solver + ': rms speed m/s']:.2g} | "
                f"{row[solver + ': deepest overlap during the run']:.4f} | "
                f"{row[solver + ': median of the sampled deepest']:.4f} |")
    return '\n'.join(lines) + '\n'


def main():
    parser = argparse.ArgumentParser(description=__doc__.split('\n')[0])
    parser.add_argument('--out', default='results/collisions')
    parser.add_argument('--counts', type=int, nargs='+', default=[1000, 10000])
    parser.add_argument('--seconds', type=float, default=3.0)
    parser.add_argument('--repeats', type=int, default=3)
    args = parser.parse_args()
    if round(args.seconds * RATE_HZ) < 1:
        parser.error(f'--seconds: at least one step of {1 / RATE_HZ:g} s')
    rows = [measure(count, args.seconds, args.repeats) for count in args.counts]
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    write_csv(rows, out / 'collisions.csv')
    command = ' '.join(['.venv/bin/python -m benchmarks.collisions', *sys.argv[1:]])
    text = provenance(command) + '\n\n' + markdown(rows, args.seconds, args.repeats)
    (out / 'collisions.md').write_text(text)
    print(text)


if __name__ == '__main__':
    main()
