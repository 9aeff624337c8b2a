"""The soft-step contact solver (contact_solver: soft_step, contacts/soft_step.py): exact
momentum, no energy gained at any contact, the failure cases other engines reported (a ball
with restitution 1 that climbs, a restitution pass that overshoots, a resting pile that
creeps), contacts kept by sphere identity across a spawn and a remove, colours that share
no sphere, and bitwise reproducible runs.
"""
import math

from hypothesis import assume, example, given, settings, strategies as st
import numpy as np
import pytest

from benchmarks.common import dropped_scene
from pool_sim.physics import INTEGRATORS, Simulation
from pool_sim.physics.contacts.colouring import colour_by_priority, colour_contacts, COLOURS
from pool_sim.physics.contacts.detection import overlaps
from pool_sim.physics.contacts.memory import CONTACTS_PER_SPHERE
from test_collisions import lattice, log_uniform, spheres_scene

SOFT = {'contact_solver': 'soft_step'}
PILE_EFFECTS = ['gravity', 'contact', 'friction', 'collisions']
# The soft step's colourings (soft_step.colouring): as found, the CPU's; by priority, the
# GPU's (on the CPU here: the same sweep, docs/gpu.md).
COLOURINGS_SWEPT = ['found', 'priority']


def soft_scene(position, velocity=None, **keys):
    return spheres_scene(position, velocity, **SOFT, **keys)


def energy(sim):
    return sim.mechanical_energy().sum()


# A free pair.

@settings(deadline=None)
# Held apart by the last relax pass, this pair was slowed to 3 m/s before it touched, and
# then parted at 3: a contact still apart after the last move is the next step's now.
@example(mass_a=1.0, mass_b=1.0, restitution=1.0, speed=19.0, offset=0.0)
@given(log_uniform(1e-3, 1e3), log_uniform(1e-3, 1e3), st.floats(0.0, 1.0),
       st.floats(0.6, 20.0), st.floats(-0.95, 0.95))
def test_a_free_pair_keeps_its_momentum_exactly_and_gains_no_energy(
        mass_a, mass_b, restitution, speed, offset):
    radius = 0.05
    sim = Simulation(soft_scene(
        [(-0.2, 0, 0), (0.2, offset * 2 * radius, 0)], [(speed, 0, 0), (0, 0, 0)],
        radius=radius, mass=[mass_a, mass_b], contact__restitution=restitution,
        physics_rate_hz=1000.0))
    momentum = sim.spheres.mass @ sim.spheres.velocity.T
    start = energy(sim)
    sim.advance(1.0)
    assert sim.spheres.mass @ sim.spheres.velocity.T == pytest.approx(
        momentum, rel=1e-12, abs=1e-12 * mass_a * speed)
    assert energy(sim) <= start * (1 + 1e-12)
    if offset == 0.0:  # head on: they part at about restitution times the approach
        parting = sim.spheres.velocity[0, 1] - sim.spheres.velocity[0, 0]
        assert parting == pytest.approx(restitution * speed, rel=0.05, abs=0.02 * speed)


@settings(deadline=None)
# Found by the deep profile once restitution 1 was let in: thrown down at 9 m/s and
# sideways at 2, the sphere glanced off the one below and never reached the floor, yet
# the floor's speculative contact, which had only slowed its approach, bounced it up at
# 9 m/s: 0.129 J gained. A push counts toward a bounce only while touching now.
@example(integrator='explicit_euler', radius=0.01, ratio=1.0, mass_low=1.0, mass_high=1.0,
         restitution=1.0, speed=9.0, offset=-0.78125, sideways=-2.0, in_water=False)
@given(st.sampled_from(list(INTEGRATORS)), log_uniform(0.01, 0.3), log_uniform(0.1, 10.0),
       log_uniform(0.01, 100.0), log_uniform(0.01, 100.0), st.floats(0.0, 1.0),
       st.floats(0.0, 10.0), st.floats(-0.8, 0.8), st.floats(-3.0, 3.0), st.booleans())
