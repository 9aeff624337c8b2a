"""Wave radiation, validated and shown: the free heave decay of floating spheres against the
Cummins equation, and the book's pool coming to rest.

Run: PYTHONPATH=. .venv/bin/python benchmarks/free_decay.py  (about a minute)
Writes results/wave_radiation/free_decay.md, free_decay.png, pool_settling.md,
pool_at_rest.png.

The reference is independent of pool_sim's step and of its table: the Cummins equation
(m + A_inf) z'' + (K * z')(t) + C z = 0 with the retardation function K of the BEM's
damping over all frequencies (results/wave_radiation/bem_heave.json, solved densely at
these drafts), where pool_sim takes one added mass and damping per draft and mass from its
table (the one-mode oscillator with the Cummins equation's dominant root, found from the
coarser table grid of the same BEM results: the comparison checks that reduction, its
interpolation and pool_sim's step, not the BEM).
"""
import math
import pathlib
import sys

import numpy as np

ROOT = pathlib.Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / 'scripts'))

from benchmarks.common import provenance  # noqa: E402
from benchmarks.reference import cummins_free_decay, decay_period_and_damping  # noqa: E402
from pool_sim.physics import Scene, Simulation  # noqa: E402

RESULTS = ROOT / 'results' / 'wave_radiation'
PROVENANCE = provenance('PYTHONPATH=. .venv/bin/python benchmarks/free_decay.py')
WATER, G = 1000.0, 9.81
# The three validation drafts (s = d/r): the cork's (density ratio 1/4), half submerged,
# the ice's (0.917).
DRAFTS = (0.6527, 1.0, 1.6476)
RADIUS = 0.15  # m
AMPLITUDE = 0.001 * RADIUS  # m: small, where linear theory holds


def cap_volume(draft_ratio, radius):
    h = draft_ratio * radius
    return math.pi * h * h * (3.0 * radius - h) / 3.0


def bem_spectrum(draft):
    """(nu (k,), A (k,), B (k,), A_inf) at a validation draft, from the BEM file."""
    from radiation_coefficients import load_bem
    data = load_bem()
    spectrum = data['validation']['spectra'][f'{draft:.4f}']
    nu = data['validation']['frequencies']
    added, damping = np.array(spectrum['added_mass']), np.array(spectrum['damping'])
    finite = np.isfinite(nu)
    return nu[finite], added[finite], damping[finite], float(added[~finite][0])


def cummins_decay(draft, periods=5.0, points_per_period=300):
    """(times, z - z_eq) from the Cummins equation at a validation draft."""
    nu, _, damping, infinite_added = bem_spectrum(draft)
    omega_guess = math.sqrt(G / RADIUS)
    period_guess = 2.0 * math.pi / omega_guess * 1.5
    dt = period_guess / points_per_period
    return cummins_free_decay(draft, nu, damping, infinite_added, RADIUS, AMPLITUDE,
                              periods * period_guess, dt)


def floating_scene(draft, effects, rate_hz=2000.0, amplitude=None):
    """One sphere of radius RADIUS whose mass floats it at `draft`, released at rest
    `amplitude` m above that draft, in water without air (so the draft is exact)."""
    amplitude = AMPLITUDE if amplitude is None else amplitude
    mass = WATER * cap_volume(draft, RADIUS)
    z_rest = RADIUS * (1.0 - draft)
    return Scene({'sphere_names': ['ball'], 'ball.mass': mass, 'ball.radius': RADIUS,
                  'ball.position': [0.0, 0.0, z_rest + amplitude], 'air.density': 0.0,
                  'effects': list(effects), 'physics_rate_hz': rate_hz}), z_rest


def simulated_decay(draft, effects=('gravity', 'buoyancy', 'wave_radiation'), duration=None,
                    rate_hz=2000.0):
    """(times, z - z_eq) of pool_sim's default integrator on the same release."""
    scene, z_rest = floating_scene(draft, effects, rate_hz)
    sim = Simulation(scene)
    if duration is None:
        duration = cummins_decay(draft)[0][-1]
    steps = int(round(duration * rate_hz))
    heights = np.empty(steps + 1)
    heights[0] = sim.spheres.position[2, 0]
    for n in range(steps):
        sim.run(1, 1.0 / rate_hz)
        heights[n + 1] = sim.spheres.position[2, 0]
    return np.arange(steps + 1) / rate_hz, heights - z_rest


