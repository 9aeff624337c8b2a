"""Sphere-sphere contact (the `collisions` effect): the broad phase against brute force,
binary collisions against their exact answers, energy never gained at a contact, piles at
rest on the floor and at the surface, and hostile cases.
"""
import math

from hypothesis import example, given, settings, strategies as st
import numpy as np
import pytest

from pool_sim.physics import INTEGRATORS, Scene, Simulation
from pool_sim.physics.contacts.detection import find_contacts, overlaps, SPECULATIVE_MARGIN
from pool_sim.physics.contacts.sequential_impulses import OVERLAP_TOLERANCE

G = 9.81


def spheres_scene(position, velocity=None, radius=0.05, mass=1.0, effects=('collisions',),
                  **keys):
    """A scene of len(position) spheres; radius and mass a number or one per sphere."""
    position = np.asarray(position, dtype=float).reshape(-1, 3)
    count = len(position)
    velocity = np.zeros((count, 3)) if velocity is None else np.asarray(velocity, float)
    params = {'sphere_names': [f's{i}' for i in range(count)], 'effects': list(effects),
              'integrator': keys.pop('integrator', 'semi_implicit_euler'),
              'spheres.position': position.ravel().tolist(),
              'spheres.velocity': velocity.reshape(-1).tolist(),
              'spheres.radius': np.broadcast_to(radius, count).astype(float).tolist(),
              'spheres.mass': np.broadcast_to(mass, count).astype(float).tolist()}
    params.update({key.replace('__', '.'): value for key, value in keys.items()})
    return Scene(params)


def log_uniform(low, high):
    return st.floats(math.log10(low), math.log10(high)).map(lambda e: 10.0**e)


# The broad phase.

@settings(deadline=None)
@given(st.integers(2, 300), st.sampled_from([0.002, 0.05, 1.0]),
       st.sampled_from([0.05, 0.5, 3.0]), st.integers(0, 2**32 - 1))
def test_the_grid_finds_every_pair_within_reach_once_whatever_the_radii(count, largest,
                                                                        spread, seed):
    # Radii over up to three decades in one scene: the hierarchy's levels must meet.
    rng = np.random.default_rng(seed)
    radius = np.exp(rng.uniform(math.log(0.001), math.log(largest), count))
    position = rng.uniform(-spread, spread, (3, count))
    still = np.zeros_like(position)
    pairs = find_contacts(position, still, position, still, radius, 0.01)[0]
    found = {tuple(sorted(pair)) for pair in pairs.T.tolist()}
    assert len(found) == pairs.shape[1]  # none twice
    distance = np.linalg.norm(position[:, :, None] - position[:, None, :], axis=0)
    reach = (radius[:, None] + radius[None, :]) * (1.0 + SPECULATIVE_MARGIN)
    within = {tuple(pair) for pair in np.argwhere(np.triu(distance < reach * (1 - 1e-12), 1))}
    assert within <= found
    assert found <= {tuple(pair) for pair in np.argwhere(np.triu(distance <= reach, 1))}


def test_a_sphere_fast_enough_to_pass_through_another_in_one_step_hits_it():
    # 0.5 m per step, ten diameters: the swept test finds the contact the end state hides.
    sim = Simulation(spheres_scene([(-0.3, 0, 0), (0.0, 0, 0)], [(100.0, 0, 0), (0, 0, 0)],
                                   radius=0.025, contact__restitution=1.0))
    sim.step()
    velocity = sim.spheres.velocity
    assert velocity[0, 0] == pytest.approx(0.0, abs=1e-9)
    assert velocity[0, 1] == pytest.approx(100.0, rel=1e-12)
    assert sim.spheres.position[0, 1] > sim.spheres.position[0, 0]  # still in order


@pytest.mark.parametrize('restitution', [0.0, 0.5, 1.0])
def test_a_pair_parting_in_the_step_is_not_driven_into_each_other_by_a_third(restitution):
    # A column: b is leaving a (0.1 mm apart at the step's start, 3.1 mm at its end,
    # beyond the 2 mm margin), and a sphere 1 000 times heavier falls 5 cm onto b within
    # the same step. Pushing them apart sends b back into a: a and b must meet as a
    # contact in that step (when a pair parting at the step's end was no contact, b
    # ended 4.9 cm deep in a).
    radius = 0.05
    sim = Simulation(spheres_scene(
        [(0, 0, 0), (0, 0, 2 * radius + 1e-4), (0, 0, 4 * radius + 0.0011)],
        [(0, 0, 0), (0, 0, 0.3), (0, 0, -5.0)], radius=radius, mass=[1.0, 1.0, 1000.0],
        contact__restitution=restitution, physics_rate_hz=100.0))
    energy = 0.5 * sim.spheres.mass @ (sim.spheres.velocity**2).sum(axis=0)
    for _ in range(5):
        sim.step()
        _, depth = overlaps(sim.spheres.position, sim.spheres.radius)
        assert depth.max(initial=0.0) <= OVERLAP_TOLERANCE * radius
    assert 0.5 * sim.spheres.mass @ (sim.spheres.velocity**2).sum(axis=0) <= energy * (1 + 1e-12)


