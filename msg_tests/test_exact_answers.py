"""Physics against answers that do not come from pool_sim: closed forms and equilibria."""
import math

import numpy as np
import pytest

from pool_sim.physics import Simulation
from pool_sim.physics.effects import effect_flags
from pool_sim.physics.kernels import effects
from pool_sim.physics.stepper import body_tuple, environment_tuple
from scenes import floating_draft_ratio, G, one_sphere, sphere_volume, WATER


def test_steel_sphere_reaches_the_closed_form_terminal_velocity_in_water():
    radius, density, drag_coefficient = 0.01, 7850.0, 0.47
    scene = one_sphere(radius, density, position=(0, 0, -10), pool_min=(-5, -5, -100),
                       effects=['gravity', 'buoyancy', 'drag'],
                       ball__drag_coefficient=drag_coefficient)
    sim = Simulation(scene)
    sim.advance(3.0)
    volume, area = sphere_volume(radius), math.pi * radius**2
    terminal = math.sqrt(2 * (density - WATER) * volume * G / (WATER * drag_coefficient * area))
    assert sim.spheres.velocity[2, 0] == pytest.approx(-terminal, rel=0.005)


@pytest.mark.parametrize('air_density', [1e-9, 1.2])
def test_quarter_density_sphere_floats_at_the_exact_cap_draft(air_density):
    radius = 0.2
    # Quadratic drag damps a small bob slowly; a high C_d settles it within the test. The
    # draft does not depend on drag.
    scene = one_sphere(radius, 250.0, position=(0, 0, 1.0), air__density=air_density,
                       ball__drag_coefficient=10.0)
    sim = Simulation(scene)
    sim.advance(60.0)
    draft = (radius - sim.spheres.position[2, 0]) / radius
    # Air buoys the part above the water too: the cap holds (rho_s - rho_a)/(rho_w - rho_a).
    expected = floating_draft_ratio((250.0 - air_density) / (WATER - air_density))
    assert draft == pytest.approx(expected, rel=0.01)
    if air_density < 1e-6:
        assert draft == pytest.approx(0.6527, rel=0.01)
    # What is left is a bob of |v|/omega < 0.5 mm (omega = 12 rad/s), still decaying.
    assert abs(sim.spheres.velocity[2, 0]) < 5e-3


def test_sphere_of_the_waters_density_stays_where_it_is_put():
    start = np.array([0.5, -0.3, -2.0])
    sim = Simulation(one_sphere(0.1, WATER, position=start))
    sim.advance(100.0)
    assert np.max(np.abs(sim.spheres.position[:, 0] - start)) < 1e-9


def explicit_force(sim, index=0):
    """The compiled per-sphere forces but drag (N) on one sphere, as the step sees them."""
    env, body = environment_tuple(sim.environment), body_tuple(sim.spheres, index)
    listed = effect_flags(sim.scene['effects'])
    fraction = effects.water_fraction(listed, env, body, float(sim.spheres.position[2, index]))
    return np.array(effects.explicit_force(listed, env, body,
                                           tuple(sim.spheres.velocity[:, index]), fraction))


def test_with_upward_gravity_buoyancy_pushes_down():
    scene = one_sphere(0.1, 500.0, position=(0, 0, -2), gravity=[0.0, 0.0, 9.81],
                       effects=['buoyancy'])
    force = explicit_force(Simulation(scene))
    assert force[2] == pytest.approx(-WATER * sphere_volume(0.1) * G, rel=1e-12)
    assert force[0] == force[1] == 0.0


def test_buoyancy_follows_tilted_gravity():
    gravity = np.array([3.0, 0.0, -9.0])
    scene = one_sphere(0.1, 500.0, position=(0, 0, -2), gravity=list(gravity),
                       effects=['buoyancy'])
    np.testing.assert_allclose(explicit_force(Simulation(scene)),
                               -WATER * sphere_volume(0.1) * gravity, rtol=1e-12)


def test_linear_submerged_volume_is_kept_only_as_a_named_option():
    scene = one_sphere(0.2, 250.0, position=(0, 0, 1.0), air__density=1e-9,
                       ball__drag_coefficient=10.0)
    sim = Simulation(scene, submerged_volume='linear')
    sim.advance(60.0)
    draft = (0.2 - sim.spheres.position[2, 0]) / 0.2
    assert draft == pytest.approx(0.5, rel=0.01)  # depth / diameter = 0.25
