"""The largest stable step of each integrator for a scene, from its stiffest sphere.

Near the waterline a sphere is a damped spring: z'' = -omega^2 z - lambda z', with
omega^2 = (rho_w - rho_a)*|g|*pi*r^2 / m_eff (the waterline spring at its stiffest) and
lambda = rho_w*C_d*pi*r^2*|v| / m_eff (quadratic drag linearised at a speed |v| it will
reach) plus, with wave_radiation, the largest radiation damping B33 / m over every draft.
One step of an integrator maps (z, z') linearly; it is stable while that map's spectral
radius stays <= 1. The map is found by running the integrator itself, compiled with a linear
spring where it calls the forces, so the bound cannot drift from the implementation.

linearly_implicit_euler takes both stiff parts implicitly and has no bound.
"""
import math
import types

import numba
import numpy as np

from .integrators import INTEGRATORS
from .kernels import compiled
from .kernels.wave_table import DAMPING_RATE, MASS_AXIS
from .stepper import SOURCE_DIGEST

UNCONDITIONALLY_STABLE = frozenset({'linearly_implicit_euler'})


def sphere_stiffness(scene, spheres=None, indices=None):
    """(omega_sq (n,) 1/s^2, drag_rate (n,) 1/s) of the linearised spring and damper.

    The spheres are the scene's as it starts, or, given `spheres` (a Spheres), those of
    `indices` as they are now (after a live change of mass or radius; all when None).
    The reference speed is the fastest of: terminal speed in water, the speed of a fall from
    the pool's top to the surface, and the initial (or current) speed.
    """
    effects = set(scene['effects'])
    if spheres is None:
        mass, radius = scene.sphere_array('mass'), scene.sphere_array('radius')
        drag_coefficient = scene.sphere_array('drag_coefficient')
        initial_speed = np.linalg.norm(scene.sphere_array('velocity'), axis=1)
    else:
        chosen = slice(None) if indices is None else np.asarray(indices, dtype=int)
        mass, radius = spheres.mass[chosen], spheres.radius[chosen]
        drag_coefficient = spheres.drag_coefficient[chosen]
        initial_speed = np.linalg.norm(spheres.velocity[:, chosen], axis=0)
    water, air = scene['water.density'], scene['air.density']
    gravity = float(np.linalg.norm(scene['gravity']))
    area, volume = math.pi * radius**2, 4.0 / 3.0 * math.pi * radius**3
    inertia = mass + (0.5 * water * volume if 'added_mass' in effects else 0.0)
    omega_sq = ((water - air) * gravity * area / inertia if 'buoyancy' in effects
                else np.zeros_like(mass))
    wave_rate = (wave_damping_rate(mass, radius, water, gravity, inertia)
                 if 'wave_radiation' in effects else np.zeros_like(mass))
    if 'drag' not in effects:
        return omega_sq, wave_rate
    net_weight = np.abs(mass - water * volume) * gravity
    terminal = np.sqrt(2.0 * net_weight / np.maximum(water * drag_coefficient * area, 1e-300))
    fall = math.sqrt(2.0 * gravity * max(scene['pool.max'][2] - scene['water.surface_z'], 0.0))
    speed = np.maximum(np.maximum(terminal, fall), initial_speed)
    # No drag coefficient, no damping: not 0 * an infinite reference speed (NaN).
    drag_rate = np.where(drag_coefficient > 0.0, water * drag_coefficient * area * speed
                         / inertia, 0.0)
    return omega_sq, drag_rate + wave_rate


def wave_damping_rate(mass, radius, water, gravity, inertia):
    """(n,) 1/s: wave radiation's B33 / inertia at the draft where it is largest (the table's
    damping at each sphere's mass number, over every draft), its added mass left out."""
    scale = water * radius**3
    column = mass / (mass + scale) * (MASS_AXIS.size - 1)
    j = np.minimum(column.astype(int), MASS_AXIS.size - 2)
    weight = column - j
    largest = np.max(DAMPING_RATE[:, j] * (1.0 - weight) + DAMPING_RATE[:, j + 1] * weight,
                     axis=0)
    return largest * scale * np.sqrt(gravity / radius) / inertia


@compiled
def linear_spring(listed, env, body, position, velocity):
    """Stands in for effects.acceleration: -omega^2 * x - drag_rate * x' on each axis, with
    body = (omega_sq, drag_rate)."""
    omega_sq, drag_rate = body
    return (-omega_sq * position[0] - drag_rate * velocity[0],
            -omega_sq * position[1] - drag_rate * velocity[1],
            -omega_sq * position[2] - drag_rate * velocity[2])


integrate_on_spring = None  # each compiled copy of the template below has its own


