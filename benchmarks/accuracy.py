"""What accuracy costs in time: every integrator, a ladder of steps, four reference cases.

    .venv/bin/python -m benchmarks.accuracy [--out results/accuracy] [--quick]

Writes accuracy.csv, accuracy.md (the tables) and accuracy.png (work-precision diagram:
max position error against cost per simulated second, log-log, one line per integrator).
Error: the largest distance from the reference over samples every 0.1 s of the horizon.
Cost: ns per sphere-step, median of 31 turns of 20 steps (the integrators of a case take
turns: common.seconds_per_step_in_turns), measured with COST_SPHERES copies of the
case's spheres so that per-call overhead does not dominate. Every integrator is timed on the
numpy pipeline, so methods compare like for like; the default's fused kernel (what a user
gets) is timed too and reported beside it. Errors are the same on both (a test holds them
to agreement).
"""
import argparse
import csv
import math
import os
from pathlib import Path
import platform

import numpy as np

from benchmarks import reference
from benchmarks.common import seconds_per_step_in_turns, write_csv
from pool_sim.physics import DEFAULT_INTEGRATOR, INTEGRATORS, Scene, Simulation
from pool_sim.physics import fused
from pool_sim.physics.stability import stable_step_bound

RATES_HZ = (10, 30, 100, 200, 300, 1000, 3000, 10000)
SAMPLE_S = 0.1  # every rate on the ladder divides it, so all runs are sampled alike
COST_SPHERES = 10_000
FINE_RATE_HZ = 100_000
SMOOTH = ('falling steel', 'bobbing cork', 'ping-pong under water')
CONTACT_CASE = 'default pool (contacts)'
FLUID = ['gravity', 'buoyancy', 'drag']


def one_sphere(radius, mass, z0, **keys):
    return Scene({'sphere_names': ['ball'], 'ball.radius': radius, 'ball.mass': mass,
                  'ball.position': [0.0, 0.0, z0], **keys})


def steel_case():
    radius, z0 = 0.01, -1.0
    mass = 7850.0 * 4.0 / 3.0 * np.pi * radius**3
    scene = one_sphere(radius, mass, z0, effects=FLUID, **{'pool.min': [-5.0, -5.0, -100.0]})
    return scene, 2.0, lambda t: reference.falling_in_deep_water(t, z0, radius, mass)


def vertical_case(radius, mass, z0, horizon):
    scene = one_sphere(radius, mass, z0, effects=FLUID)
    return scene, horizon, lambda t: reference.vertical_through_the_surface(
        t, z0, 0.0, radius, mass)


def cork_case():
    radius = 0.2
    # Dropped with its bottom 2 mm in the water: bobs through the nonlinear cap.
    return vertical_case(radius, 250.0 * 4.0 / 3.0 * np.pi * radius**3, 0.198, 4.0)


def ping_pong_case():
    return vertical_case(0.02, 0.0027, -1.0, 3.0)


def pool_case():
    scene = Scene.default()
    horizon = 3.0
    fine = run(scene.with_values(integrator='rk4', physics_rate_hz=float(FINE_RATE_HZ)),
               horizon)
    return scene, horizon, fine


CASES = {'falling steel': steel_case, 'bobbing cork': cork_case,
         'ping-pong under water': ping_pong_case, CONTACT_CASE: pool_case}


def run(scene, horizon):
    """(samples, 3, n) positions every SAMPLE_S, from t = SAMPLE_S to the horizon."""
    sim = Simulation(scene)
    samples = []
    with np.errstate(all='ignore'):
        for _ in range(round(horizon / SAMPLE_S)):
            sim.advance(SAMPLE_S)
            samples.append(sim.spheres.position.copy())
    return np.array(samples)


def reference_positions(scene, horizon, answer):
    """The reference as (samples, 3, n): `answer` is an array or z(t) for a vertical drop."""
    if isinstance(answer, np.ndarray):
        return answer
    times = SAMPLE_S * np.arange(1, round(horizon / SAMPLE_S) + 1)
    positions = np.repeat(scene.build_spheres().position[None], len(times), axis=0)
    positions[:, 2, 0] = answer(times)
    return positions


def many_copies(scene, integrator, backend='numpy'):
    """The case's spheres copied to COST_SPHERES, stepped by `integrator`."""
    copies = COST_SPHERES // len(scene.sphere_names)
    params = {key: value for key, value in scene.values.items()
              if key.split('.')[0] not in scene.sphere_names}
    names = []
    for copy in range(copies):
        for name in scene.sphere_names:
            names.append(f'{name}{copy}')
            for key in ('mass', 'radius', 'position'):
                params[f'{name}{copy}.{key}'] = scene[f'{name}.{key}']
    params.update({'sphere_names': names, 'integrator': integrator})
    return Simulation(Scene(params), backend=backend)