def test_no_soft_contact_adds_energy(integrator, radius, ratio, mass_low, mass_high,
                                     restitution, speed, offset, sideways, in_water):
    # One sphere thrown at another resting on the floor: both faces and the pair go through
    # the solver. After each step the energy is at most the start's, or what the
    # integrator alone makes of it (explicit Euler gains energy in any step).
    top_radius = radius * ratio
    low_z = -4.0 + radius
    effects = ['gravity', 'buoyancy', 'contact', 'collisions']
    mass = np.clip([mass_low * 4190 * radius**3, mass_high * 4190 * top_radius**3], 1e-6, 1e9)
    # A known limit: the thrown sphere no heavier than the one it hits
    # (test_a_heavy_sphere_on_a_light_one_gains_a_bounded_energy).
    assume(mass[1] <= mass[0])

    def simulation(with_collisions):
        return Simulation(soft_scene(
            [(0, 0, low_z), (offset * min(radius, top_radius), 0,
                             low_z + radius + top_radius + 1e-9)],
            [(0, 0, 0), (sideways, 0, -speed)], radius=[radius, top_radius], mass=mass,
            effects=effects if with_collisions else effects[:-1],
            integrator=integrator, contact__restitution=restitution,
            water__surface_z=4.0 if in_water else -4.0))
    sim, alone = simulation(True), simulation(False)
    for _ in range(3):
        start = energy(sim)
        alone.spheres.position[:], alone.spheres.velocity[:] = (sim.spheres.position,
                                                                sim.spheres.velocity)
        sim.step()
        alone.step()
        allowed = max(start, energy(alone))
        # Not the exact bound sequential_impulses keeps: a soft contact holds energy in
        # its overlap, which the spheres' energy does not count, and gives it back (the
        # deep profile found 6e-9 of the energy: a sphere of 1.5 cm resting on one of 1 cm
        # in water); and the impulse that stopped an impact, warm-started into the next
        # step, pushes the spheres apart again (6e-5: equal spheres, 18 cm, meeting at
        # 3 m/s, glancing). A known limit, bounded here at 1e-4 of the energy.
        assert energy(sim) <= allowed + 1e-4 * abs(allowed) + 1e-12
        assert np.isfinite(sim.spheres.position).all()


@pytest.mark.parametrize('integrator', ['semi_implicit_euler', 'linearly_implicit_euler'])
def test_a_heavy_sphere_on_a_light_one_gains_a_bounded_energy(integrator):
    # Found by test_no_soft_contact_adds_energy: a sphere ten times heavier thrown at 1 m/s,
    # restitution 0, onto one resting on the floor. Without the support sweep the impact
    # took 21.9 J and the next step gave 4.3 J back, the heavy sphere leaving at 0.41 m/s:
    # one relax sweep a substep did not stop a heavy sphere on a light one pushed out of
    # the floor (Gauss-Seidel passes momentum slowly against a mass ratio). Measured with
    # it: 20.4 J taken, at most 0.054 J back in a step, the heavy sphere at rest.
    radius = 0.1
    low_z = -4.0 + radius
    sim = Simulation(soft_scene(
        [(0, 0, low_z), (0, 0, low_z + 2 * radius + 1e-9)], [(0, 0, 0), (0, 0, -1.0)],
        radius=radius, mass=[4190 * radius**3, 10 * 4190 * radius**3],
        effects=['gravity', 'contact', 'collisions'], integrator=integrator))
    start = energy(sim)
    gains = []
    for _ in range(40):
        before = energy(sim)
        sim.step()
        gains.append(energy(sim) - before)
    impact = -gains[0]
    assert impact > 20.0
    assert max(gains) < 0.01 * impact  # measured 0.0027 of it (0.20 without the sweep)
    assert energy(sim) < start - 0.75 * impact  # over the bounce, energy goes


def test_spheres_dropped_through_the_surface_in_a_crowd_do_not_sink_into_each_other():
    # 5 000 spheres of radii 2x and densities 10x apart dropped as a lattice through the
    # surface: those behind press on those the water slows, step after step. A version that
    # warm-started no contact that approached fast let them sink 0.36 of the smaller radius
    # into each other within 1 s (1.69 at 10 000 spheres); measured 0.09 now.
    sim = Simulation(dropped_scene(5000, solver='soft_step'))
    deepest = 0.0
    for _ in range(20):
        sim.run(10, sim.max_step)
        radius = sim.spheres.radius
        pairs, depth = overlaps(sim.spheres.position, radius)
        if depth.size:
            deepest = max(deepest, (depth / np.minimum(radius[pairs[0]],
                                                       radius[pairs[1]])).max())
    assert deepest < 0.2


