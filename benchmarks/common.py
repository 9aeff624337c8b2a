"""Shared by the benchmarks: many-sphere scenes, median timers, CPU time of a process, CSV."""
import csv
import os
from pathlib import Path
import statistics
import time

import numpy as np

from pool_sim.physics import DEFAULT_EFFECTS, Scene


def many_spheres_scene(count, effects, seed=0, **keys):
    """`count` spheres of random size and density scattered through air and water."""
    rng = np.random.default_rng(seed)
    names = [f's{i}' for i in range(count)]
    params = {'sphere_names': names, 'effects': list(effects), **keys}
    radius = rng.uniform(0.02, 0.2, count)
    density = rng.uniform(100.0, 8000.0, count)
    position = rng.uniform([-3.5, -3.5, -3.5], [3.5, 3.5, 3.5], (count, 3))
    for i, name in enumerate(names):
        params[f'{name}.radius'] = float(radius[i])
        params[f'{name}.mass'] = float(density[i] * 4 / 3 * np.pi * radius[i] ** 3)
        params[f'{name}.position'] = [float(v) for v in position[i]]
    return Scene(params)


def dropped_spheres(count, seed=0, least_density=300.0):
    """(position (count, 3) m, radius (count,) m, mass (count,) kg): a lattice above the
    water, 0.13 m apart, slightly jittered; densities uniform from least_density to 3000
    kg/m^3 (below the water's 1000 a sphere floats)."""
    rng = np.random.default_rng(seed)
    side = 22
    index = np.arange(count)
    lattice = np.stack([index % side, (index // side) % side, index // (side * side)], 1)
    position = (lattice - [side / 2 - 0.5, side / 2 - 0.5, 0.0]) * 0.13 + [0.0, 0.0, 0.3]
    position += rng.uniform(-0.005, 0.005, position.shape)
    radius = rng.uniform(0.03, 0.06, count)
    density = rng.uniform(least_density, 3000.0, count)
    return position, radius, density * 4.0 / 3.0 * np.pi * radius**3


def dropped_scene(count, collisions=True, solver='sequential_impulses', rate_hz=200.0,
                  restitution=0.5, friction=0.6, least_density=300.0):
    """benchmarks/collisions.py's scene: dropped_spheres with the default effects (and
    `collisions`, resolved by solver), at rate_hz, restitution and friction (static and
    kinetic) as given."""
    position, radius, mass = dropped_spheres(count, least_density=least_density)
    effects = list(DEFAULT_EFFECTS) + (['collisions'] if collisions else [])
    return Scene({'sphere_names': [f's{i}' for i in range(count)], 'effects': effects,
                  'physics_rate_hz': rate_hz, 'contact.restitution': restitution,
                  'contact.static_friction': friction, 'contact.kinetic_friction': friction,
                  'contact_solver': solver, 'spheres.position': position.ravel().tolist(),
                  'spheres.radius': radius.tolist(), 'spheres.mass': mass.tolist()})


def scattered_spheres(count):
    """(position (count, 3) m, radius (count,) m, mass (count,) kg): benchmarks/node_rate's
    spheres, anywhere in the cube from -3.5 to 3.5 m (air and water; some overlap at the
    start), radii 0.02 to 0.1 m, densities 100 to 3000 kg/m^3, in no spatial order; rounded
    as its params file writes them (mass to 1 mg, radius to 0.1 mm, position to 1 mm)."""
    rng = np.random.default_rng(count)
    position, radius, mass = np.empty((count, 3)), np.empty(count), np.empty(count)
    for i in range(count):  # drawn sphere by sphere: the params files of earlier runs
        drawn = float(rng.uniform(0.02, 0.1))
        mass[i] = round(float(rng.uniform(100.0, 3000.0) * 4.0 / 3.0 * np.pi * drawn**3), 6)
        radius[i] = round(drawn, 4)
        position[i] = np.round(rng.uniform(-3.5, 3.5, 3), 3)
    return position, radius, mass


def scattered_scene(count, collisions=True, solver=None):
    """The node's scene in benchmarks/node_rate (scattered_spheres, the node's defaults
    but for the effects: the default ones and `collisions`, resolved by solver)."""
    position, radius, mass = scattered_spheres(count)
    keys = {'contact_solver': solver} if solver else {}
    return Scene({'sphere_names': [f's{i}' for i in range(count)],
                  'effects': list(DEFAULT_EFFECTS) + (['collisions'] if collisions else []),
                  'spheres.position': position.ravel().tolist(),
                  'spheres.radius': radius.tolist(), 'spheres.mass': mass.tolist(), **keys})


def timed(function, budget_s=0.6, repeats=7):
    """Median seconds per call: each repeat runs enough calls to last budget_s/repeats."""
    start = time.perf_counter()
    function()
    once = max(time.perf_counter() - start, 1e-7)
    inner = max(1, int(budget_s / repeats / once))
    samples = []
    for _ in range(repeats):
        start = time.perf_counter()
        for _ in range(inner):
            function()
        samples.append((time.perf_counter() - start) / inner)
    return statistics.median(samples)


def cpu_seconds(pid):
    """User + system CPU seconds a process has used so far (from /proc)."""
    with open(f'/proc/{pid}/stat') as stat:
        fields = stat.read().rsplit(')', 1)[1].split()
    return (int(fields[11]) + int(fields[12])) / os.sysconf('SC_CLK_TCK')


def seconds_per_step_in_turns(simulations, steps=20, repeats=31, restart=False):
    """Median seconds per step of each simulation, timed in turns: each repeat runs every
    simulation `steps` steps in a row in one compiled call (as Simulation.advance does), so
    that the shared machine's slow spells fall on all of them alike and their ratios hold.
    restart: every repeat starts from the initial state (a sphere's cost can depend on where
    it is)."""
    for simulation in simulations:
        simulation.step()  # compiles (or loads) the step, outside the timing
    samples = [[] for _ in simulations]
    for _ in range(repeats):
        for simulation, mine in zip(simulations, samples):
            if restart:
                simulation.reset()
            start = time.perf_counter()
            simulation.run(steps, simulation.max_step)
            mine.append((time.perf_counter() - start) / steps)
    return [statistics.median(mine) for mine in samples]


def write_results(path, text):
    """A results file: text written to path (its folder made if it has none yet), and
    printed."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(text)
    print(text)


def write_csv(rows, path):
    """Rows (dicts with the same keys) as a CSV file with a header."""
    with open(path, 'w', newline='') as stream:
        writer = csv.DictWriter(stream, fieldnames=list(rows[0]))
        writer.writeheader()
        writer.writerows(rows)


def provenance(command: str) -> str:
    """One line a results file starts with: the command that made it, the commit (marked
    when pool_sim/ or benchmarks/, the code a figure rests on, had uncommitted changes),
    the date and the machine."""
    import datetime
    import platform
    import subprocess
    root = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))

    def git(*arguments):
        try:
            return subprocess.run(['git', *arguments], cwd=root, capture_output=True,
                                  text=True, timeout=10).stdout.strip()
        except OSError:
            return ''
    # POOL_SIM_COMMIT: where the tree came without its .git (a device machine's copy).
    commit = git('rev-parse', '--short', 'HEAD') or os.environ.get('POOL_SIM_COMMIT',
                                                                   'unknown')
    if git('status', '--porcelain', '--untracked-files=no', '--', 'pool_sim', 'benchmarks'):
        commit += ' with uncommitted changes'
    model = next((line.split(':', 1)[1].strip() for line in open('/proc/cpuinfo')
                  if line.startswith('model name')), platform.processor())
    return (f'Made by `{command}` at commit {commit}, {datetime.date.today().isoformat()}; '
            f'{platform.machine()}, {os.cpu_count()} cores ({model}), Python '
            f'{platform.python_version()}.')