# Binary collisions: exact answers.

def collide(mass_a, mass_b, restitution, speed_a, speed_b, offset, radius=0.05):
    """Two spheres along x, centres `offset` x the contact distance apart across it;
    the simulation after they have met, the momentum they started with, their approach
    speed and the rounding the momentum may show (1e-12 of the sum of its two parts':
    two nearly opposite momenta leave a sum whose own size says nothing of it)."""
    speed_b = min(speed_b, speed_a - 0.5)  # they close
    sim = Simulation(spheres_scene(
        [(-0.2, 0, 0), (0.2, offset * 2 * radius, 0)], [(speed_a, 0, 0), (speed_b, 0, 0)],
        radius=radius, mass=[mass_a, mass_b], contact__restitution=restitution,
        physics_rate_hz=1000.0))
    momentum = sim.spheres.mass @ sim.spheres.velocity.T
    rounding = 1e-12 * np.abs(sim.spheres.mass * sim.spheres.velocity).sum()
    sim.advance(1.0)
    return sim, momentum, speed_a - speed_b, rounding


masses, restitutions = log_uniform(1e-3, 1e3), st.floats(0.0, 1.0)
speeds = st.floats(0.6, 20.0), st.floats(-20.0, 20.0)


@settings(deadline=None)
@given(masses, masses, restitutions, *speeds)
def test_a_head_on_collision_keeps_momentum_and_restitution_squared_of_the_energy(
        mass_a, mass_b, restitution, speed_a, speed_b):
    sim, momentum, approach, rounding = collide(mass_a, mass_b, restitution, speed_a,
                                                speed_b, 0.0)
    velocity = sim.spheres.velocity
    assert sim.spheres.mass @ velocity.T == pytest.approx(momentum, rel=1e-12, abs=rounding)
    separation = velocity[0, 1] - velocity[0, 0]
    assert separation == pytest.approx(restitution * approach, rel=1e-9, abs=1e-12)
    reduced = mass_a * mass_b / (mass_a + mass_b)  # the kinetic energy of relative motion
    assert 0.5 * reduced * separation**2 == pytest.approx(
        restitution**2 * 0.5 * reduced * approach**2, rel=1e-9, abs=1e-15)
    assert np.abs(velocity[1:]).max() == 0.0


@settings(deadline=None)
@given(masses, masses, restitutions, *speeds, st.floats(-0.95, 0.95))
def test_a_glancing_collision_keeps_momentum_and_gains_no_energy(
        mass_a, mass_b, restitution, speed_a, speed_b, offset):
    sim, momentum, _, rounding = collide(mass_a, mass_b, restitution, speed_a, speed_b, offset)
    mass, velocity = sim.spheres.mass, sim.spheres.velocity
    assert mass @ velocity.T == pytest.approx(momentum, rel=1e-12, abs=rounding)
    start = 0.5 * (mass_a * speed_a**2 + mass_b * min(speed_b, speed_a - 0.5)**2)
    assert 0.5 * mass @ (velocity**2).sum(axis=0) <= start * (1 + 1e-12)


@pytest.mark.parametrize('rate_hz, speed', [(200.0, 0.003), (200.0, 0.006), (20.0, 0.03)])
def test_a_slow_collision_across_gravity_passes_its_momentum_on(rate_hz, speed):
    # Falling side by side, one 3-30 mm/s toward the other: between 1 % and 10 % of a
    # step's fall, the slack weight-bearing contacts get (found in review: with that slack
    # across gravity too, the first kept its speed and the second never took any). Below
    # resting speed the rebound is none: both move on at half the speed.
    sim = Simulation(spheres_scene([(-0.2, 0, 3.9), (0.0, 0, 3.9)], [(speed, 0, 0), (0, 0, 0)],
                                   effects=['gravity', 'collisions'], physics_rate_hz=rate_hz,
                                   pool__min=[-2, -2, -400.0], pool__max=[2, 2, 4.0]))
    sim.advance(0.2 / speed)
    velocity_x = sim.spheres.velocity[0]
    assert velocity_x == pytest.approx([speed / 2, speed / 2], rel=1e-9)