def validation_rows():
    rows = []
    for draft in DRAFTS:
        times, z = cummins_decay(draft)
        reference = decay_period_and_damping(times, z)
        sim_times, sim_z = simulated_decay(draft, duration=times[-1])
        ours = decay_period_and_damping(sim_times, sim_z)
        rows.append((draft, reference, ours, (times, z), (sim_times, sim_z)))
    return rows


def pool_heights(effects, duration=120.0, sample_hz=30.0):
    """(times, {name: z (k,)}, sim) of the seed's pool sampled about sample_hz (a whole
    number of physics steps apart: the times are the exact ones), with these effects."""
    sim = Simulation(Scene.default().with_values(effects=list(effects)))
    rate = sim.scene['physics_rate_hz']
    per_sample = max(1, round(rate / sample_hz))
    samples = int(math.ceil(duration * rate / per_sample))
    heights = np.empty((samples + 1, sim.spheres.count))
    heights[0] = sim.spheres.position[2]
    for k in range(samples):
        sim.run(per_sample, 1.0 / rate)
        heights[k + 1] = sim.spheres.position[2]
    return np.arange(samples + 1) * per_sample / rate, dict(zip(sim.spheres.names,
                                                               heights.T)), sim


def rest_height(sim, name):
    """z (m) where a sphere of the seed's pool rests: on the floor if it sinks, else at
    the draft where air and water together carry its weight (bisection on the exact cap)."""
    i = sim.spheres.names.index(name)
    r, mass = float(sim.spheres.radius[i]), float(sim.spheres.mass[i])
    air, water = sim.scene['air.density'], sim.scene['water.density']
    volume = 4.0 / 3.0 * math.pi * r**3
    ratio = (mass / volume - air) / (water - air)
    if ratio >= 1.0:
        return sim.scene['pool.min'][2] + r
    low, high = 0.0, 2.0
    for _ in range(200):
        middle = 0.5 * (low + high)
        if cap_volume(middle, r) / volume < ratio:
            low = middle
        else:
            high = middle
    return r * (1.0 - 0.5 * (low + high))


def settled_from(times, z, rest, tolerance=1e-3):
    """The time from which z stays within tolerance (m) of rest; inf if it never does."""
    away = np.flatnonzero(np.abs(z - rest) >= tolerance)
    if away.size == 0:
        return float(times[0])
    return float(times[away[-1] + 1]) if away[-1] + 1 < times.size else math.inf


