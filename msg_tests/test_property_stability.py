"""Property-based: whatever sphere, step, speed, place and gravity, the default integrator
stays finite and inside the pool, and without external forces its energy never grows.

Which energy: kinetic (1/2*m*v^2) + gravitational (-m*g.x) + buoyancy potential (the
integral of the buoyant force over depth). That potential exists only when gravity is
normal to the water surface: with gravity tilted, buoyancy's horizontal part depends on
depth and does work around a closed loop, so no energy is conserved and only finiteness and
the pool are checked. Wind and current are off: a moving fluid feeds energy in.
With added mass on, the fluid's share of the inertia is not an energy of the sphere, and our
model (the contract's 1/2*rho*V_sub joining the inertia) leaves out the d(m_a)/dz*v^2 force a
Lagrangian model has, so that property checks finiteness and the pool only.

The bound: above the lowest energy reached so far the energy may rise by at most
(m + rho_w*V)*|g|*v_max*dt, the most work gravity and buoyancy together can do in one step
(a wobble), and it ends at or below its start.
"""
import math

from hypothesis import given, HealthCheck, settings, strategies as st
import numpy as np

from pool_sim.physics import DEFAULT_EFFECTS, Scene, Simulation

POOL = 10.0  # half-width of the pool, m: room for a 2 m sphere anywhere


def log_uniform(low, high):
    return st.floats(math.log10(low), math.log10(high)).map(lambda e: 10.0**e)


def unit_vectors():
    return st.tuples(*[st.floats(-1.0, 1.0)] * 3).filter(
        lambda v: np.linalg.norm(v) > 0.1).map(lambda v: np.array(v) / np.linalg.norm(v))


@st.composite
def spheres(draw, gravity_directions):
    radius = draw(log_uniform(1e-3, 2.0))
    place = draw(st.sampled_from(['air', 'surface', 'water']))
    room = POOL - radius
    z = {'air': draw(st.floats(radius, room)), 'water': draw(st.floats(-room, -radius)),
         'surface': draw(st.floats(-radius, radius))}[place]
    return {
        'mass': draw(log_uniform(1e-4, 1e4)), 'radius': radius,
        'position': [draw(st.floats(-room, room)), draw(st.floats(-room, room)), z],
        'velocity': list(draw(unit_vectors()) * draw(st.floats(0.0, 100.0))),
        'gravity': list(9.81 * draw(gravity_directions)),
        'dt': draw(log_uniform(5e-3, 0.1)),
        'restitution': draw(st.floats(0.0, 1.0)),
        'friction': draw(st.floats(0.0, 1.0)),
    }


def scene_of(case, effects=DEFAULT_EFFECTS):
    return Scene({
        'sphere_names': ['ball'], 'ball.mass': case['mass'], 'ball.radius': case['radius'],
        'ball.position': case['position'], 'ball.velocity': case['velocity'],
        'gravity': case['gravity'], 'effects': list(effects),
        'pool.min': [-POOL] * 3, 'pool.max': [POOL] * 3,
        'contact.restitution': case['restitution'],
        'contact.static_friction': case['friction'],
        'contact.kinetic_friction': case['friction'],
        'physics_rate_hz': 1.0 / case['dt']})


def run_ten_seconds(sim):
    """Step 10 s, checking every state; returns (start, worst rise, end energy, top speed)."""
    start = sim.mechanical_energy()[0]
    lowest, worst_rise, top_speed = start, 0.0, float(np.linalg.norm(sim.spheres.velocity))
    radius = sim.spheres.radius[0]
    for _ in range(math.ceil(10.0 / sim.max_step)):
        sim.step()
        position, velocity = sim.spheres.position[:, 0], sim.spheres.velocity[:, 0]
        assert np.all(np.isfinite(position)) and np.all(np.isfinite(velocity))
        assert np.all(np.abs(position) <= POOL - radius + 1e-9)
        energy = sim.mechanical_energy()[0]
        worst_rise = max(worst_rise, energy - lowest)
        lowest = min(lowest, energy)
        top_speed = max(top_speed, float(np.linalg.norm(velocity)))
    return start, worst_rise, sim.mechanical_energy()[0], top_speed


VERTICAL = st.sampled_from([np.array([0.0, 0.0, -1.0]), np.array([0.0, 0.0, 1.0])])
# How many examples: the profile loaded in conftest.py (40 unless asked otherwise).
SETTINGS = settings(deadline=None, suppress_health_check=[HealthCheck.too_slow])


@SETTINGS
@given(spheres(VERTICAL))
def test_energy_never_grows_beyond_a_one_step_wobble_and_ends_below_its_start(case):
    sim = Simulation(scene_of(case))
    start, worst_rise, end, top_speed = run_ten_seconds(sim)
    volume = 4.0 / 3.0 * math.pi * case['radius']**3
    bound = (case['mass'] + 1000.0 * volume) * 9.81 * top_speed * case['dt']
    roundoff = 1e-9 * (abs(start) + case['mass'] * 9.81 * POOL)
    assert worst_rise <= bound + roundoff, (worst_rise, bound)
    assert end <= start + roundoff


@SETTINGS
@given(spheres(unit_vectors()))
def test_any_gravity_direction_stays_finite_and_inside_the_pool(case):
    run_ten_seconds(Simulation(scene_of(case)))


@SETTINGS
@given(spheres(unit_vectors()))
def test_with_lift_and_added_mass_it_stays_finite_and_inside_the_pool(case):
    scene = scene_of(case, ('gravity', 'buoyancy', 'drag', 'lift', 'added_mass',
                            'wave_radiation', 'contact', 'friction')).with_values(
        **{'ball.lift_coefficient': 1.2})
    run_ten_seconds(Simulation(scene))