def _step_maps_template(omega_sq, drag_rate, dt):
    """(n, 2, 2): the step map of `integrate_on_spring` (a global of each compiled copy)
    on each linearised sphere, its columns the steps from (1, 0) and (0, 1)."""
    maps = np.empty((omega_sq.shape[0], 2, 2))
    for i in range(omega_sq.shape[0]):
        body = (omega_sq[i], drag_rate[i])
        for column in range(2):
            start = 1.0 if column == 0 else 0.0
            s = integrate_on_spring((), (), body, (start, 0.0, 0.0), (1.0 - start, 0.0, 0.0),
                                    dt)
            maps[i, 0, column], maps[i, 1, column] = s[0], s[3]
    return maps


def _renamed(function, name, replaced_globals):
    """function's code under another name (numba's cache tells functions apart by name)
    and with some of its globals replaced."""
    copy = types.FunctionType(function.__code__, {**function.__globals__, **replaced_globals},
                              name)
    copy.__qualname__ = name
    return copy


def _step_maps_of(name):
    """The compiled (omega_sq (n,), drag_rate (n,), dt) -> (n, 2, 2) step maps of one
    integrator: its own code, with the linear spring where it calls acceleration."""
    suffix = f'on_linear_spring_{SOURCE_DIGEST}'  # own cache entries, new with the sources
    original = getattr(INTEGRATORS[name], 'py_func', INTEGRATORS[name])  # numba's, or plain
    on_spring = compiled(_renamed(original, f'{name}_{suffix}',
                                  {'acceleration': linear_spring}))
    return numba.njit(cache=True, error_model='numpy')(_renamed(
        _step_maps_template, f'step_maps_of_{name}_{suffix}',
        {'integrate_on_spring': on_spring}))


_step_maps = {}  # integrator name -> its compiled step_maps, made on first use


def spectral_radius(integrator, omega_sq, drag_rate, dt):
    """(n,) spectral radius of one step of `integrator` on each linearised sphere."""
    if integrator not in _step_maps:
        _step_maps[integrator] = _step_maps_of(integrator)
    matrices = _step_maps[integrator](np.ascontiguousarray(omega_sq, dtype=float),
                                      np.ascontiguousarray(drag_rate, dtype=float), float(dt))
    finite = np.all(np.isfinite(matrices), axis=(1, 2))
    radius = np.full(len(omega_sq), np.inf)
    if finite.any():
        radius[finite] = np.max(np.abs(np.linalg.eigvals(matrices[finite])), axis=1)
    return radius


def _linearised(scene, integrator, spheres, indices):
    """(integrator, omega_sq, drag_rate) of those spheres, or None where no step can be
    unstable (an unconditionally stable integrator, no sphere, no spring and no drag)."""
    integrator = integrator or scene['integrator']
    if integrator in UNCONDITIONALLY_STABLE or (spheres is None and not scene.sphere_names):
        return None
    with np.errstate(over='ignore', invalid='ignore'):  # extreme rates may be inf: unstable
        omega_sq, drag_rate = sphere_stiffness(scene, spheres, indices)
    if not (omega_sq.any() or drag_rate.any()):
        return None
    return integrator, omega_sq, drag_rate


def _stable(linearised, dt):
    integrator, omega_sq, drag_rate = linearised
    return bool(np.all(spectral_radius(integrator, omega_sq, drag_rate, dt) <= 1.0 + 1e-12))


def stable_at(scene, dt, integrator=None, spheres=None, indices=None):
    """True when `integrator` (the scene's) is stable at step dt for those spheres: one
    look at the step map, cheap enough for every live change (the bound bisects)."""
    linearised = _linearised(scene, integrator, spheres, indices)
    return linearised is None or _stable(linearised, dt)


def stable_step_bound(scene, integrator=None, spheres=None, indices=None):
    """Largest stable step (s) for the scene's stiffest sphere; inf when there is no bound.

    spheres, indices: as in sphere_stiffness (the bound for some spheres as they are now).
    0.0 means no step is stable (explicit Euler on an undamped spring)."""
    linearised = _linearised(scene, integrator, spheres, indices)
    if linearised is None:
        return math.inf

    def stable(dt):
        return _stable(linearised, dt)
    # Scan up from tiny steps to the first unstable one, then bisect.
    candidates = np.logspace(-7, 2, 181)
    unstable = [dt for dt in candidates if not stable(dt)]
    if not unstable:
        return math.inf
    high = unstable[0]
    low = candidates[np.searchsorted(candidates, high) - 1] if high > candidates[0] else 0.0
    if low == 0.0 or not stable(low):
        return 0.0
    for _ in range(60):
        middle = 0.5 * (low + high)
        low, high = (middle, high) if stable(middle) else (low, middle)
    return low