def main():
    import matplotlib
    matplotlib.use('Agg')
    import matplotlib.pyplot as plt

    global AMPLITUDE
    lines = ['# Free heave decay of a floating sphere: pool_sim against the Cummins equation',
             '', f'Radius {RADIUS} m, released at rest above its draft, no air, effects '
             'gravity, buoyancy, wave_radiation; pool_sim at 2000 Hz with the default '
             'integrator. Reference: the Cummins equation with the BEM damping\'s retardation '
             'function (benchmarks/reference.py). Period and damping ratio from the three '
             'cycles after the first (the first carries the start-up of the fluid memory).',
             '', '| release | draft s = d/r | period, Cummins (s) | period, pool_sim (s) | '
             'error | damping ratio, Cummins | damping ratio, pool_sim | error |',
             '|---:|---:|---:|---:|---:|---:|---:|---:|']
    linear = AMPLITUDE
    for amplitude in (linear, 10.0 * linear):
        AMPLITUDE = amplitude
        found = validation_rows()
        if amplitude == linear:
            rows = found
        for draft, (t_ref, z_ref), (t_sim, z_sim), _, _ in found:
            lines.append(f'| {amplitude * 1e3:.2f} mm | {draft:.4f} | {t_ref:.4f} | '
                         f'{t_sim:.4f} | {t_sim / t_ref - 1:+.1%} | {z_ref:.4f} | '
                         f'{z_sim:.4f} | {z_sim / z_ref - 1:+.1%} |')
    AMPLITUDE = linear
    (RESULTS / 'free_decay.md').write_text('\n'.join(lines[:1] + ['', PROVENANCE] + lines[1:]) + '\n')
    print('\n'.join(lines))

    figure, axes = plt.subplots(len(rows), 1, figsize=(8, 8), sharex=True)
    for axis, (draft, _, _, (times, z), (sim_times, sim_z)) in zip(axes, rows):
        without_times, without = simulated_decay(draft, ('gravity', 'buoyancy'), times[-1])
        axis.plot(without_times, without * 1e3, color='0.6', label='pool_sim without '
                  'wave_radiation')
        axis.plot(times, z * 1e3, color='k', lw=2.5, label='Cummins equation (BEM, reference)')
        axis.plot(sim_times, sim_z * 1e3, color='tab:red', ls='--', label='pool_sim with '
                  'wave_radiation')
        axis.set_ylim(-1.3 * AMPLITUDE * 1e3, 1.3 * AMPLITUDE * 1e3)
        axis.set_ylabel('heave (mm)')
        axis.set_title(f'draft {draft:.3f} r', fontsize=10)
    axes[0].legend(fontsize=8, loc='upper right')
    axes[-1].set_xlabel('time (s)')
    figure.suptitle(f'Free heave decay of a floating sphere, r = {RADIUS} m')
    figure.tight_layout()
    figure.savefig(RESULTS / 'free_decay.png', dpi=110)

    settle_lines = ['# The book\'s pool coming to rest', '',
                    'Heights sampled every 7 steps (28.6 Hz); swing = peak to peak in the window '
                    '(mm); settled: from when the height stays within 1 mm of where the sphere '
                    'rests (its exact draft in air and water, or the floor).', '',
                    '| effects | sphere | 5-10 s | 10-20 s | 30-60 s | 90-120 s | 150-180 s | '
                    'settled (s) |', '|---|---|---:|---:|---:|---:|---:|---:|']
    final = None
    for label, effects in (('without wave_radiation', ('gravity', 'buoyancy', 'drag',
                                                       'contact', 'friction')),
                           ('default (with wave_radiation)', None)):
        chosen = effects if effects is not None else Scene.default()['effects']
        times, heights, sim = pool_heights(chosen, duration=180.0)
        if effects is None:
            final = sim
        for name, z in heights.items():
            swings = []
            for start, end in ((5, 10), (10, 20), (30, 60), (90, 120), (150, 180)):
                window = z[(times >= start) & (times <= end)]
                swings.append(f'{(window.max() - window.min()) * 1e3:.2f}')
            settled = settled_from(times, z, rest_height(sim, name))
            settle_lines.append(f'| {label} | {name} | {" | ".join(swings)} | '
                                + (f'{settled:.1f} |' if settled < 180.0 else 'not by 180 |'))
    (RESULTS / 'pool_settling.md').write_text('\n'.join(settle_lines[:1] + ['', PROVENANCE]
                                                       + settle_lines[1:]) + '\n')
    print('\n'.join(settle_lines))
    draw_pool(final, RESULTS / 'pool_at_rest.png')


def draw_pool(sim, path):
    """The pool seen from the side, as the seed's Figure 9: box, water, spheres at rest."""
    import matplotlib.pyplot as plt
    from matplotlib.patches import Circle, Rectangle
    low, high = sim.scene['pool.min'], sim.scene['pool.max']
    surface = sim.scene['water.surface_z']
    figure, axis = plt.subplots(figsize=(6, 6))
    axis.add_patch(Rectangle((low[0], low[2]), high[0] - low[0], surface - low[2],
                             color='#9ecae1', zorder=0))
    axis.add_patch(Rectangle((low[0], low[2]), high[0] - low[0], high[2] - low[2],
                             fill=False, lw=2, zorder=3))
    colours = {'cork': '#c49a6c', 'steel': '#7f8c8d', 'ice': '#e8f6ff'}
    for i, name in enumerate(sim.spheres.names):
        x, z = sim.spheres.position[0, i], sim.spheres.position[2, i]
        r = sim.spheres.radius[i]
        axis.add_patch(Circle((x, z), r, facecolor=colours.get(name, 'w'), edgecolor='k',
                              zorder=2))
        axis.annotate(f'{name}\nz = {z:+.4f} m', (x, z + r), xytext=(0, 12),
                      textcoords='offset points', ha='center', fontsize=8)
    axis.set_xlim(low[0] - 0.2, high[0] + 0.2)
    axis.set_ylim(low[2] - 0.2, high[2] + 0.2)
    axis.set_aspect('equal')
    axis.set_xlabel('x (m)')
    axis.set_ylabel('z (m)')
    axis.set_title(f'The seed\'s pool at t = {sim.time:.0f} s (pool_sim, default effects)')
    figure.tight_layout()
    figure.savefig(path, dpi=110)


if __name__ == '__main__':
    main()
