"""Reference answers that do not come from pool_sim's code.

- The steel sphere falling from rest through deep water: closed form.
- A sphere moving vertically through the surface: the same equations pool_sim models,
  written here again from the physics (exact cap, media weighted by volume fraction) and
  solved by scipy's DOP853 at rtol 1e-12.
- The free heave decay of a floating sphere from the Cummins equation, with the frequency-
  dependent radiation damping of the BEM (its retardation function) rather than the one
  frequency pool_sim evaluates it at.
"""
import math

import numpy as np
from scipy.integrate import solve_ivp
from scipy.interpolate import CubicHermiteSpline, RegularGridInterpolator

G = 9.81


def falling_in_deep_water(t, z0, radius, mass, drag_coefficient=0.47, water=1000.0):
    """Height z(t) (m) of a sphere released at rest at z0, fully submerged, no added mass.

    With g' = g*(m - rho*V)/m and v_t = sqrt(2*(m - rho*V)*g / (rho*C_d*A)):
    v(t) = -v_t*tanh(g'*t/v_t) and z(t) = z0 - (v_t^2/g')*ln cosh(g'*t/v_t).
    (With added mass, m + rho*V/2 would replace m in g' only; v_t is unchanged.)
    """
    volume, area = 4.0 / 3.0 * math.pi * radius**3, math.pi * radius**2
    net_weight = (mass - water * volume) * G
    terminal = math.sqrt(2.0 * net_weight / (water * drag_coefficient * area))
    reduced_gravity = net_weight / mass
    x = reduced_gravity * np.asarray(t) / terminal
    # ln cosh x without overflow: x + ln(1 + e^-2x) - ln 2
    log_cosh = x + np.log1p(np.exp(-2.0 * x)) - math.log(2.0)
    return z0 - terminal**2 / reduced_gravity * log_cosh


def vertical_through_the_surface(times, z0, v0, radius, mass, drag_coefficient=0.47,
                                 water=1000.0, air=1.2, surface_z=0.0):
    """z at `times` for gravity + buoyancy + drag, solved by DOP853 at rtol 1e-12."""
    volume, area = 4.0 / 3.0 * math.pi * radius**3, math.pi * radius**2

    def rate(t, state):
        z, v = state
        depth = min(max(surface_z - (z - radius), 0.0), 2.0 * radius)
        under = math.pi * depth * depth * (3.0 * radius - depth) / 3.0 / volume
        density = air * (1.0 - under) + water * under  # displaced fluid, volume-weighted
        force = -mass * G + density * volume * G - 0.5 * density * drag_coefficient * area \
            * abs(v) * v
        return [v, force / mass]
    solution = solve_ivp(rate, (0.0, float(times[-1])), [z0, v0], method='DOP853',
                         t_eval=times, rtol=1e-12, atol=1e-14, max_step=0.01)
    assert solution.success, solution.message
    return solution.y[0]


def lift_curve(sphere, attack):
    """Signed C_l at the angle of attack (rad, 0 edge-on, pi/2 face-on), from the sphere's
    lift_coefficient (the most it gives), lift_slope and stall_angle."""
    peak = sphere['lift_coefficient']
    slope = sphere.get('lift_slope', 2.0 * math.pi)
    stall = sphere.get('stall_angle', math.radians(15.0))
    at_stall = min(slope * stall, abs(peak))
    if attack <= stall:
        size = min(slope * attack, abs(peak))
    else:
        size = at_stall * (math.pi / 2 - attack) / (math.pi / 2 - stall)
    return math.copysign(size, peak)


def retardation_function(frequencies_nu, damping, radius, density=1000.0, gravity=G,
                         times=None):
    """K(t) = 2/pi * integral_0^inf B33(omega) cos(omega t) d omega (N/(m/s)/s), from the
    non-dimensional damping B = B33/(rho r^3 omega) at nu = omega^2 r / g (finite
    frequencies), integrated by the trapezoidal rule on 4000 frequencies (B interpolated
    linearly in log nu, zero beyond the solved range)."""
    nu = np.asarray(frequencies_nu, dtype=float)
    finite = np.isfinite(nu) & (nu > 0.0)
    nu, damping = nu[finite], np.asarray(damping, dtype=float)[finite]
    omega_max = math.sqrt(nu[-1] * gravity / radius)
    omega = np.linspace(0.0, omega_max, 4000)
    nu_fine = omega**2 * radius / gravity
    b_hat = np.interp(np.log(np.maximum(nu_fine, 1e-300)), np.log(nu), damping, left=0.0,
                      right=0.0)
    b_dimensional = density * radius**3 * omega * b_hat
    cosine = np.cos(np.outer(times, omega))
    return 2.0 / math.pi * np.trapezoid(b_dimensional * cosine, omega, axis=1)


