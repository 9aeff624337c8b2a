"""Fixed-step integrators of the smooth dynamics, one compiled function each, by name.

Each is `integrator(listed, env, body, position, velocity, dt)` for one sphere (see
effects.py for the arguments; position and velocity 3-tuples, m and m/s) and returns the
state a step of dt seconds later as one flat tuple (x, y, z, vx, vy, vz). Contacts are
resolved afterwards, outside them. The explicit ones see the forces only through
`acceleration`, which the stability analysis replaces by a linear spring
(physics/stability.py). physics/integrators.py names them.
"""
import math

from . import compiled
from .effects import acceleration, buoyancy_stiffness, drag_factors, explicit_force, \
    heave_radiation, inertia, water_fraction, water_taken_on


@compiled
def _plus(vector, scale, rate):
    """vector + scale * rate, for 3-tuples."""
    return (vector[0] + scale * rate[0], vector[1] + scale * rate[1],
            vector[2] + scale * rate[2])


@compiled
def _state(position, velocity):
    return position[0], position[1], position[2], velocity[0], velocity[1], velocity[2]


@compiled
def explicit_euler(listed, env, body, position, velocity, dt):
    """Forward Euler: first order, unstable for stiff drag or a stiff float."""
    rate = acceleration(listed, env, body, position, velocity)
    return _state(_plus(position, dt, velocity), _plus(velocity, dt, rate))


@compiled
def semi_implicit_euler(listed, env, body, position, velocity, dt):
    """The seed's: new velocity first, then position with the new velocity (symplectic)."""
    new_velocity = _plus(velocity, dt, acceleration(listed, env, body, position, velocity))
    return _state(_plus(position, dt, new_velocity), new_velocity)


@compiled
def velocity_verlet(listed, env, body, position, velocity, dt):
    """Second order; the end-of-step force sees a predicted velocity, so drag stays 2nd order."""
    rate = acceleration(listed, env, body, position, velocity)
    new_position = _plus(_plus(position, dt, velocity), 0.5 * dt * dt, rate)
    predicted_velocity = _plus(velocity, dt, rate)
    new_rate = acceleration(listed, env, body, new_position, predicted_velocity)
    mean_rate = (rate[0] + new_rate[0], rate[1] + new_rate[1], rate[2] + new_rate[2])
    return _state(new_position, _plus(velocity, 0.5 * dt, mean_rate))


@compiled
def _rk4_sum(start, k1, k2, k3, k4, dt):
    sixth = dt / 6.0
    return (start[0] + sixth * (k1[0] + 2.0 * k2[0] + 2.0 * k3[0] + k4[0]),
            start[1] + sixth * (k1[1] + 2.0 * k2[1] + 2.0 * k3[1] + k4[1]),
            start[2] + sixth * (k1[2] + 2.0 * k2[2] + 2.0 * k3[2] + k4[2]))


@compiled
def rk4(listed, env, body, position, velocity, dt):
    """Classical fourth-order Runge-Kutta on (position, velocity)."""
    a1 = acceleration(listed, env, body, position, velocity)
    x2, v2 = _plus(position, 0.5 * dt, velocity), _plus(velocity, 0.5 * dt, a1)
    a2 = acceleration(listed, env, body, x2, v2)
    x3, v3 = _plus(position, 0.5 * dt, v2), _plus(velocity, 0.5 * dt, a2)
    a3 = acceleration(listed, env, body, x3, v3)
    x4, v4 = _plus(position, dt, v3), _plus(velocity, dt, a3)
    a4 = acceleration(listed, env, body, x4, v4)
    return _state(_rk4_sum(position, velocity, v2, v3, v4, dt),
                  _rk4_sum(velocity, a1, a2, a3, a4, dt))


