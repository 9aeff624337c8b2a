"""The heave added mass and radiation damping of a floating sphere, from linear potential
flow, and the table pool_sim's `wave_radiation` effect evaluates.

Two stages:

1. `--bem` (needs Capytaine, `pip install -r scripts/requirements-bem.txt`; about 12
   minutes on 2 cores): solves the heave radiation problem of a sphere of radius 1 m in
   infinitely deep water with Capytaine's boundary-element method, for drafts s = d/r from
   0.05 to 1.95 and non-dimensional frequencies nu = omega^2 r / g from 0 to infinity, and
   densely in frequency at three validation drafts. Irregular frequencies are removed with
   a lid on the waterplane. Writes results/wave_radiation/bem_heave.json.
2. (always; numpy and scipy) finds, at each draft s and mass number mu = m / (rho r^3),
   the dominant complex root of the Cummins equation's heave (dominant_pole; started from
   the natural frequency nu_n = pi s (2 - s) / (mu + A(nu_n, s))), and writes the one-mode
   oscillator with that root, its added mass and damping, as
   pool_sim/physics/kernels/wave_table.py.

Non-dimensional coefficients: A = A33 / (rho r^3), B = B33 / (rho r^3 omega).
"""
import argparse
import json
import math
import pathlib
import time

import numpy as np

ROOT = pathlib.Path(__file__).resolve().parent.parent
BEM_FILE = ROOT / 'results' / 'wave_radiation' / 'bem_heave.json'
TABLE_FILE = ROOT / 'pool_sim' / 'physics' / 'kernels' / 'wave_table.py'

DRAFTS = np.round(np.concatenate([[0.05], np.arange(0.1, 1.95, 0.1), [1.95]]), 4)
FREQUENCIES = np.concatenate([[0.0], np.geomspace(0.01, 30.0, 34), [np.inf]])
# Cork (density ratio 1/4), half submerged, ice (0.917): the drafts the free-decay
# validation uses; their spectra are solved densely for the retardation function.
VALIDATION_DRAFTS = (0.6527, 1.0, 1.6476)
VALIDATION_FREQUENCIES = np.concatenate([np.geomspace(0.005, 60.0, 90), [np.inf]])
# The table's mass axis: t = mu / (1 + mu) over [0, 1].
MASS_AXIS = np.linspace(0.0, 1.0, 41)