def cummins_free_decay(draft, frequencies_nu, damping, infinite_added_mass, radius,
                       amplitude, duration, dt, density=1000.0, gravity=G):
    """(times, heave z(t) - z_eq) of a sphere floating at draft s = d/r (its mass the water
    it displaces there), released at rest `amplitude` m above its draft, from the Cummins
    equation (m + A_inf) z'' + integral_0^t K(t - tau) z'(tau) d tau + C z = 0, with
    C = rho g pi r^2 s (2 - s) (the waterplane spring) and K the retardation function of
    the BEM damping. Velocity Verlet with the memory integral by the trapezoidal rule."""
    s = draft
    mass = density * math.pi * (s * radius)**2 * (3.0 * radius - s * radius) / 3.0
    inertia = mass + infinite_added_mass * density * radius**3
    spring = density * gravity * math.pi * radius**2 * s * (2.0 - s)
    count = int(round(duration / dt)) + 1
    times = np.arange(count) * dt
    kernel = retardation_function(frequencies_nu, damping, radius, density, gravity, times)
    z, v = np.zeros(count), np.zeros(count)
    z[0] = amplitude

    def memory(n, v_now):
        """integral_0^t_n K(t_n - tau) v(tau) d tau with v(t_n) = v_now."""
        if n == 0:
            return 0.0
        history = np.concatenate([v[:n], [v_now]])
        weights = kernel[n::-1]
        return dt * (np.dot(weights, history) - 0.5 * (weights[0] * history[0]
                                                       + weights[-1] * history[-1]))

    acceleration = -spring * z[0] / inertia
    for n in range(count - 1):
        z[n + 1] = z[n] + dt * v[n] + 0.5 * dt * dt * acceleration
        predicted = v[n] + dt * acceleration
        for _ in range(2):  # the memory term at n + 1 needs v there: two fixed-point passes
            new_acceleration = -(spring * z[n + 1] + memory(n + 1, predicted)) / inertia
            predicted = v[n] + 0.5 * dt * (acceleration + new_acceleration)
        v[n + 1], acceleration = predicted, new_acceleration
    return times, z


def decay_period_and_damping(times, z, skip=1, cycles=3):
    """(period s, damping ratio) of a free decay released at rest at z[0] > 0: the mean
    spacing of its maxima and the mean logarithmic decrement over `cycles` cycles (delta =
    ln(x_k / x_k+1), zeta = delta / sqrt(4 pi^2 + delta^2)) after the first `skip`. The
    release is the first maximum, each later one placed by a parabola through the three
    samples around it. Skipping the first cycle leaves out the start-up of the fluid's
    memory in the Cummins equation (at the ice's draft its first decrement is 0.031, every
    later one 0.0224)."""
    inner = np.flatnonzero((z[1:-1] > z[:-2]) & (z[1:-1] >= z[2:])) + 1
    inner = inner[z[inner] > 0.0]
    peak_times, peaks = [times[0]], [z[0]]
    for i in inner:
        a, b, c = z[i - 1], z[i], z[i + 1]
        curvature = a - 2.0 * b + c
        shift = 0.5 * (a - c) / curvature if curvature != 0.0 else 0.0
        peak_times.append(times[i] + shift * (times[1] - times[0]))
        peaks.append(b - 0.25 * (a - c) * shift)
    peak_times = np.array(peak_times)[skip:skip + cycles + 1]
    peaks = np.array(peaks)[skip:skip + cycles + 1]
    assert peaks.size == cycles + 1, 'the decay is shorter than the cycles asked for'
    decrement = float(np.mean(np.log(peaks[:-1] / peaks[1:])))
    period = float(np.mean(np.diff(peak_times)))
    return period, decrement / math.sqrt(4.0 * math.pi**2 + decrement**2)


