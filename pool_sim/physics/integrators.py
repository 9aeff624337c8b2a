"""Fixed-step integrators of the smooth dynamics, interchangeable by name.

Each is `advance(dynamics, spheres, position, velocity, dt) -> (position, velocity)`: a pure
function of (3, n) arrays in m and m/s; contacts are resolved afterwards, outside them.
"""
import numpy as np

from .effects import drag_gains


def explicit_euler(dynamics, spheres, position, velocity, dt):
    """Forward Euler: first order, unstable for stiff drag or a stiff float."""
    acceleration = dynamics.acceleration(spheres, position, velocity)
    return position + dt * velocity, velocity + dt * acceleration


def semi_implicit_euler(dynamics, spheres, position, velocity, dt):
    """The seed's: new velocity first, then position with the new velocity (symplectic)."""
    new_velocity = velocity + dt * dynamics.acceleration(spheres, position, velocity)
    return position + dt * new_velocity, new_velocity


def velocity_verlet(dynamics, spheres, position, velocity, dt):
    """Second order; the end-of-step force sees a predicted velocity, so drag stays 2nd order."""
    acceleration = dynamics.acceleration(spheres, position, velocity)
    new_position = position + dt * velocity + 0.5 * dt * dt * acceleration
    predicted_velocity = velocity + dt * acceleration
    new_acceleration = dynamics.acceleration(spheres, new_position, predicted_velocity)
    return new_position, velocity + 0.5 * dt * (acceleration + new_acceleration)


def rk4(dynamics, spheres, position, velocity, dt):
    """Classical fourth-order Runge-Kutta on (position, velocity)."""
    def rate(x, v):
        return v, dynamics.acceleration(spheres, x, v)
    k1x, k1v = rate(position, velocity)
    k2x, k2v = rate(position + 0.5 * dt * k1x, velocity + 0.5 * dt * k1v)
    k3x, k3v = rate(position + 0.5 * dt * k2x, velocity + 0.5 * dt * k2v)
    k4x, k4v = rate(position + dt * k3x, velocity + dt * k3v)
    return (position + dt / 6.0 * (k1x + 2.0 * k2x + 2.0 * k3x + k4x),
            velocity + dt / 6.0 * (k1v + 2.0 * k2v + 2.0 * k3v + k4v))


def linearly_implicit_euler(dynamics, spheres, position, velocity, dt):
    """The default: stable at any step for stiff drag, light spheres and a stiff float.

    The two stiff parts are taken implicitly and everything else explicitly:
    - quadratic drag as gain * (v_new - flow), the gain taken at the larger of the current
      relative speed and the speed the step will end with (the closed-form root of
      m*s + dt*c*s^2 = |m*v_rel + dt*F|), so a sphere starting from rest is damped too;
    - the buoyancy spring k at the waterline (the larger of its slope at the start and its
      secant slope to where z would end without it, so a step that would jump the
      waterline band feels it) with a theta-method whose weight w blends from
      the trapezoidal rule (w = 1/2: no damping, second order) when the spring is resolved
      to backward Euler (w = 1: L-stable) when it is not: w = 1/2 + h^2 / (2*(4 + h^2)),
      h = omega*dt, omega^2 = k/m. Below h = 0.3 it damps the float by < 0.04*omega*h^2
      per second; at h = 6.7 it cuts the stiff mode to 0.16 per step.
    Positions advance with the mean velocity (weight w on z where the spring acts).
    Solving for v_new is a division per sphere:
        (m + dt*gain + w^2*dt^2*k) v_new = m*v + dt*(F + gain*flow) - w*(1-w)*dt^2*k*v
    Fixed points are exact: terminal velocity and floating draft carry no step error.
    First order with drag, second order for gravity and the float.
    """
    env = dynamics.env
    water_fraction = dynamics.water_fraction(spheres, position)
    inertia = dynamics.inertia(spheres, water_fraction)
    force = dynamics.explicit_force(spheres, position, velocity, water_fraction)
    momentum = inertia * velocity + dt * force
    denominator = np.broadcast_to(inertia, (3, spheres.count)).copy()
    factors = dynamics.drag_factors(spheres, water_fraction)
    if factors is not None:
        factor_air, factor_water = factors
        flow_air = env.air.flow_velocity[:, None]
        flow_water = env.water.flow_velocity[:, None]
        total = factor_air + factor_water
        mean_flow = (factor_air * flow_air + factor_water * flow_water) / np.where(
            total > 0.0, total, 1.0)
        relative_momentum = inertia * (velocity - mean_flow) + dt * force
        pushed = np.sqrt(np.einsum('ij,ij->j', relative_momentum, relative_momentum))
        end_speed = 2.0 * pushed / (inertia + np.sqrt(inertia * inertia
                                                      + 4.0 * dt * total * pushed))
        for factor, gain, flow in zip(factors, drag_gains(env, factors, velocity),
                                      (flow_air, flow_water)):
            gain = np.maximum(gain, factor * end_speed)  # factor * max(|v_rel|, end speed)
            momentum += dt * gain * flow
            denominator += dt * gain
    stiffness = None
    if dynamics.has_buoyancy:
        predicted_z = position[2] + 0.5 * dt * (velocity[2] + momentum[2] / denominator[2])
        stiffness = dynamics.vertical_stiffness(spheres, position, predicted_z)
    weight = 0.5
    if stiffness is not None:
        spring = dt * dt * stiffness  # (omega*dt)^2 * m
        h_squared = spring / inertia
        weight = 0.5 + 0.5 * h_squared / (4.0 + h_squared)
        momentum[2] -= weight * (1.0 - weight) * spring * velocity[2]
        denominator[2] += weight * weight * spring
    new_velocity = momentum / denominator
    new_position = position + 0.5 * dt * (velocity + new_velocity)
    if stiffness is not None:
        new_position[2] += (weight - 0.5) * dt * (new_velocity[2] - velocity[2])
    return new_position, new_velocity


INTEGRATORS = {
    'explicit_euler': explicit_euler,
    'semi_implicit_euler': semi_implicit_euler,
    'velocity_verlet': velocity_verlet,
    'rk4': rk4,
    'linearly_implicit_euler': linearly_implicit_euler,
}
DEFAULT_INTEGRATOR = 'linearly_implicit_euler'