@pytest.mark.parametrize('colouring', COLOURINGS_SWEPT)
@pytest.mark.parametrize('densities, speed', [([340, 430] + [2500] * 8, 1.7),
                                              ([340] + [3000] * 9, 2.5)])
def test_a_column_landing_on_floaters_does_not_crush_them_into_each_other(densities, speed,
                                                                          colouring):
    # A column of ten 3 cm spheres falling in water onto the floor, the lowest ones lighter
    # than water (kg/m^3), under heavy ones: as the 10 000-sphere landing's deepest pair.
    # Without the support sweep the column drove them 0.22 (0.29) of a radius into each
    # other; measured 0.058 (0.069) with it.
    radius = 0.03
    jitter = np.random.default_rng(0).uniform(-0.004, 0.004, (len(densities), 2))
    sim = Simulation(spheres_scene(
        [(x, y, -4.0 + radius + 0.005 + k * (2 * radius + 0.001))
         for k, (x, y) in enumerate(jitter)], [(0.0, 0.0, -speed)] * len(densities),
        radius=radius, mass=[d * 4 / 3 * math.pi * radius**3 for d in densities],
        effects=['gravity', 'buoyancy', 'drag', 'contact', 'friction', 'collisions'],
        contact_solver='soft_step', contact__restitution=0.5, water__surface_z=4.0,
        soft_step__colouring=colouring))
    deepest = 0.0
    for _ in range(120):
        sim.step()
        apart = np.linalg.norm(np.diff(sim.spheres.position, axis=1), axis=0)
        deepest = max(deepest, float((2.0 * radius - apart).max() / radius))
    assert deepest < 0.1


@pytest.mark.xfail(strict=True, reason="soft_step's known limit: a sphere dropped on one "
                   'resting on the floor rebounds far below restitution^2 x its drop')
@pytest.mark.parametrize('restitution, upper_kg', [(1.0, 1.0), (0.5, 10.0)])
def test_a_sphere_dropped_on_one_resting_on_the_floor_rebounds(restitution, upper_kg):
    # 0.2 m onto a 1 kg sphere on the floor: off the floor itself it would rebound
    # restitution^2 x 0.2 m. Measured: 0.017 m (restitution 1, equal masses; 0.021 before
    # the support sweep) and 0.009 m (0.5, ten times heavier; 0.044 before: the sweep stops
    # the heavy one against the one the floor holds up, and the restitution pass then
    # shares the bounce by the pair's masses). Strict: mended, it fails until the mark goes.
    radius = 0.05
    low_z = -4.0 + radius
    sim = Simulation(soft_scene([(0, 0, low_z), (0, 0, low_z + 2 * radius + 0.2)],
                                radius=radius, mass=[1.0, upper_kg],
                                effects=['gravity', 'contact', 'collisions'],
                                contact__restitution=restitution))
    heights = []
    for _ in range(200):
        sim.step()
        heights.append(sim.spheres.position[2, 1] - (low_z + 2 * radius))
    landed = next(i for i, height in enumerate(heights) if height < 0.01)
    assert max(heights[landed:]) > 0.8 * restitution**2 * 0.2


@pytest.mark.parametrize('colouring', COLOURINGS_SWEPT)
def test_a_dropped_pile_of_spheres_denser_than_water_comes_to_rest(colouring):
    # The contact issue's resting pile, at 2 000 spheres (results/collisions/resting_pile.md
    # has 10 000): every sphere sinks, lands on the floor or on others, and rests. Its goal:
    # rms under 5 mm/s and none over 5 cm/s. Measured: rms 3e-14 m/s from 6 s on (0.02-0.06
    # with sequential_impulses, whose pile keeps jittering).
    sim = Simulation(dropped_scene(2000, solver='soft_step', least_density=1500.0)
                     .with_values(soft_step={'colouring': colouring}))
    sim.advance(6.0)
    for _ in range(4):
        sim.advance(0.5)
        speed = np.linalg.norm(sim.spheres.velocity, axis=0)
        assert np.sqrt(np.mean(speed**2)) < 0.005 and speed.max() < 0.05
        assert sim.spheres.position[2].max() < -2.5  # landed, not afloat