@pytest.mark.parametrize('speed', [0.003, 0.03])
def test_a_slow_collision_on_a_frictionless_floor_keeps_its_momentum(speed):
    # Resting on the floor, one 3-30 mm/s toward the other: slower than a step's fall,
    # so no rebound, and both move on at half the speed. The floor holds them up; it
    # takes no momentum across without friction (before: the resting spheres' velocity,
    # set to the step's move / dt, left both at a quarter of the speed they started with).
    z = -4.0 + 0.05
    sim = Simulation(spheres_scene([(-0.2, 0, z), (0.0, 0, z)], [(speed, 0, 0), (0, 0, 0)],
                                   effects=['gravity', 'contact', 'collisions'],
                                   physics_rate_hz=200.0, water__surface_z=-10.0))
    sim.advance(0.2 / speed)
    assert sim.spheres.velocity[0] == pytest.approx([speed / 2, speed / 2], rel=1e-9)
    assert np.abs(sim.spheres.velocity[1:]).max() <= 1e-12
    assert sim.spheres.position[2] == pytest.approx([z, z], abs=1e-12)


@pytest.mark.parametrize('push', [0.7, 1.0, 1.3])
def test_spheres_side_by_side_on_the_floor_slide_as_one_alone_does(push):
    # With friction, under the default integrator, two spheres touching side by side and
    # pushed alike (0.7-1.3 x their weight, along the row's normal) move as one alone does
    # (found in review: the resting spheres' velocity set to the step's move / dt, the
    # velocity at mid-step, held them to 0.44 of 2.89 m/s at 1.0 x their weight).
    z = -4.0 + 0.05

    def pushed(positions):
        sim = Simulation(spheres_scene(
            positions, effects=['gravity', 'contact', 'friction', 'collisions'],
            integrator='linearly_implicit_euler', water__surface_z=-10.0))
        for name in sim.spheres.names:
            sim.set_external_force(name, (push * G, 0, 0))
        sim.advance(0.5)
        return sim.spheres.velocity

    alone = pushed([(-3, 0, z)])[0, 0]
    together = pushed([(-3, 0, z), (-3, 0.1, z)])
    assert together[0] == pytest.approx([alone, alone], rel=1e-9)


@pytest.mark.parametrize('direction', [1.0, -1.0])
def test_newtons_cradle_passes_the_momentum_along_the_row(direction):
    # Five equal spheres touching at rest; a sixth hits the row at 1 m/s, restitution 1:
    # the last leaves at 1 m/s and the rest stay at rest.
    row = [(direction * -0.1 * i, 0, 0) for i in range(5)]
    sim = Simulation(spheres_scene([(direction * 0.6, 0, 0), *row],
                                   [(-direction, 0, 0)] + [(0, 0, 0)] * 5,
                                   contact__restitution=1.0))
    sim.advance(1.0)
    velocity = sim.spheres.velocity[0]
    assert velocity[-1] == pytest.approx(-direction, rel=1e-12)
    assert np.abs(velocity[:-1]).max() < 1e-12
    assert np.abs(sim.spheres.velocity[1:]).max() < 1e-12


@settings(deadline=None)
# Found by the deep profile: a buoyant sphere on the floor, rising (explicit Euler gave it
# 0.44 m/s in the step) under one sliding across it, was taken as resting and pushed that
# one on along their slanted normal (+5e-5 J).
@example(integrator='explicit_euler', radius=0.01, ratio=1.0, mass_low=0.1, mass_high=1.0,
         restitution=0.0, speed=0.0, gap=0.0, offset=0.0, sideways=0.5, in_water=True)
# And one a first version of that fix let through: thrown through its partner onto the
# floor within the step (explicit Euler), a sphere bounced up at 5 m/s, was projected 2 cm
# up, and kept its speed.
@example(integrator='explicit_euler', radius=0.01, ratio=1.0, mass_low=1.0, mass_high=1.0,
         restitution=1.0, speed=5.0, gap=0.0, offset=0.0, sideways=0.0, in_water=False)
