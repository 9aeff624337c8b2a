"""Coulomb friction on the floor: static below mu_s*N, (F - mu_k*N)/m above it."""
import pytest

from pool_sim.physics import Simulation
from scenes import G, one_sphere

MASS, MU_S, MU_K = 2.0, 0.6, 0.4
NORMAL = MASS * G


def sphere_on_the_floor(rolling=0.0, rate=1000.0):
    # All air (surface below the floor) and no drag: the normal force is exactly m*g.
    # A 100 m floor: the fastest case slides 7 m in the test's second.
    scene = one_sphere(0.1, mass=MASS, position=(0, 0, -3.9), water__surface_z=-10.0,
                       pool_min=(-50, -50, -4), pool_max=(50, 50, 4),
                       effects=['gravity', 'contact', 'friction'],
                       contact__static_friction=MU_S, contact__kinetic_friction=MU_K,
                       contact__rolling_friction=rolling, physics_rate_hz=rate)
    return Simulation(scene)


@pytest.mark.parametrize('fraction_of_static_limit', [0.1, 0.5, 0.99])
def test_a_push_below_static_friction_does_not_move_it(fraction_of_static_limit):
    sim = sphere_on_the_floor()
    sim.set_external_force('ball', [fraction_of_static_limit * MU_S * NORMAL, 0.0, 0.0])
    sim.advance(2.0)
    assert sim.spheres.position[0, 0] == 0.0
    assert sim.spheres.velocity[0, 0] == 0.0
    assert sim.spheres.position[2, 0] == pytest.approx(-3.9, abs=1e-12)


@pytest.mark.parametrize('rolling', [0.0, 0.05])
@pytest.mark.parametrize('fraction_of_static_limit', [1.2, 3.0])
def test_a_push_above_static_friction_accelerates_at_the_kinetic_rate(fraction_of_static_limit,
                                                                       rolling):
    push = fraction_of_static_limit * MU_S * NORMAL
    sim = sphere_on_the_floor(rolling)
    sim.set_external_force('ball', [0.0, push, 0.0])
    duration = 1.0
    sim.advance(duration)
    acceleration = (push - (MU_K + rolling) * NORMAL) / MASS
    assert sim.spheres.velocity[1, 0] == pytest.approx(acceleration * duration, rel=1e-3)
    assert sim.spheres.position[1, 0] == pytest.approx(0.5 * acceleration * duration**2,
                                                       rel=0.01)
    assert sim.spheres.velocity[0, 0] == 0.0


def test_a_sliding_sphere_stops_and_stays_stopped():
    sim = sphere_on_the_floor()
    sim.spheres.velocity[0, 0] = 2.0
    sim.advance(2.0)
    stop_distance = 2.0**2 / (2 * MU_K * G)
    assert sim.spheres.velocity[0, 0] == 0.0
    assert sim.spheres.position[0, 0] == pytest.approx(stop_distance, rel=0.01)


def test_friction_in_a_floor_corner_never_pushes_a_sphere_through_the_wall():
    # Found by hypothesis: the slide correction pointed back at the wall just bounced off.
    # The first step crosses both the wall (y) and the floor (z) of the corner.
    scene = one_sphere(0.5, mass=1.0, position=(0.0, -3.495, -3.49), velocity=(0.0, -2.0, -2.0),
                       effects=['gravity', 'contact', 'friction'], contact__rolling_friction=0.3,
                       contact__static_friction=0.3, contact__kinetic_friction=0.0,
                       water__surface_z=-10.0, physics_rate_hz=100.0)
    sim = Simulation(scene)
    for _ in range(100):
        sim.step()
        assert sim.spheres.position[1, 0] >= -3.5 and sim.spheres.position[2, 0] >= -3.5