def costs_ns_per_sphere_step(scene):
    """{integrator: ns per sphere-step on the numpy pipeline, 'fused': the default's kernel
    (nan where it does not apply)}, all timed in turns."""
    simulations = {integrator: many_copies(scene, integrator) for integrator in INTEGRATORS}
    if fused.supports(scene, 'cap'):
        simulations['fused'] = many_copies(scene, DEFAULT_INTEGRATOR, 'fused')
    seconds = seconds_per_step_in_turns(list(simulations.values()))
    count = len(simulations[DEFAULT_INTEGRATOR].spheres.names)
    costs = {name: s / count * 1e9 for name, s in zip(simulations, seconds)}
    costs.setdefault('fused', float('nan'))
    return costs


def observed_order(rows):
    """Slope of log(error) against log(dt) over the three smallest steps whose error is
    above 1e-11 m (below that, round-off sets the error, not the method)."""
    usable = [(r['dt_s'], r['max_error_m']) for r in rows
              if r['stable'] and r['max_error_m'] > 1e-11]
    usable = sorted(usable)[:3]
    if len(usable) < 2:
        return float('nan')
    dt, error = np.log([u[0] for u in usable]), np.log([u[1] for u in usable])
    return float(np.polyfit(dt, error, 1)[0])


def measure(quick):
    rows = []
    rates = RATES_HZ[:5] if quick else RATES_HZ
    for case, make in CASES.items():
        if quick and case == CONTACT_CASE:
            continue
        scene, horizon, answer = make()
        expected = reference_positions(scene, horizon, answer)
        travel = float(np.max(np.linalg.norm(expected - scene.build_spheres().position[None],
                                             axis=1)))
        costs = costs_ns_per_sphere_step(scene)
        fused_cost = costs['fused']
        for integrator in INTEGRATORS:
            cost = costs[integrator]
            bound = stable_step_bound(scene.with_values(integrator=integrator))
            for rate in rates:
                positions = run(scene.with_values(integrator=integrator,
                                                  physics_rate_hz=float(rate)), horizon)
                error = float(np.max(np.linalg.norm(positions - expected, axis=1)))
                stable = bool(np.all(np.isfinite(positions))) and error < 10.0 * travel
                rows.append({
                    'case': case, 'integrator': integrator, 'rate_hz': rate,
                    'dt_s': 1.0 / rate, 'max_error_m': error if stable else float('inf'),
                    'relative_error': error / travel if stable else float('inf'),
                    'stable': stable, 'ns_per_sphere_step': cost,
                    'us_per_sphere_second': cost * rate / 1000.0,
                    'stable_step_bound_s': bound, 'travel_m': travel,
                    'fused_default_ns_per_sphere_step': fused_cost})
            print(f'{case:24} {integrator:24} {cost:8.0f} ns/sphere-step', flush=True)
    return rows


def read_csv(path):
    """The rows write_csv wrote, with their types back."""
    with open(path, newline='') as stream:
        rows = list(csv.DictReader(stream))
    for row in rows:
        for key, value in row.items():
            if key in ('case', 'integrator'):
                continue
            row[key] = (value == 'True') if key == 'stable' else float(value)
        row['rate_hz'] = int(row['rate_hz'])
    return rows