@given(st.sampled_from(list(INTEGRATORS)), log_uniform(0.01, 0.3), log_uniform(0.1, 10.0),
       log_uniform(0.01, 100.0), log_uniform(0.01, 100.0), st.floats(0.0, 1.0),
       st.floats(0.0, 10.0), st.floats(0.0, 1.0), st.floats(-0.8, 0.8), st.floats(-3.0, 3.0),
       st.booleans())
def test_no_contact_adds_energy(integrator, radius, ratio, mass_low, mass_high, restitution,
                                speed, gap, offset, sideways, in_water):
    # A sphere thrown down at one resting on the floor, hitting it within the step: the
    # energy after the step is at most the start's, or what the integrator alone makes
    # of it without the contact (explicit Euler gains energy in any step).
    top_radius = radius * ratio
    surface = 4.0 if in_water else -4.0
    low_z = -4.0 + radius
    top_z = low_z + radius + top_radius + gap * speed / 200.0 + 1e-9
    effects = ['gravity', 'buoyancy', 'contact', 'collisions']

    def simulation(with_collisions):
        return Simulation(spheres_scene(
            [(0, 0, low_z), (offset * min(radius, top_radius), 0, top_z)],
            [(0, 0, 0), (sideways, 0, -speed)], radius=[radius, top_radius],
            mass=np.clip([mass_low * 4190 * radius**3, mass_high * 4190 * top_radius**3],
                         1e-6, 1e9),  # relative densities 0.01-100, within mass's range
            effects=effects if with_collisions else effects[:-1], integrator=integrator,
            contact__restitution=restitution, water__surface_z=surface))
    sim, alone = simulation(True), simulation(False)
    start = sim.mechanical_energy().sum()
    sim.step()
    alone.step()
    allowed = max(start, alone.mechanical_energy().sum())
    assert sim.mechanical_energy().sum() <= allowed + 1e-12 * abs(allowed) + 1e-15


@pytest.mark.xfail(strict=True, reason='a known sequential_impulses fault, not yet mended: '
                   'a sphere thrown at a very buoyant one on the floor gains 4.9e-4 J')
def test_a_sphere_thrown_at_a_buoyant_one_on_the_floor_gains_no_energy():
    # Found by the deep profile of test_no_contact_adds_energy on 2026-12-06: a sphere of
    # relative density 1 thrown down at 4 m/s, restitution 1, onto one of density 0.01 on
    # the floor under water (1 cm radii) leaves the pair with 0.5246 J against 0.5241 J.
    # soft_step's own property test passed its 1 000 that day. Strict: mended, it fails
    # until the mark goes.
    test_no_contact_adds_energy.hypothesis.inner_test(
        integrator='semi_implicit_euler', radius=0.01, ratio=1.0, mass_low=0.01,
        mass_high=1.0, restitution=1.0, speed=4.0, gap=0.0, offset=0.0, sideways=0.0,
        in_water=True)


# Piles at rest.