def elastic_glancing_bounce(light_kg, effects):
    """A sphere of light_kg thrown at 6 m/s, glancing, restitution 1, off one of 0.0419 kg
    resting on the floor (radii 1 cm, in air): the simulation after one step, and the
    energy it started with."""
    radius = 0.01
    low_z = -4.0 + radius
    sim = Simulation(soft_scene(
        [(0, 0, low_z), (0.25 * radius, 0, low_z + 2 * radius + 1e-9)],
        [(0, 0, 0), (-1.0, 0, -6.0)], radius=radius, mass=[0.0419, light_kg],
        effects=effects, integrator='velocity_verlet', contact__restitution=1.0,
        water__surface_z=-4.0))
    start = energy(sim)
    sim.step()
    return sim, start


def test_an_elastic_glancing_bounce_gains_no_energy():
    # Found by test_no_soft_contact_adds_energy (a sphere of density 10 kg/m^3): it left
    # with 0.1 % more energy than it came with (8.2e-7 J of its 7.8e-4 J kinetic), at
    # 6.075 m/s from 6.0. The gain was the fault of the next test: the smooth step took it
    # past the floor into the water below (the surface is at the floor here), whose
    # buoyancy soft_step kept. With contacts/face_crossing.py it loses 8.0e-8 J.
    sim, start = elastic_glancing_bounce(4.19e-5, ['gravity', 'buoyancy', 'contact',
                                                   'collisions'])
    assert energy(sim) - start <= 0.0


def test_a_sphere_lighter_than_air_is_not_flung_off_the_floor():
    # The same bounce with a sphere of 1e-6 kg (density 0.24 kg/m^3, lighter than air). The
    # water's surface is at the floor here: the smooth step, which knows no floor, took the
    # sphere 3 cm past it into the water, whose buoyancy turned it to 41.7 m/s up within the
    # step, and soft_step kept that change (sequential_impulses' face rule gave 0.03 m/s).
    # contacts/face_crossing.py now keeps, along the face's normal, the speed it reached
    # the floor at: it leaves at 6.15 m/s, restitution 1's bounce of its 6 m/s.
    sim, start = elastic_glancing_bounce(1e-6, ['gravity', 'buoyancy', 'contact',
                                                'collisions'])
    assert abs(sim.spheres.velocity[2, 1]) < 7.0
    assert energy(sim) - start <= 0.0  # measured -1.1e-6 J


# What other engines got wrong.

def highest_z_of_the_top_sphere(sim, seconds):
    highest = -math.inf
    for _ in range(int(seconds * 200)):
        sim.step()
        highest = max(highest, sim.spheres.position[2, 1])
    return highest


def test_a_sphere_resting_on_another_with_restitution_one_does_not_climb():
    # Jolt #1328, rapier #97: bouncing back the speed gravity adds in one step lifts a
    # resting body a little every step.
    radius = 0.05
    sim = Simulation(soft_scene([(0, 0, -4.0 + radius), (0, 0, -4.0 + 3 * radius)],
                                radius=radius, effects=PILE_EFFECTS,
                                contact__restitution=1.0, physics_rate_hz=200.0))
    start_z = sim.spheres.position[2, 1]
    assert highest_z_of_the_top_sphere(sim, 5.0) <= start_z + 1e-4 * radius


@pytest.mark.parametrize('drop_m', [0.01, 0.2, 1.0])
def test_a_bounce_with_restitution_one_never_rises_above_the_drop(drop_m):
    # box3d #83: a restitution pass that overshoots throws a sphere higher than it fell.
    radius = 0.05
    top_z = -4.0 + 3 * radius + drop_m
    sim = Simulation(soft_scene([(0, 0, -4.0 + radius), (0, 0, top_z)], radius=radius,
                                effects=PILE_EFFECTS, contact__restitution=1.0,
                                physics_rate_hz=200.0))
    assert highest_z_of_the_top_sphere(sim, 3.0) <= top_z + 1e-6


@pytest.mark.parametrize('colouring', COLOURINGS_SWEPT)
def test_a_resting_pile_does_not_creep(colouring):
    # avian #385, godot #70816: jitter that walks a stack. 125 spheres settle for 3 s;
    # over the next 2 s none moves more than a hundredth of its radius.
    radius = 0.05
    sim = Simulation(soft_scene(lattice(125, 0.105, -3.7), radius=radius,
                                effects=PILE_EFFECTS, soft_step__colouring=colouring,
                                pool__min=[-0.3, -0.3, -4.0], pool__max=[0.3, 0.3, 4.0]))
    sim.advance(3.0)
    settled = sim.spheres.position.copy()
    energy_settled = energy(sim)
    sim.advance(2.0)
    moved = np.linalg.norm(sim.spheres.position - settled, axis=0)
    assert moved.max() < 0.01 * radius
    assert energy(sim) <= energy_settled + 1e-9 * abs(energy_settled)
    _, depth = overlaps(sim.spheres.position, sim.spheres.radius)
    assert depth.max() < 0.02 * radius
    assert sim.recoveries == 0