def markdown(rows):
    lines = [f'Machine: {platform.machine()}, {os.cpu_count()} cores, '
             f'Python {platform.python_version()}, numpy {np.__version__}; cost measured '
             f'with {COST_SPHERES} spheres.', '']
    rates = sorted({r['rate_hz'] for r in rows})
    for case in dict.fromkeys(r['case'] for r in rows):
        case_rows = [r for r in rows if r['case'] == case]
        travel = case_rows[0]['travel_m']
        lines += [f'**{case}** — max position error in m (travel {travel:.3g} m); '
                  'cost in ns per sphere-step', '',
                  '| integrator | ns/sphere-step | stable step bound | '
                  + ' | '.join(f'{r:g} Hz' for r in rates) + ' |',
                  '|---|---:|---:|' + '---:|' * len(rates)]
        for integrator in dict.fromkeys(r['integrator'] for r in case_rows):
            mine = {r['rate_hz']: r for r in case_rows if r['integrator'] == integrator}
            bound = mine[rates[0]]['stable_step_bound_s']
            cells = [f'{mine[r]["max_error_m"]:.2g}' if mine[r]['stable'] else 'unstable'
                     for r in rates]
            lines.append(f'| {integrator} | {mine[rates[0]]["ns_per_sphere_step"]:.0f} | '
                         + ('none' if bound == float('inf') else f'{bound * 1e3:.3g} ms')
                         + ' | ' + ' | '.join(cells) + ' |')
        lines += [f'| {DEFAULT_INTEGRATOR}, fused kernel | '
                  f'{case_rows[0]["fused_default_ns_per_sphere_step"]:.0f} | none | '
                  'same errors as above |' + ' |' * (len(rates) - 1), '']
    lines += ['**Observed order** (slope of log error against log step, three smallest '
              'steps above round-off)', '',
              '| integrator | ' + ' | '.join(SMOOTH) + ' |', '|---|' + '---:|' * len(SMOOTH)]
    for integrator in INTEGRATORS:
        orders = [observed_order([r for r in rows if r['case'] == case
                                  and r['integrator'] == integrator]) for case in SMOOTH]
        lines.append(f'| {integrator} | ' + ' | '.join(f'{o:.2f}' for o in orders) + ' |')
    lines += ['', '**Cheapest within 1 % of the travel at 200 Hz**', '']
    for case in dict.fromkeys(r['case'] for r in rows):
        good = [r for r in rows if r['case'] == case and r['rate_hz'] == 200
                and r['relative_error'] <= 0.01]
        best = min(good, key=lambda r: r['ns_per_sphere_step'], default=None)
        line = f'- {case}: ' + (f'{best["integrator"]} ({best["ns_per_sphere_step"]:.0f} '
                                f'ns/sphere-step, error {best["relative_error"]:.2%})'
                                if best else 'none')
        default = next(r for r in rows if r['case'] == case and r['rate_hz'] == 200
                       and r['integrator'] == DEFAULT_INTEGRATOR)
        if not math.isnan(default['fused_default_ns_per_sphere_step']):
            line += (f'; as users run it, the default\'s fused kernel: '
                     f'{default["fused_default_ns_per_sphere_step"]:.0f} ns/sphere-step, error '
                     f'{default["relative_error"]:.2%}')
        lines.append(line)
    lines += ['', 'The first name on each line is the cheapest on the numpy pipeline, where '
              'every method runs alike; the fused kernel is what the default costs in use.']
    costs = {r['integrator']: r['ns_per_sphere_step'] for r in rows
             if r['case'] == CONTACT_CASE}
    if costs:
        pool = [r for r in rows if r['case'] == CONTACT_CASE][0]
        lines += ['', f'Cost ratio RK4 / default on the pool: '
                  f'{costs["rk4"] / costs[DEFAULT_INTEGRATOR]:.2f} on the numpy pipeline, '
                  f'{costs["rk4"] / pool["fused_default_ns_per_sphere_step"]:.1f} against '
                  'the default as users run it (fused kernel)']
    return '\n'.join(lines) + '\n'


def plot(rows, path):
    import matplotlib
    matplotlib.use('Agg')
    import matplotlib.pyplot as plt
    cases = list(dict.fromkeys(r['case'] for r in rows))
    figure, axes = plt.subplots(2, 2, figsize=(11, 8.5))
    for axis, case in zip(axes.flat, cases):
        for integrator in INTEGRATORS:
            mine = [r for r in rows if r['case'] == case and r['integrator'] == integrator
                    and r['stable'] and r['max_error_m'] > 0]
            axis.loglog([r['us_per_sphere_second'] for r in mine],
                        [r['max_error_m'] for r in mine], marker='o', label=integrator)
            if integrator == DEFAULT_INTEGRATOR and mine and not math.isnan(
                    mine[0]['fused_default_ns_per_sphere_step']):
                # Same errors, the cost of the default as users run it.
                axis.loglog([r['fused_default_ns_per_sphere_step'] * r['rate_hz'] / 1000.0
                             for r in mine], [r['max_error_m'] for r in mine], 'k--',
                            marker='.', label=f'{integrator}, fused kernel')
        axis.set_title(case)
        axis.set_xlabel('cost: µs per sphere per simulated second')
        axis.set_ylabel('max position error, m')
        axis.grid(True, which='both', alpha=0.3)
    axes.flat[0].legend(fontsize=8)
    figure.suptitle('pool_sim work-precision: steps from 1/10 s to 1/10 000 s')
    figure.tight_layout()
    figure.savefig(path, dpi=90)


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument('--out', default='results/accuracy')
    parser.add_argument('--quick', action='store_true', help='coarse steps, no pool case')
    parser.add_argument('--tables-only', action='store_true',
                        help='remake the tables and the plot from the CSV of an earlier run')
    args = parser.parse_args()
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    fused.use_threads(1)  # the fused kernel as the node runs it
    if args.tables_only:
        rows = read_csv(out / 'accuracy.csv')
    else:
        rows = measure(args.quick)
        write_csv(rows, out / 'accuracy.csv')
    table = markdown(rows)
    (out / 'accuracy.md').write_text(table)
    plot(rows, out / 'accuracy.png')
    print(table)


if __name__ == '__main__':
    main()
