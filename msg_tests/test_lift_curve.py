"""Lift by angle of attack: the lift curve's closed forms at chosen angles, its symmetry and
continuity, and what it changes for a buoyant sphere thrown with lift."""
import math

import numpy as np
import pytest

from pool_sim.physics import Simulation
from pool_sim.physics.effects import effect_flags
from pool_sim.physics.kernels.effects import lift_force
from pool_sim.physics.stepper import body_tuple, environment_tuple
from scenes import one_sphere

SPEED, AREA, WATER = 3.0, 0.05, 1000.0
PEAK, SLOPE, STALL = 1.2, 2.0 * math.pi, math.radians(15.0)


def lift_at(attack_deg, peak=PEAK, slope=SLOPE, stall=STALL, speed=SPEED):
    """Lift (N, 3) on a sphere wholly under still water moving at `speed` in the x-z
    plane at attack_deg to its lifting surface (normal +z)."""
    scene = one_sphere(0.1, 500.0, position=(0.0, 0.0, -2.0), effects=['lift']).with_values(
        **{'ball.lift_coefficient': peak, 'ball.lift_area': AREA, 'ball.lift_slope': slope,
           'ball.stall_angle': stall})
    sim = Simulation(scene)
    attack = math.radians(attack_deg)
    velocity = (speed * math.cos(attack), 0.0, speed * math.sin(attack))
    return np.array(lift_force(effect_flags(['lift']), environment_tuple(sim.environment),
                               body_tuple(sim.spheres, 0), 1.0, velocity))


def expected_coefficient(attack_deg, peak=PEAK, slope=SLOPE, stall=STALL):
    """C_l written out: slope * alpha up to the stall (at most |peak|), then linearly to
    zero at 90 degrees; odd in alpha, signed by peak."""
    alpha = math.radians(abs(attack_deg))
    if alpha <= stall:
        size = min(slope * alpha, abs(peak))
    else:
        size = min(slope * stall, abs(peak)) * (math.pi / 2 - alpha) / (math.pi / 2 - stall)
    return math.copysign(size, peak) * math.copysign(1.0, attack_deg)


@pytest.mark.parametrize('attack_deg', [0.0, 1.0, 3.0, 10.0, 12.0, 15.0, 30.0, 45.0, 80.0,
                                        90.0])
def test_the_lift_follows_the_curve_at_chosen_angles(attack_deg):
    force = lift_at(attack_deg)
    dynamic = 0.5 * WATER * AREA * SPEED**2
    coefficient = expected_coefficient(attack_deg)
    # The flow meets the surface from above (velocity along +n): pushed down, across it.
    attack = math.radians(attack_deg)
    across = np.array([math.sin(attack), 0.0, -math.cos(attack)])
    np.testing.assert_allclose(force, coefficient * dynamic * across, rtol=1e-12,
                               atol=1e-12 * dynamic)
    velocity = np.array([math.cos(attack), 0.0, math.sin(attack)])
    assert abs(force @ velocity) <= 1e-12 * dynamic  # perpendicular to the flow


def test_the_closed_forms_by_hand():
    dynamic = 0.5 * WATER * AREA * SPEED**2
    assert np.linalg.norm(lift_at(0.0)) == 0.0  # edge-on: no lift
    assert np.linalg.norm(lift_at(90.0)) < 1e-12 * dynamic  # face-on: stalled to nothing
    assert np.linalg.norm(lift_at(5.0)) == pytest.approx(2 * math.pi * math.radians(5.0)
                                                         * dynamic, rel=1e-12)
    assert np.linalg.norm(lift_at(14.0)) == pytest.approx(1.2 * dynamic, rel=1e-12)  # capped
    assert np.linalg.norm(lift_at(52.5)) == pytest.approx(0.6 * dynamic, rel=1e-12)  # half


def test_it_is_odd_in_the_angle_and_flips_with_the_coefficients_sign():
    for attack_deg in (2.0, 9.0, 20.0, 60.0):
        up, down = lift_at(attack_deg), lift_at(-attack_deg)
        # The flow mirrored through the surface plane: the lift mirrored with it.
        np.testing.assert_allclose(down, [up[0], 0.0, -up[2]], rtol=1e-12, atol=1e-12)
        np.testing.assert_allclose(lift_at(attack_deg, peak=-PEAK), -up, rtol=1e-12)


def test_it_is_continuous_through_edge_on_and_face_on():
    dynamic = 0.5 * WATER * AREA * SPEED**2
    for near in (1e-9, 1e-6):
        assert np.linalg.norm(lift_at(near)) < 2 * math.pi * math.radians(near) * dynamic * 1.01
        assert np.linalg.norm(lift_at(90.0 - near)) < 1e-3 * dynamic
        assert np.linalg.norm(lift_at(-90.0 + near)) < 1e-3 * dynamic
    # Along the normal itself, rounding leaves no direction to push along: no lift at all.
    assert np.all(np.isfinite(lift_at(90.0, speed=1e4)))


def test_edge_on_there_is_no_lift_so_a_neutral_sphere_keeps_its_depth():
    """The old lift had its full size edge-on: this sphere, of the water's own density,
    moving level under water with its lifting surface level, was lifted out of its depth.
    Edge-on there is no lift now, and nothing else moves it up or down."""
    scene = one_sphere(0.1, 1000.0, position=(-3.0, 0.0, -2.0), velocity=(2.0, 0.0, 0.0),
                       effects=['gravity', 'buoyancy', 'drag', 'lift'], air__density=0.0)
    sim = Simulation(scene.with_values(**{'ball.lift_coefficient': 1.0}))
    sim.advance(2.0)
    assert sim.spheres.position[0, 0] > -2.5  # it moved on
    assert sim.spheres.position[2, 0] == pytest.approx(-2.0, abs=1e-12)
    assert sim.spheres.velocity[2, 0] == pytest.approx(0.0, abs=1e-12)


def test_a_buoyant_sphere_thrown_with_lift_rises_and_floats():
    """Thrown down through the surface at 10 m/s with a strong lift: it comes up and floats
    at its draft, lift and all."""
    scene = one_sphere(0.1, 250.0, position=(0.0, 0.0, 1.0), velocity=(1.0, 0.0, -10.0),
                       effects=['gravity', 'buoyancy', 'drag', 'lift', 'wave_radiation',
                                'contact', 'friction']).with_values(
        **{'ball.lift_coefficient': 1.5, 'ball.lift_normal': [0.0, 0.0, 1.0]})
    sim = Simulation(scene)
    sim.advance(30.0)
    draft = 0.6527 * 0.1  # density ratio 1/4
    assert sim.spheres.position[2, 0] == pytest.approx(0.1 - draft, abs=5e-3)
    assert np.linalg.norm(sim.spheres.velocity[:, 0]) < 0.05