def _sphere_below_waterline(draft, panels_per_radian=14, meridians=36):
    """Capytaine body: the wetted part of a unit sphere whose bottom is `draft` m under the
    free surface z = 0, meshed along its own meridian (no clipped panels at the waterline),
    with a lid on the waterplane against irregular frequencies."""
    import capytaine as cpt
    from capytaine.meshes.symmetric_meshes import RotationSymmetricMesh
    centre_z = 1.0 - draft
    waterline_angle = math.acos(min(max(centre_z, -1.0), 1.0))
    count = max(8, int(math.ceil(waterline_angle * panels_per_radian)))
    angle = np.linspace(0.0, waterline_angle, count + 1)
    profile = np.stack([np.sin(angle), np.zeros_like(angle), centre_z - np.cos(angle)], axis=1)
    profile[-1, 2] = 0.0
    hull = RotationSymmetricMesh.from_profile_points(profile, n=meridians).merged()
    # The lid just under the waterplane, no wider than the hull there.
    lid_z = -0.01 * draft
    lid_radius = min(math.sin(waterline_angle), math.sqrt(max(0.0, 1.0 - (lid_z - centre_z)**2)))
    lid = cpt.mesh_disk(radius=lid_radius, center=(0.0, 0.0, lid_z),
                        resolution=(max(4, count // 3), meridians), normal=(0.0, 0.0, 1.0))
    return cpt.FloatingBody(mesh=hull, lid_mesh=lid, dofs=cpt.rigid_body_dofs(only=['Heave']))


def _solve(solver, body, nu):
    import capytaine as cpt
    omega = math.sqrt(nu * 9.81) if math.isfinite(nu) else math.inf
    result = solver.solve(cpt.RadiationProblem(body=body, radiating_dof='Heave', omega=omega,
                                               rho=1.0, g=9.81, water_depth=math.inf))
    added = float(result.added_mass['Heave'])
    damping = float(result.radiation_damping['Heave']) / omega if 0.0 < omega < math.inf \
        else 0.0
    return added, damping


def run_bem():
    import capytaine as cpt
    cpt.set_logging('ERROR')
    solver = cpt.BEMSolver()
    started = time.time()

    def spectrum(draft, frequencies):
        body = _sphere_below_waterline(draft)
        pairs = [_solve(solver, body, nu) for nu in frequencies]
        print(f'draft {draft:.4f}: {len(frequencies)} frequencies, '
              f'{time.time() - started:.0f} s', flush=True)
        return [p[0] for p in pairs], [p[1] for p in pairs]

    table = [spectrum(s, FREQUENCIES) for s in DRAFTS]
    validation = {f'{s:.4f}': spectrum(s, VALIDATION_FREQUENCIES) for s in VALIDATION_DRAFTS}
    BEM_FILE.parent.mkdir(parents=True, exist_ok=True)
    BEM_FILE.write_text(json.dumps({
        'about': 'Heave radiation of a floating unit sphere in deep water, Capytaine '
                 f'{cpt.__version__} BEM (scripts/radiation_coefficients.py). '
                 'A = A33/(rho r^3), B = B33/(rho r^3 omega), nu = omega^2 r/g, s = draft/r.',
        'drafts': DRAFTS.tolist(),
        'frequencies': [f if math.isfinite(f) else 'inf' for f in FREQUENCIES],
        'added_mass': [t[0] for t in table], 'damping': [t[1] for t in table],
        'validation': {'frequencies': [f if math.isfinite(f) else 'inf'
                                       for f in VALIDATION_FREQUENCIES],
                       'spectra': {k: {'added_mass': a, 'damping': b}
                                   for k, (a, b) in validation.items()}},
    }, indent=1))


def load_bem(path=BEM_FILE):
    """The BEM results: dict with arrays drafts (m,), frequencies (k,) (inf last),
    added_mass and damping (m, k), and the validation spectra."""
    data = json.loads(pathlib.Path(path).read_text())
    as_float = lambda values: np.array([math.inf if v == 'inf' else v for v in values])
    data['drafts'] = np.array(data['drafts'])
    data['frequencies'] = as_float(data['frequencies'])
    data['added_mass'], data['damping'] = np.array(data['added_mass']), np.array(data['damping'])
    data['validation']['frequencies'] = as_float(data['validation']['frequencies'])
    return data


def coefficient_at(frequencies, values, nu):
    """A coefficient at nu from its values at `frequencies` (ascending; 0 first and inf last
    where solved): linear in log(nu) between finite ones, linear in nu from zero frequency
    to the first, linear in 1/nu from the last to infinite frequency (else held)."""
    finite = np.isfinite(frequencies) & (frequencies > 0.0)
    f, y = frequencies[finite], values[finite]
    if nu <= f[0]:
        zero = values[frequencies == 0.0]
        return float(y[0] if zero.size == 0 else zero[0] + (y[0] - zero[0]) * nu / f[0])
    if nu >= f[-1]:
        infinite = values[np.isinf(frequencies)]
        return float(y[-1] if infinite.size == 0
                     else infinite[0] + (y[-1] - infinite[0]) * f[-1] / nu)
    return float(np.interp(math.log(nu), np.log(f), y))


def natural_heave(frequencies, added, damping, draft, mass_number):
    """(nu_n, A(nu_n), B(nu_n)) at one draft for mu = m/(rho r^3): the root of
    nu = pi s (2 - s) / (mu + A(nu)), found by bisection in log(nu) (the right side falls
    from infinity at nu -> 0 as A stays finite, so the root is unique where A is smooth)."""
    spring = math.pi * draft * (2.0 - draft)

    def residual(nu):
        return nu * (mass_number + coefficient_at(frequencies, added, nu)) - spring

    low, high = 1e-8, 1e4
    if residual(high) < 0.0:  # mu = 0 and a tiny added mass: stays at the top
        low = high
    for _ in range(200):
        middle = math.sqrt(low * high)
        if residual(middle) > 0.0:
            high = middle
        else:
            low = middle
    nu = math.sqrt(low * high)
    return nu, coefficient_at(frequencies, added, nu), coefficient_at(frequencies, damping, nu)


def dominant_pole(frequencies, added, damping, draft, mass_number):
    """(A_e, B_e, converged): the added mass A33/(rho r^3) and damping B33/(rho r^3 sqrt(g/r))
    of the one-mode oscillator (mu + A_e) z'' + B_e z' + c z = 0 (time in sqrt(r/g),
    c = pi s (2 - s)) whose complex root is the dominant root of the Cummins equation,
    -(mu + A(W)) W^2 + i W B~(W) + c = 0 for z ~ exp(i W t), W = w + i sigma, A and the
    dimensional damping B~ = B(nu) w continued off the real axis to first order,
    A(w + i sigma) = A(w) + i sigma A'(w). A free decay then has the Cummins decay's
    period and damping, not just the natural frequency's coefficients. Where the solve
    does not converge to a decaying oscillation, the natural frequency's (converged False)."""
    from scipy.interpolate import PchipInterpolator
    from scipy.optimize import fsolve
    spring = math.pi * draft * (2.0 - draft)
    nu, a_n, b_n = natural_heave(frequencies, added, damping, draft, mass_number)
    fallback = (a_n, b_n * math.sqrt(nu), False)
    if spring == 0.0 or nu <= 0.0:
        return fallback
    known = np.isfinite(frequencies)
    omega = np.sqrt(frequencies[known])
    a_of = PchipInterpolator(omega, added[known], extrapolate=True)
    b_of = PchipInterpolator(omega, damping[known] * omega, extrapolate=True)

    def residual(unknowns):
        w, sigma = unknowns
        root = complex(w, sigma)
        a = complex(a_of(w), sigma * a_of(w, 1))
        b = complex(b_of(w), sigma * b_of(w, 1))
        value = -(mass_number + a) * root * root + 1j * root * b + spring
        return [value.real, value.imag]

    w0 = math.sqrt(nu)
    sigma0 = b_n * w0 / (2.0 * (mass_number + a_n) * w0) * w0 if mass_number + a_n > 0 else 0.0
    solution, _, status, _ = fsolve(residual, [w0, sigma0], full_output=True, xtol=1e-12)
    w, sigma = solution
    if status != 1 or not (0.0 <= sigma < w <= omega[-1]):
        return fallback
    size_sq = w * w + sigma * sigma
    return spring / size_sq - mass_number, 2.0 * sigma * spring / size_sq, True


# The shipped table's draft axis, evenly spaced for a lookup without search, and the part
# of it before full submergence over which the added mass is tapered to zero.
TABLE_DRAFTS = np.linspace(0.0, 2.0, 41)
TAPER = 0.2


def build_table(data):
    """(drafts, mass axis, added, damping_rate) on TABLE_DRAFTS x MASS_AXIS: the added mass
    A33/(rho r^3) and damping B33/(rho r^3 sqrt(g/r)) of dominant_pole's one-mode oscillator
    (the natural frequency's where it does not converge). At s = 0 the sphere only touches
    the water: no added mass, no damping; at s = 2 the waterplane is gone, nu_n = 0 and
    there is no damping. Between
    the solved drafts, monotone cubic (PCHIP) interpolation; the added mass then tapered
    linearly to zero over the last TAPER of s, so it joins and leaves the sphere smoothly
    when wave_radiation stops acting."""
    from scipy.interpolate import PchipInterpolator
    solved = data['drafts']
    drafts = np.concatenate([[0.0], solved, [2.0]])
    added = np.zeros((drafts.size, MASS_AXIS.size))
    rate = np.zeros_like(added)
    frequencies = data['frequencies']
    fallbacks = 0
    for row, s in enumerate(solved, start=1):
        for column, t in enumerate(MASS_AXIS):
            if t == 1.0:  # mu infinite: nu_n = 0
                a, b = data['added_mass'][row - 1][0], 0.0
            else:
                a, b, converged = dominant_pole(frequencies, data['added_mass'][row - 1],
                                                data['damping'][row - 1], s, t / (1.0 - t))
                fallbacks += not converged
            added[row, column], rate[row, column] = a, b
    added[-1, :] = data['added_mass'][-1][0]  # the deepest row's zero-frequency value
    taper = np.clip((2.0 - TABLE_DRAFTS) / TAPER, 0.0, 1.0)[:, None]
    added = PchipInterpolator(drafts, added, axis=0)(TABLE_DRAFTS) * taper
    rate = np.maximum(PchipInterpolator(drafts, rate, axis=0)(TABLE_DRAFTS), 0.0)
    build_table.fallbacks = fallbacks
    return TABLE_DRAFTS, MASS_AXIS, added, rate


def added_mass_slopes(drafts, added):
    """dA/ds at the table's nodes, PCHIP's (monotone, no overshoot): with them pool_sim
    reads the added mass as a cubic Hermite spline in s, continuous in its slope, so the
    force of the water taken on (which has the slope in it) jumps only at the band's ends."""
    from scipy.interpolate import PchipInterpolator
    return PchipInterpolator(drafts, added, axis=0).derivative()(drafts)


def write_table(data):
    drafts, mass_axis, added, rate = build_table(data)
    slopes = added_mass_slopes(drafts, added)

    def rows(matrix):
        return ',\n'.join('    (' + ', '.join(f'{v:.6g}' for v in row) + ',)'
                          for row in matrix)

    TABLE_FILE.write_text(f'''"""Generated by scripts/radiation_coefficients.py from results/wave_radiation/bem_heave.json;
do not edit. The heave added mass and radiation damping of a floating sphere, from linear
potential flow (Capytaine BEM, deep water): the one-mode oscillator with the dominant root of
the Cummins equation at each draft and mass.

Rows: draft s = d/r (DRAFTS). Columns: t = mu / (1 + mu), mu = m / (rho_water r^3)
(MASS_AXIS); both evenly spaced from 0. ADDED_MASS: A33 / (rho r^3), tapered to 0 over the
last {TAPER} of s; ADDED_MASS_SLOPE: its derivative in s at the nodes (a cubic Hermite spline
in s). DAMPING_RATE: B33 / (rho r^3 sqrt(g / r)).
"""
import numpy as np

DRAFTS = np.array({[float(v) for v in np.round(drafts, 6)]})
MASS_AXIS = np.array({[float(v) for v in np.round(mass_axis, 6)]})
ADDED_MASS = np.array((
{rows(added)},
))
ADDED_MASS_SLOPE = np.array((
{rows(slopes)},
))
DAMPING_RATE = np.array((
{rows(rate)},
))
''')


if __name__ == '__main__':
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument('--bem', action='store_true', help='solve the BEM problems first')
    if parser.parse_args().bem:
        run_bem()
    write_table(load_bem())
    print(f'wrote {TABLE_FILE.relative_to(ROOT)}; {build_table.fallbacks} of the table\'s '
          'points took the natural frequency\'s coefficients')
