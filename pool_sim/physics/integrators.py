"""Fixed-step integrators of the smooth dynamics, interchangeable by name.

Each is `advance(dynamics, spheres, position, velocity, dt) -> (position, velocity)`: a pure
function of (3, n) arrays in m and m/s; contacts are resolved afterwards, outside them.
"""
import numpy as np


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

    Symplectic Euler in which the two stiff parts are taken at the end of the step:
    quadratic drag as gain(v_now) * (v_new - flow), and the buoyancy spring at the waterline
    as -k * (z_new - z).  Solving for v_new is a division per sphere:
        (m + dt*gain + dt^2*k_z) v_new = m*v + dt*(F + gain*flow)
    It never reverses a relative velocity by drag alone, damps the float like backward Euler,
    and its fixed points are exact: terminal velocity and floating draft have no step error.
    """
    env = dynamics.env
    water_fraction = dynamics.water_fraction(spheres, position)
    inertia = dynamics.inertia(spheres, water_fraction)
    momentum = inertia * velocity + dt * dynamics.explicit_force(
        spheres, position, velocity, water_fraction)
    denominator = np.broadcast_to(inertia, (3, spheres.count)).copy()
    gains = dynamics.drag_gains(spheres, velocity, water_fraction)
    if gains is not None:
        gain_air, gain_water = gains
        momentum += dt * (gain_air * env.air.flow_velocity[:, None]
                          + gain_water * env.water.flow_velocity[:, None])
        denominator += dt * (gain_air + gain_water)
    stiffness = dynamics.vertical_stiffness(spheres, position)
    if stiffness is not None:
        denominator[2] += dt * dt * stiffness
    new_velocity = momentum / denominator
    return position + dt * new_velocity, new_velocity


INTEGRATORS = {
    'explicit_euler': explicit_euler,
    'semi_implicit_euler': semi_implicit_euler,
    'velocity_verlet': velocity_verlet,
    'rk4': rk4,
    'linearly_implicit_euler': linearly_implicit_euler,
}
DEFAULT_INTEGRATOR = 'linearly_implicit_euler'
