"""No bounce adds energy: the floor and ceiling give back restitution x the speed at impact.

Bouncing from the speed at the step's start instead let a sphere slowed on its way in (a
cork pushed down onto the floor under water) leave faster than it hit: with restitution 1 a
cork 8 cm above the floor at 3 m/s gained 52 % of its kinetic energy at 30 Hz.
"""
import math

from hypothesis import given, HealthCheck, settings, strategies as st
import numpy as np
import pytest

from pool_sim.physics import INTEGRATORS, mechanical_energy, Simulation
from scenes import G, one_sphere, sphere_volume, WATER

NO_DRAG = ['gravity', 'buoyancy', 'contact']


@pytest.mark.parametrize('integrator', list(INTEGRATORS))
def test_a_cork_pushed_onto_the_floor_under_water_leaves_at_its_speed_at_impact(integrator):
    # Under water the cork's net force is constant, so every integrator ends the step with
    # the exact speed, and the exact speed at impact is sqrt(u^2 - 2*a*d): 2.34 m/s, not 3
    # (the old bounce, from the speed at the step's start).
    radius, gap, speed, rate_hz = 0.2, 0.06, 3.0, 30.0
    sim = Simulation(one_sphere(radius, 250.0, position=(0, 0, -4.0 + radius + gap),
                                velocity=(0, 0, -speed), effects=NO_DRAG,
                                contact__restitution=1.0, integrator=integrator,
                                physics_rate_hz=rate_hz))
    start = sim.mechanical_energy()[0]
    sim.step()
    assert sim.spheres.position[2, 0] == -4.0 + radius  # it did reach the floor in this step
    deceleration = (WATER / 250.0 - 1.0) * G  # the air's density does not act under water
    at_impact = math.sqrt(speed**2 - 2.0 * deceleration * gap)
    lowest = at_impact
    if integrator == 'semi_implicit_euler':
        # Its end position falls a*dt^2/2 short of the exact one, which makes the estimate
        # back from the end the lower by (a*dt)^2 in v^2: 2.12 m/s.
        lowest = math.sqrt(at_impact**2 - (deceleration / rate_hz)**2)
    assert lowest * (1.0 - 1e-12) <= sim.spheres.velocity[2, 0] <= at_impact * (1.0 + 1e-12)
    assert sim.mechanical_energy()[0] <= start + 1e-12 * abs(start)


def log_uniform(low, high):
    return st.floats(math.log10(low), math.log10(high)).map(lambda e: 10.0**e)


@st.composite
def throws(draw):
    """A sphere thrown at the floor, or (buoyant) at the ceiling, with the water surface
    anywhere from below the floor to above the ceiling."""
    buoyant = draw(st.booleans())
    density = draw(log_uniform(20.0, 900.0) if buoyant else log_uniform(1100.0, 2e4))
    radius = draw(log_uniform(0.01, 0.5))
    face = draw(st.sampled_from(['floor', 'ceiling'] if buoyant else ['floor']))
    gap = draw(st.floats(0.0, 1.0))
    z = -4.0 + radius + gap if face == 'floor' else 4.0 - radius - gap
    toward = -1.0 if face == 'floor' else 1.0
    integrator = draw(st.sampled_from(list(INTEGRATORS)))
    return {'density': density, 'radius': radius, 'position': (0.0, 0.0, z),
            'velocity': (draw(st.floats(-3.0, 3.0)), 0.0, toward * draw(st.floats(0.0, 30.0))),
            'surface_z': draw(st.floats(-5.0, 5.0)), 'dt': draw(log_uniform(1e-3, 0.1)),
            'integrator': integrator}


def energy_of(sim, position, velocity):
    spheres = sim.spheres.copy()
    spheres.position, spheres.velocity = position, velocity
    return mechanical_energy(sim.environment, spheres)[0]


SETTINGS = settings(deadline=None, suppress_health_check=[HealthCheck.too_slow])


@SETTINGS
@given(throws())
def test_no_bounce_ends_a_step_with_more_energy_than_the_step_would_have_had_without_it(case):
    """Across every step in which contact acted: energy after <= the larger of the energy at
    the step's start and the energy the same step ends with when the wall is not there
    (an integrator's own error may add energy; the bounce must not add more)."""
    def thrown(effects):
        return Simulation(one_sphere(
            case['radius'], case['density'], position=case['position'],
            velocity=case['velocity'], effects=effects, water__surface_z=case['surface_z'],
            contact__restitution=1.0, integrator=case['integrator'],
            physics_rate_hz=1.0 / case['dt']))
    sim = thrown(NO_DRAG)
    free = thrown([effect for effect in NO_DRAG if effect != 'contact'])  # no wall there
    radius = case['radius']
    # Round-off: relative to the energies in play (weight and buoyancy across the pool).
    scale = ((sim.spheres.mass[0] + WATER * sphere_volume(radius)) * G * 8.0
             + 0.5 * sim.spheres.mass[0] * float(np.sum(np.square(case['velocity']))))
    pool = sim.environment.pool
    faces = np.array([pool.corner_min + radius, pool.corner_max - radius]).T
    for _ in range(min(200, math.ceil(2.0 / case['dt']))):
        start = sim.mechanical_energy()[0]
        free.spheres.position[:], free.spheres.velocity[:] = (sim.spheres.position,
                                                              sim.spheres.velocity)
        free.step()
        free_position, free_velocity = free.spheres.position, free.spheres.velocity
        sim.step()
        if not np.any(sim.spheres.position[:, :1] == faces):
            continue  # contact puts a sphere exactly on a face: it did not act
        bound = max(start, energy_of(sim, free_position, free_velocity))
        assert sim.mechanical_energy()[0] <= bound + 1e-9 * (abs(bound) + scale)