# Contacts kept by identity.

def remembered(sim):
    """{key: normal force N} of every contact the solver remembers."""
    keys, forces, held = sim._memory
    return {int(keys[row, k]): float(forces[row, k, 0])
            for row in range(held.size) for k in range(held[row])}


def test_a_remove_and_a_spawn_keep_the_other_spheres_contacts():
    radius = 0.05
    scene = soft_scene(lattice(27, 0.105, -3.8), radius=radius, effects=PILE_EFFECTS,
                       pool__min=[-0.2, -0.2, -4.0], pool__max=[0.2, 0.2, 4.0])
    sim = Simulation(scene)
    sim.advance(2.0)
    identity = dict(zip(sim.spheres.names, sim._identity.tolist()))
    before = remembered(sim)
    assert len(before) > 27  # pairs and floor contacts, all under load
    gone = 's13'  # in the middle of the pile
    names = [name for name in scene.sphere_names if name != gone]
    sim.change_spheres(scene.with_values(sphere_names=names + ['late']))
    kept = dict(zip(sim.spheres.names, sim._identity.tolist()))
    assert all(kept[name] == identity[name] for name in names)
    assert kept['late'] not in identity.values()
    # The change itself keeps every contact but those the removed sphere's row held.
    mine = identity[gone]
    assert remembered(sim) == {key: force for key, force in before.items() if key >> 32 != mine}
    sim.step()
    after = remembered(sim)
    others = {key for key in before if mine not in (key >> 32, key & 0xFFFFFFFF)}
    # The other contacts still there carry on from their own forces, not another's: all
    # but those the removed sphere's weight bore on stay within half of theirs.
    carried = others & after.keys()
    assert len(carried) > 0.8 * len(others)
    close = [key for key in carried if after[key] == pytest.approx(before[key], rel=0.5)]
    assert len(close) > 0.8 * len(carried)
    # A name used again is another sphere: it gets an identity never seen before.
    sim.change_spheres(scene.with_values(sphere_names=names + [gone]))
    assert dict(zip(sim.spheres.names, sim._identity.tolist()))[gone] not in (
        set(identity.values()) | {kept['late']})


def test_a_reordering_carries_each_spheres_contacts_to_its_new_place():
    # The memory is kept a row per sphere: change_spheres must move each row with its
    # sphere. A settled pile, its spheres named in reverse order, goes on at rest; with
    # its memory wiped instead, the first step starts every contact from nothing and the
    # pile sags (a millimetre a second).
    scene = soft_scene(lattice(27, 0.105, -3.8), radius=0.05, effects=PILE_EFFECTS,
                       pool__min=[-0.2, -0.2, -4.0], pool__max=[0.2, 0.2, 4.0])
    fastest = {}
    for wiped in (False, True):
        sim = Simulation(scene)
        sim.advance(2.0)
        assert np.abs(sim.spheres.velocity).max() < 1e-9
        before = remembered(sim)
        sim.change_spheres(scene.with_values(sphere_names=scene.sphere_names[::-1]))
        keys, _, held = sim._memory
        assert remembered(sim) == before
        for row, identity in enumerate(sim._identity):  # a row holds its own sphere's
            assert all(keys[row, k] >> 32 == identity for k in range(held[row]))
        if wiped:
            sim._memory = None
        sim.step()
        fastest[wiped] = np.linalg.norm(sim.spheres.velocity, axis=0).max()
    assert fastest[False] < 1e-9
    assert fastest[True] > 1e-4