def lattice(count, spacing, centre_z, seed=0, jitter=0.004):
    side = int(round(count ** (1 / 3)))
    index = np.arange(count)
    cells = np.stack([index % side, (index // side) % side, index // side**2], 1)
    rng = np.random.default_rng(seed)
    position = (cells - (side - 1) / 2) * spacing + rng.uniform(-jitter, jitter, cells.shape)
    position[:, 2] += centre_z
    return position


# Measured (2026-12-04): from 15 s to 30 s the 1 000 pile keeps compacting slowly, rms
# speed 3.4-5.6 mm/s, fastest 1.6-7.4 cm/s, deepest overlap 0.81-1.14 % of a radius
# (every 0.5 s).
# Resting, not still: the bounds say so, with room for other machines' rounding.
PILE_RMS_SPEED = 0.01  # m/s
PILE_FASTEST = 0.1  # m/s


def test_a_pile_of_a_thousand_spheres_comes_to_rest_on_the_floor_gaining_no_energy():
    radius = 0.05
    sim = Simulation(spheres_scene(
        lattice(1000, 0.11, -2.8), radius=radius, mass=1.0,
        effects=['gravity', 'contact', 'friction', 'collisions'],
        pool__min=[-0.7, -0.7, -4.0], pool__max=[0.7, 0.7, 4.0]))
    energy = [sim.mechanical_energy().sum()]
    for _ in range(30):
        sim.advance(0.5)  # 15 s
        energy.append(sim.mechanical_energy().sum())
        assert np.isfinite(sim.spheres.position).all()
    # The drop turns potential energy into heat; no half second ends with more.
    assert np.all(np.diff(energy) <= 1e-9 * abs(energy[0]))
    _, depth = overlaps(sim.spheres.position, sim.spheres.radius)
    assert depth.max() <= OVERLAP_TOLERANCE * radius
    speed = np.linalg.norm(sim.spheres.velocity, axis=0)
    assert math.sqrt(np.mean(speed**2)) < PILE_RMS_SPEED
    assert speed.max() < PILE_FASTEST
    assert sim.recoveries == 0


def test_floating_spheres_pack_at_the_surface():
    # 64 half-density spheres dropped into water in a 1 m box: they float, side by side,
    # at the draft of a lone floating sphere (half its volume under), not overlapping.
    # Frictionless: with friction a sphere can stay perched on three floaters (each can
    # carry its own weight again), as a real raft of balls can.
    radius, density = 0.05, 500.0
    mass = density * 4.0 / 3.0 * math.pi * radius**3
    sim = Simulation(spheres_scene(
        lattice(64, 0.12, 0.6), radius=radius, mass=mass,
        effects=['gravity', 'buoyancy', 'drag', 'wave_radiation', 'contact', 'collisions'],
        pool__min=[-0.5, -0.5, -1.0], pool__max=[0.5, 0.5, 1.5]))
    sim.advance(20.0)
    z = sim.spheres.position[2]
    # A square packing holds 100 in the 1 m^2 surface: all 64 fit in one layer, each
    # centre on the surface (half under: density 500).
    assert np.abs(z).max() < 0.02 * radius
    _, depth = overlaps(sim.spheres.position, sim.spheres.radius)
    assert depth.size == 0 or depth.max() <= OVERLAP_TOLERANCE * radius
    # The waves they radiate have taken their bobbing (drag alone, quadratic, would leave
    # 3 cm/s at 20 s: it slows a motion only as 1/t). Sideways, frictionless, only that
    # drag slows them: they still drift, below 1 cm/s.
    assert np.abs(sim.spheres.velocity[2]).max() < 1e-6
    assert np.linalg.norm(sim.spheres.velocity, axis=0).max() < 0.02


def test_small_spheres_rest_on_a_big_one():
    # Radii 50x apart: a 1 m sphere on the floor with 60 spheres of 2 cm dropped on it.
    rng = np.random.default_rng(4)
    small = np.column_stack([rng.uniform(-0.3, 0.3, 60), rng.uniform(-0.3, 0.3, 60),
                             -2.0 + 1.2 + rng.uniform(0, 0.5, 60)])
    position = np.vstack([[0, 0, -2.0], small])
    radius = np.r_[1.0, np.full(60, 0.02)]
    sim = Simulation(spheres_scene(
        position, radius=radius, mass=np.r_[4000.0, np.full(60, 0.03)],
        effects=['gravity', 'contact', 'friction', 'collisions'],
        pool__min=[-3.0, -3.0, -3.0], pool__max=[3.0, 3.0, 3.0]))
    sim.advance(3.0)
    pairs, depth = overlaps(sim.spheres.position, sim.spheres.radius)
    smaller = np.minimum(radius[pairs[0]], radius[pairs[1]])
    assert depth.size == 0 or (depth / smaller).max() <= OVERLAP_TOLERANCE
    above = sim.spheres.position[2, 1:] > -2.0
    distance = np.linalg.norm(sim.spheres.position[:, 1:] - sim.spheres.position[:, :1], axis=0)
    assert np.all(distance[above] >= 1.02 - OVERLAP_TOLERANCE * 0.02)  # none inside it


# Hostile cases.

def test_spheres_started_at_one_point_come_apart_without_nan():
    sim = Simulation(spheres_scene([(0, 0, 0)] * 4, effects=['contact', 'collisions']))
    sim.advance(0.5)
    assert np.isfinite(sim.spheres.position).all() and np.isfinite(sim.spheres.velocity).all()
    _, depth = overlaps(sim.spheres.position, sim.spheres.radius)
    assert depth.size == 0 or depth.max() <= OVERLAP_TOLERANCE * 0.05


@pytest.mark.parametrize('speed', [1e-300, 5e-324, 1.0, 1e4])
def test_extreme_speeds_and_masses_stay_finite(speed):
    sim = Simulation(spheres_scene(
        [(-1.0, 0, 0), (1.0, 0, 0), (0, 0, 1.0)],
        [(speed, 0, 0), (-speed, 0, 0), (0, 0, -speed)], mass=[1e-6, 1e9, 1.0],
        radius=[1e-3, 1.0, 0.1], effects=['gravity', 'contact', 'friction', 'collisions']))
    sim.advance(1.0)
    assert np.isfinite(sim.spheres.position).all() and np.isfinite(sim.spheres.velocity).all()
    energy = sim.mechanical_energy()
    assert np.isfinite(energy).all()


def test_one_sphere_and_no_sphere_with_collisions_listed():
    for position in ([], [(0, 0, 0)]):
        sim = Simulation(spheres_scene(np.zeros((0, 3)) if not position else position,
                                       effects=['gravity', 'contact', 'collisions']))
        sim.advance(0.2)


def test_without_collisions_listed_spheres_pass_through_each_other():
    sim = Simulation(spheres_scene([(-0.2, 0, 0), (0.2, 0, 0)], [(1, 0, 0), (-1, 0, 0)],
                                   effects=[]))
    sim.advance(0.4)
    assert sim.spheres.position[0].tolist() == pytest.approx([0.2, -0.2])


# Through the node.

def test_the_node_collides_spheres_it_was_started_with_and_spheres_spawned_later(pool_sim):
    from rcl_interfaces.srv import SetParameters
    from rclpy.parameter import Parameter
    scene = {'sphere_names': ['a', 'b'], 'effects': ['gravity', 'contact', 'collisions'],
             'integrator': 'semi_implicit_euler', 'contact.restitution': 1.0,
             'a.radius': 0.1, 'a.mass': 1.0, 'a.position': [-1.0, 0.0, -3.9],
             'a.velocity': [2.0, 0.0, 0.0],
             'b.radius': 0.1, 'b.mass': 1.0, 'b.position': [1.0, 0.0, -3.9],
             'b.velocity': [-2.0, 0.0, 0.0], 'real_time_factor': 0.0}
    sim = pool_sim(scene)
    sim.advance(1.0)
    (a, va), (b, vb) = sim.state('a'), sim.state('b')
    assert va[0] == pytest.approx(-2.0, rel=1e-9) and vb[0] == pytest.approx(2.0, rel=1e-9)
    assert b[0] - a[0] >= 0.2 * (1 - OVERLAP_TOLERANCE)
    # Spawn c above b (a set_parameters request, as `ros2 param set` or a spawn service
    # sends): it lands on b and stays on it, not through it.
    request = SetParameters.Request(parameters=[
        Parameter('sphere_names', value=['a', 'b', 'c']).to_parameter_msg(),
        Parameter('c.radius', value=0.1).to_parameter_msg(),
        Parameter('c.mass', value=1.0).to_parameter_msg(),
        Parameter('c.position', value=[float(sim.state('b')[0][0]), 0.0, -3.5])
        .to_parameter_msg()])
    assert all(result.successful for result in
               sim.call(SetParameters, 'set_parameters', request).results)
    for _ in range(4):  # b keeps rolling along the floor; c rides on it or falls beside it
        sim.advance(0.5)
        states = sim.states()
        assert np.isfinite(states).all()
        _, depth = overlaps(states[:, :3].T, np.full(3, 0.1))
        assert depth.size == 0 or depth.max() <= OVERLAP_TOLERANCE * 0.1
    assert sim.states()[2, 2] >= -3.9 - 1e-9  # c is on the floor or on b, never below


def test_the_node_refuses_an_unknown_effect_beside_collisions(pool_sim):
    from pool_sim.physics import InvalidInput
    with pytest.raises((InvalidInput, Exception)):
        pool_sim({'effects': ['collisions', 'collision']})


def test_headless_runs_a_params_file_that_lists_collisions(tmp_path, capsys):
    from pool_sim import headless
    params = tmp_path / 'stack.yaml'
    params.write_text('\n'.join([
        '/**:', '  ros__parameters:', '    sphere_names: [low, high]',
        '    effects: [gravity, buoyancy, drag, wave_radiation, contact, friction, collisions]',
        '    low: {mass: 32.9, radius: 0.1, position: [0.0, 0.0, -3.9]}',
        '    high: {mass: 32.9, radius: 0.1, position: [0.0, 0.0, -2.0]}']) + '\n')
    headless.main([str(params), '--seconds', '4', '--every', '4'])
    last = capsys.readouterr().out.strip().splitlines()[-1].replace('|', ' ').split()
    low_z, high_z = float(last[1]), float(last[3])
    assert low_z == pytest.approx(-3.9, abs=1e-3)
    assert high_z == pytest.approx(-3.7, abs=OVERLAP_TOLERANCE * 0.1)  # on it, not through
