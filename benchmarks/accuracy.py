"""What accuracy costs in time: every integrator, a ladder of steps, four reference cases.

    .venv/bin/python -m benchmarks.accuracy [--out results/accuracy] [--quick]

Writes accuracy.csv, accuracy.md (the tables) and accuracy.png (work-precision diagram:
max position error against cost per simulated second, log-log, one line per integrator).
Error: the largest distance from the reference over samples every 0.1 s of the horizon.
Cost: ns per sphere-step of the compiled step as users run it (one thread, many steps a
call), with the case's spheres copied to 3 (the size of the default pool: median of 15 turns
of 2 000 steps) and to 10 000 (median of 31 turns of 20 steps); the integrators of a case
take turns (common.seconds_per_step_in_turns).
"""
import argparse
import csv
import os
from pathlib import Path
import platform

import numpy as np

from benchmarks import reference
from benchmarks.common import provenance, seconds_per_step_in_turns, write_csv
from pool_sim.physics import DEFAULT_INTEGRATOR, INTEGRATORS, Scene, Simulation
from pool_sim.physics import stepper
from pool_sim.physics.stability import stable_step_bound

RATES_HZ = (10, 30, 100, 200, 300, 1000, 3000, 10000)
SAMPLE_S = 0.1  # every rate on the ladder divides it, so all runs are sampled alike
COST_SPHERES = (3, 10_000)  # few: the default pool's size; many
COST_STEPS = {3: (2000, 15), 10_000: (20, 31)}  # steps a call, turns
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


def many_copies(scene, integrator, count):
    """The case's spheres copied to `count` (spheres beyond the first copies of the last
    one), stepped by `integrator`."""
    params = {key: value for key, value in scene.values.items()
              if key.split('.')[0] not in scene.sphere_names}
    names = []
    for copy in range(count):
        name = scene.sphere_names[copy % len(scene.sphere_names)]
        names.append(f'{name}{copy}')
        for key in ('mass', 'radius', 'position'):
            params[f'{name}{copy}.{key}'] = scene[f'{name}.{key}']
    params.update({'sphere_names': names, 'integrator': integrator})
    return Simulation(Scene(params))


def costs_ns_per_sphere_step(scene):
    """{(integrator, spheres): ns per sphere-step}, at each of COST_SPHERES, the integrators
    timed in turns."""
    costs = {}
    for count in COST_SPHERES:
        simulations = [many_copies(scene, integrator, count) for integrator in INTEGRATORS]
        steps, turns = COST_STEPS[count]
        seconds = seconds_per_step_in_turns(simulations, steps, turns, restart=True)
        costs.update({(integrator, count): s / count * 1e9
                      for integrator, s in zip(INTEGRATORS, seconds)})
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
        few, many = COST_SPHERES
        for integrator in INTEGRATORS:
            cost, cost_few = costs[(integrator, many)], costs[(integrator, few)]
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
                    'ns_per_sphere_step_few': cost_few,
                    'us_per_sphere_second': cost * rate / 1000.0,
                    'stable_step_bound_s': bound, 'travel_m': travel})
            print(f'{case:24} {integrator:24} {cost_few:8.1f} {cost:8.1f} ns/sphere-step',
                  flush=True)
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
             f'Python {platform.python_version()}, numpy {np.__version__}; cost of the '
             f'compiled step with the case\'s spheres copied to {COST_SPHERES[0]} and to '
             f'{COST_SPHERES[1]:,}.', '']
    rates = sorted({r['rate_hz'] for r in rows})
    for case in dict.fromkeys(r['case'] for r in rows):
        case_rows = [r for r in rows if r['case'] == case]
        travel = case_rows[0]['travel_m']
        lines += [f'**{case}** — max position error in m (travel {travel:.3g} m); '
                  f'cost in ns per sphere-step at {COST_SPHERES[0]} and {COST_SPHERES[1]:,} '
                  'spheres', '',
                  f'| integrator | ns, {COST_SPHERES[0]} | ns, {COST_SPHERES[1]:,} | '
                  'stable step bound | ' + ' | '.join(f'{r:g} Hz' for r in rates) + ' |',
                  '|---|---:|---:|---:|' + '---:|' * len(rates)]
        for integrator in dict.fromkeys(r['integrator'] for r in case_rows):
            mine = {r['rate_hz']: r for r in case_rows if r['integrator'] == integrator}
            bound = mine[rates[0]]['stable_step_bound_s']
            cells = [f'{mine[r]["max_error_m"]:.2g}' if mine[r]['stable'] else 'unstable'
                     for r in rates]
            lines.append(f'| {integrator} | {mine[rates[0]]["ns_per_sphere_step_few"]:.0f} | '
                         f'{mine[rates[0]]["ns_per_sphere_step"]:.0f} | '
                         + ('none' if bound == float('inf') else f'{bound * 1e3:.3g} ms')
                         + ' | ' + ' | '.join(cells) + ' |')
        lines.append('')
    lines += ['**Observed order** (slope of log error against log step, three smallest '
              'steps above round-off)', '',
              '| integrator | ' + ' | '.join(SMOOTH) + ' |', '|---|' + '---:|' * len(SMOOTH)]
    for integrator in INTEGRATORS:
        orders = [observed_order([r for r in rows if r['case'] == case
                                  and r['integrator'] == integrator]) for case in SMOOTH]
        lines.append(f'| {integrator} | ' + ' | '.join(f'{o:.2f}' for o in orders) + ' |')
    lines += ['', '**Cheapest within 1 % of the travel at 200 Hz**, at '
              f'{COST_SPHERES[0]} and at {COST_SPHERES[1]:,} spheres', '']
    for case in dict.fromkeys(r['case'] for r in rows):
        good = [r for r in rows if r['case'] == case and r['rate_hz'] == 200
                and r['relative_error'] <= 0.01]
        parts = []
        for field, count in (('ns_per_sphere_step_few', COST_SPHERES[0]),
                             ('ns_per_sphere_step', COST_SPHERES[1])):
            best = min(good, key=lambda r: r[field], default=None)
            parts.append(f'{count:,} spheres: ' + (
                f'{best["integrator"]} ({best[field]:.0f} ns/sphere-step, error '
                f'{best["relative_error"]:.2%})' if best else 'none'))
        lines.append(f'- {case}: ' + '; '.join(parts))
    pool = {r['integrator']: r for r in rows if r['case'] == CONTACT_CASE}
    if pool:
        lines += ['', 'Cost ratio RK4 / default on the pool: '
                  + ', '.join(f'{pool["rk4"][f] / pool[DEFAULT_INTEGRATOR][f]:.2f} at {n:,} '
                              'spheres' for f, n in (('ns_per_sphere_step_few', COST_SPHERES[0]),
                                                     ('ns_per_sphere_step', COST_SPHERES[1])))]
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
        axis.set_title(case)
        axis.set_xlabel(f'cost: µs per sphere per simulated second ({COST_SPHERES[1]:,} '
                        'spheres)')
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
    stepper.use_threads(1)  # as the node runs it
    if args.tables_only:
        rows = read_csv(out / 'accuracy.csv')
    else:
        rows = measure(args.quick)
        write_csv(rows, out / 'accuracy.csv')
    table = markdown(rows)
    (out / 'accuracy.md').write_text(
        provenance('.venv/bin/python -m benchmarks.accuracy') + '\n\n' + table)
    plot(rows, out / 'accuracy.png')
    print(table)


if __name__ == '__main__':
    main()