@compiled
def linearly_implicit_euler(listed, env, body, position, velocity, dt):
    """The default: stable at any step for stiff drag, light spheres and a stiff float.

    The stiff parts are taken implicitly and everything else explicitly:
    - quadratic drag as gain * (v_new - flow), the gain taken at the larger of the current
      relative speed and the speed the step will end with (the closed-form root of
      m*s + dt*c*s^2 = |m*v_rel + dt*F|), so a sphere starting from rest is damped too;
    - the buoyancy spring k at the waterline (effects.buoyancy_stiffness) with a
      theta-method whose weight w blends from the trapezoidal rule (w = 1/2: no damping,
      second order) when the spring is resolved to backward Euler (w = 1: L-stable) when it
      is not: w = 1/2 + h^2 / (2*(4 + h^2)), h = omega*dt, omega^2 = k/m. Below h = 0.3 it
      damps the float by < 0.04*omega*h^2 per second; at h = 6.7 it cuts the stiff mode to
      0.16 per step;
    - wave radiation's damping B33 (z' - current_z); its added mass A33, the lesser of the
      step's start and where it is headed (z + dt z'), joins the vertical inertia m_z (the
      water it leaves is left with its energy); where the step ends carrying more, it shares
      its momentum with the water taken on (effects.water_taken_on), exactly for what
      the step took on: the water carried gives the sphere no energy.
    Positions advance with the mean velocity (weight w on z where the spring acts).
    Solving for v_new is a division per sphere:
        (m + dt*gain + w^2*dt^2*k) v_new = m*v + dt*(F + gain*flow) - w*(1-w)*dt^2*k*v
    (m_z for m in z).
    Fixed points are exact: terminal velocity and floating draft carry no step error.
    First order with drag, second order for gravity and the float.
    """
    x, y, z = position
    vx, vy, vz = velocity
    fraction = water_fraction(listed, env, body, z)
    m = inertia(listed, env, body, fraction)
    fx, fy, fz = explicit_force(listed, env, body, velocity, fraction)
    m_z, z_gain, added = m, 0.0, 0.0  # vertical inertia; what z's divisor has beyond x's
    if listed.wave_radiation:
        added, added_slope, damping = heave_radiation(listed, env, body, z)
        # Water the sphere will have left by the step's end (as predicted) is dropped first,
        # keeping v_z: carried through the step, its momentum would push the sphere on.
        ahead = heave_radiation(listed, env, body, z + dt * vz)[0]
        added = ahead if ahead < added else added
        m_z += added
        z_gain = dt * damping
        fz += damping * env.current_z
    px, py, pz = m * vx + dt * fx, m * vy + dt * fy, m_z * vz + dt * fz
    horizontal = m  # the solve's divisor for x and y; z's gains the spring's part too
    if listed.drag:
        factor_air, factor_water = drag_factors(env, body, fraction)
        wx, wy, wz = env.wind_x, env.wind_y, env.wind_z
        cx, cy, cz = env.current_x, env.current_y, env.current_z
        total = factor_air + factor_water
        inverse_total = 1.0 / (total if total > 0.0 else 1.0)
        mx = (factor_air * wx + factor_water * cx) * inverse_total
        my = (factor_air * wy + factor_water * cy) * inverse_total
        mz = (factor_air * wz + factor_water * cz) * inverse_total
        rx, ry, rz = m * (vx - mx) + dt * fx, m * (vy - my) + dt * fy, m * (vz - mz) + dt * fz
        pushed = math.sqrt(rx * rx + ry * ry + rz * rz)
        end_speed = 2.0 * pushed / (m + math.sqrt(m * m + 4.0 * dt * total * pushed))
        speed_air = math.sqrt((vx - wx) ** 2 + (vy - wy) ** 2 + (vz - wz) ** 2)
        speed_water = math.sqrt((vx - cx) ** 2 + (vy - cy) ** 2 + (vz - cz) ** 2)
        gain_air = factor_air * (speed_air if speed_air > end_speed else end_speed)
        gain_water = factor_water * (speed_water if speed_water > end_speed else end_speed)
        px += dt * (gain_air * wx + gain_water * cx)
        py += dt * (gain_air * wy + gain_water * cy)
        pz += dt * (gain_air * wz + gain_water * cz)
        horizontal += dt * (gain_air + gain_water)
    vertical = horizontal + (m_z - m) + z_gain
    weight = 0.5
    inverse_horizontal = 1.0 / horizontal
    if listed.buoyancy:
        # pz / vertical, not pz * inverse_horizontal, though they are equal without the
        # waves: the step of a sphere away from the surface, wave radiation listed or
        # not, is then the same to the bit (stepper.py's wave-band pass relies on it).
        predicted_z = z + 0.5 * dt * (vz + pz / vertical)
        spring = dt * dt * buoyancy_stiffness(listed.cap, env, body, z, predicted_z)
        h_squared = spring / m_z
        weight = 0.5 + 0.5 * h_squared / (4.0 + h_squared)
        pz -= weight * (1.0 - weight) * spring * vz
        vertical += weight * weight * spring
    nvx, nvy, nvz = px * inverse_horizontal, py * inverse_horizontal, pz / vertical
    nz = z + 0.5 * dt * (vz + nvz) + (weight - 0.5) * dt * (nvz - vz)
    if listed.wave_radiation:
        nvz = water_taken_on(listed, env, body, m_z, added, nz, nvz)
    return x + 0.5 * dt * (vx + nvx), y + 0.5 * dt * (vy + nvy), nz, nvx, nvy, nvz