def smooth_motion(times, position, velocity, sphere, world, effects, submerged_volume='cap'):
    """(3, len(times)) positions of one sphere under the smooth effects listed (gravity,
    buoyancy, drag, lift, added_mass), solved by DOP853 at rtol 1e-12: the model pool_sim
    states, written here again from its description, in three dimensions.

    sphere: dict of mass, radius, drag_coefficient, lift_coefficient, lift_area,
    lift_normal (3), external_force (3).  world: dict of gravity (3), air_density, wind (3),
    water_density, current (3), surface_z.  submerged_volume: 'cap' (the exact spherical
    cap) or 'linear' (depth / diameter).
    Each medium acts on the part of the volume inside it; added mass is half the displaced
    fluid's mass, joining the inertia. Lift follows the lift curve (slope up to the stall,
    then linearly down to 0 face-on, capped at |lift_coefficient|; sphere keys lift_slope,
    stall_angle). wave_radiation: the heave added mass and damping of the shipped table
    (scipy's cubic Hermite spline in the draft for the added mass, its linear grid
    interpolator for the damping) at the current draft, and the momentum
    shared with the water taken on, -max(dA/dt, 0) z'.
    """
    r, m = sphere['radius'], sphere['mass']
    volume, area = 4.0 / 3.0 * math.pi * r**3, math.pi * r**2
    gravity = np.asarray(world['gravity'], dtype=float)
    media = ((world['air_density'], np.asarray(world['wind'], dtype=float)),
             (world['water_density'], np.asarray(world['current'], dtype=float)))
    normal = np.asarray(sphere['lift_normal'], dtype=float)
    external = np.asarray(sphere['external_force'], dtype=float)

    def rate(t, state):
        x, v = state[:3], state[3:]
        depth = min(max(world['surface_z'] - (x[2] - r), 0.0), 2.0 * r)
        if submerged_volume == 'cap':
            under = math.pi * depth * depth * (3.0 * r - depth) / 3.0 / volume
        else:
            under = depth / (2.0 * r)
        shares = (1.0 - under, under)
        displaced = sum(density * share for (density, _), share in zip(media, shares)) * volume
        force = external.copy()
        if 'gravity' in effects:
            force += m * gravity
        if 'buoyancy' in effects:
            force -= displaced * gravity
        for (density, flow), share in zip(media, shares):
            relative = v - flow
            speed = float(np.linalg.norm(relative))
            if 'drag' in effects:
                force -= 0.5 * density * sphere['drag_coefficient'] * area * share * speed \
                    * relative
            if 'lift' in effects and speed > 0.0:
                across = normal - (normal @ relative) / speed**2 * relative
                size = float(np.linalg.norm(across))
                attack = math.atan2(abs(normal @ relative),
                                    float(np.linalg.norm(np.cross(normal, relative))))
                if size > 0.0:
                    force += (0.5 * density * lift_curve(sphere, attack) * sphere['lift_area']
                              * share * speed**2 / size
                              * -math.copysign(1.0, normal @ relative)) * across
        inertia = m + (0.5 * displaced if 'added_mass' in effects else 0.0)
        inertia = np.array([inertia, inertia, inertia])
        if 'wave_radiation' in effects:
            added, slope, damping = heave_radiation(x[2])
            taking_on = max(slope * v[2], 0.0)  # dA/dt while the sphere takes water on
            force[2] -= taking_on * v[2] + damping * (v[2] - media[1][1][2])
            inertia[2] += added
        return np.concatenate([v, force / inertia])

    def heave_radiation(z):
        """(A33 kg, dA33/dz kg/m, B33 kg/s) from the table, zero off the surface."""
        s = 1.0 + (world['surface_z'] - z) / r
        if not 0.0 < s < 2.0:
            return 0.0, 0.0, 0.0
        scale = world['water_density'] * r**3
        t = m / (m + scale)
        columns = len(wave_table.MASS_AXIS) - 1
        j = min(int(t * columns), columns - 1)
        w = (t - wave_table.MASS_AXIS[j]) / (wave_table.MASS_AXIS[j + 1]
                                             - wave_table.MASS_AXIS[j])
        added = ((1 - w) * splines[j](s) + w * splines[j + 1](s)) * scale
        slope = -((1 - w) * splines[j](s, 1) + w * splines[j + 1](s, 1)) * scale / r
        damping = table_damping((s, t)) * scale * math.sqrt(abs(gravity[2]) / r)
        return float(added), float(slope), float(damping)

    if 'wave_radiation' in effects:
        from pool_sim.physics.kernels import wave_table
        grid = (wave_table.DRAFTS, wave_table.MASS_AXIS)
        # The added mass: a cubic Hermite spline in s on each mass column, linear between.
        splines = [CubicHermiteSpline(wave_table.DRAFTS, wave_table.ADDED_MASS[:, j],
                                      wave_table.ADDED_MASS_SLOPE[:, j])
                   for j in range(len(wave_table.MASS_AXIS))]
        table_damping = RegularGridInterpolator(grid, wave_table.DAMPING_RATE)
    solution = solve_ivp(rate, (0.0, float(times[-1])), np.concatenate([position, velocity]),
                         method='DOP853', t_eval=times, rtol=1e-12, atol=1e-14,
                         max_step=0.005)
    assert solution.success, solution.message
    return solution.y[:3]
