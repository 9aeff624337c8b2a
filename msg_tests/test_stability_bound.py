"""Stable step bounds of the explicit integrators: textbook limits, and what they predict."""
import math

import numpy as np
import pytest

import rclpy
from rclpy.context import Context

from pool_sim.physics import Simulation
from pool_sim.physics.stability import sphere_stiffness, stable_step_bound
from pool_sim.ros.simulator_node import PoolSimNode
from ros_harness import overrides
from scenes import one_sphere


def undamped_float():
    # Half the water's density and no air: it floats centred on the surface, z = 0.
    return one_sphere(0.1, 500.0, position=(0, 0, 0), effects=['gravity', 'buoyancy'],
                      air__density=1e-9)


@pytest.mark.parametrize('integrator, limit_times_omega', [
    ('semi_implicit_euler', 2.0), ('velocity_verlet', 2.0), ('rk4', 2.0 * math.sqrt(2.0)),
    ('linearly_implicit_euler', math.inf)])
def test_bounds_on_an_undamped_spring_are_the_textbook_limits(integrator, limit_times_omega):
    omega = math.sqrt(sphere_stiffness(undamped_float())[0][0])
    bound = stable_step_bound(undamped_float(), integrator)
    assert bound * omega == pytest.approx(limit_times_omega, rel=1e-6)


def test_explicit_euler_has_no_stable_step_on_an_undamped_spring():
    # Its growth per step is sqrt(1 + (omega*dt)^2): only the 1e-12 tolerance admits any dt.
    omega = math.sqrt(sphere_stiffness(undamped_float())[0][0])
    assert stable_step_bound(undamped_float(), 'explicit_euler') * omega < 1e-5


@pytest.mark.parametrize('integrator', ['semi_implicit_euler', 'velocity_verlet', 'rk4'])
def test_the_bound_separates_growth_from_decay_on_the_linearised_float(integrator):
    scene = undamped_float().with_values(integrator=integrator)
    bound = stable_step_bound(scene)
    for factor, grows in ((0.9, False), (1.2, True)):
        sim = Simulation(scene.with_values(physics_rate_hz=1.0 / (factor * bound)))
        sim.spheres.position[2, 0] = -0.005  # 5 mm off its float: the linear regime
        # The largest swing over 400 steps: beyond the waterline band (r = 0.1 m) the spring
        # is gone, so an unstable float swings chaotically there rather than for ever out.
        amplitude = 0.0
        for _ in range(400):
            sim.step()
            amplitude = max(amplitude, abs(sim.spheres.position[2, 0]))
        escaped = not np.isfinite(amplitude) or amplitude > 0.05
        assert escaped == grows, (integrator, factor)


@pytest.mark.parametrize('integrator, rate_hz, warns', [
    ('semi_implicit_euler', 10.0, True), ('semi_implicit_euler', 200.0, False),
    ('linearly_implicit_euler', 10.0, False)])
def test_the_node_warns_at_startup_when_the_rate_is_beyond_the_bound(capfd, integrator,
                                                                     rate_hz, warns):
    context = Context()
    rclpy.init(context=context)
    try:
        node = PoolSimNode(context=context, parameter_overrides=overrides({
            'integrator': integrator, 'physics_rate_hz': rate_hz}))
        node.destroy_node()
    finally:
        rclpy.shutdown(context=context)
    log = capfd.readouterr().err
    assert (f'{integrator} is unstable at {rate_hz:g} Hz' in log) == warns, log
    if warns:
        assert 'needs a step under 28.6 ms' in log