def test_a_sphere_with_more_contacts_than_its_row_holds_keeps_the_first():
    # Sphere 0 (the smallest identity) owns all twelve of its close-packed neighbours'
    # contacts; its row holds CONTACTS_PER_SPHERE of them, in the order they came, and
    # the rest start the next step from no force. Nothing else changes.
    radius = 0.05
    shells = [(x, y, 0.0) for x in (-1, 1) for y in (-1, 1)] + [
        (x, 0.0, z) for x in (-1, 1) for z in (-1, 1)] + [
        (0.0, y, z) for y in (-1, 1) for z in (-1, 1)]
    reach = 2.0 * radius * (1.0 - 1e-3) / math.sqrt(2.0)  # overlapping by a thousandth
    position = [(0.0, 0.0, 0.0)] + [(reach * x, reach * y, reach * z) for x, y, z in shells]
    sim = Simulation(soft_scene(position, radius=radius))
    sim.step()
    keys, _, held = sim._memory
    assert held[0] == CONTACTS_PER_SPHERE
    owned = [key for key in remembered(sim) if key >> 32 == sim._identity[0]]
    assert len(owned) == CONTACTS_PER_SPHERE
    momentum = sim.spheres.velocity @ sim.spheres.mass
    sim.run(10, sim.max_step)
    assert np.all(np.isfinite(sim.spheres.velocity))
    np.testing.assert_allclose(sim.spheres.velocity @ sim.spheres.mass, momentum, atol=1e-12)


def test_a_reset_forgets_every_contact():
    sim = Simulation(soft_scene(lattice(8, 0.105, -3.85), effects=PILE_EFFECTS))
    sim.advance(0.5)
    assert remembered(sim)
    sim.reset()
    sim.run(0, sim.max_step)
    assert remembered(sim) == {}


# Colours.

@pytest.mark.parametrize('colour', ['found', 'priority'])
@settings(deadline=None)
@given(st.integers(1, 400), st.integers(2, 60), st.integers(0, 2**32 - 1))
def test_no_two_contacts_of_one_colour_share_a_sphere(colour, contacts, spheres, seed):
    rng = np.random.default_rng(seed)
    ground = spheres  # the row of the faces: shared freely
    ends = np.empty((contacts, 2), dtype=np.int64)
    ends[:, 0] = rng.integers(0, spheres, contacts)
    ends[:, 1] = np.where(rng.uniform(size=contacts) < 0.3, ground,
                          (ends[:, 0] + rng.integers(1, spheres, contacts)) % spheres)
    slot, colour_start = (colour_contacts(ends, ground, np.zeros(contacts, np.int64), 0)
                          if colour == 'found' else colour_by_priority(ends, ground))
    assert sorted(slot[:contacts].tolist()) == list(range(contacts))  # each once
    assert colour_start[0] == 0 and colour_start[-1] == contacts
    in_slot = np.empty(contacts, dtype=np.int64)
    in_slot[slot[:contacts]] = np.arange(contacts)
    for colour in range(COLOURS - 1):  # the last takes what is left
        members = ends[in_slot[colour_start[colour]:colour_start[colour + 1]]].ravel()
        members = members[members != ground]
        assert np.unique(members).size == members.size


# Reproducible.

def test_a_soft_step_pile_is_bitwise_the_same_run_to_run():
    def run():
        sim = Simulation(soft_scene(lattice(64, 0.11, -3.6), radius=0.05,
                                    effects=PILE_EFFECTS, contact__restitution=0.3,
                                    pool__min=[-0.3, -0.3, -4.0], pool__max=[0.3, 0.3, 4.0]))
        sim.advance(1.5)
        return sim.spheres.position.tobytes() + sim.spheres.velocity.tobytes()
    assert run() == run()


def test_lockstep_runs_with_colliding_spheres_are_bitwise_the_same(pool_sim):
    position = lattice(27, 0.105, -3.8)
    params = {'effects': PILE_EFFECTS, **SOFT, 'wrench_timeout': 0.0,
              'sphere_names': [f'b{i}' for i in range(27)],
              'spheres.position': position.ravel().tolist(),
              'spheres.radius': [0.05] * 27, 'spheres.mass': [1.0] * 27}
    runs = []
    for _ in range(2):
        sim = pool_sim(dict(params))
        sim.advance(1.0)
        runs.append(sim.states().tobytes())
    assert runs[0] == runs[1]


def test_hostile_starts_stay_finite():
    # All at one point, at rest, and at the largest speeds a scene allows.
    for speed in (0.0, 1e-300, 1e4):
        sim = Simulation(soft_scene([(0, 0, 0)] * 6, [(speed, -speed, speed)] * 6,
                                    effects=PILE_EFFECTS, mass=[1e-6, 1e9, 1, 1, 1, 1]))
        sim.advance(0.5)
        assert np.isfinite(sim.spheres.position).all()
        assert np.isfinite(sim.spheres.velocity).all()
