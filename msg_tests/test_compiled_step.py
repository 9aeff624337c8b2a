"""Every integrator, effect set and submerged-volume model runs as one compiled step: it
follows an independent reference (DOP853 on the model written again in
benchmarks/reference.py) at the order of its method, its plain and parallel builds agree bit
for bit, and many steps in one call are those steps one by one."""
import pathlib

import numpy as np
import pytest

from benchmarks.reference import smooth_motion
from pool_sim.physics import InvalidInput, INTEGRATORS, Scene, Simulation
from pool_sim.physics import stepper
from pool_sim.physics.contacts import SOLVERS

SMOOTH = ['gravity', 'buoyancy', 'drag', 'lift', 'added_mass']
WITH_WAVES = SMOOTH + ['wave_radiation']
RADIUS, DENSITY = 0.2, 600.0
SPHERE = {'mass': DENSITY * 4.0 / 3.0 * np.pi * RADIUS**3, 'radius': RADIUS,
          'drag_coefficient': 0.8, 'lift_coefficient': 0.6, 'lift_area': 0.1,
          'lift_normal': [0.6, 0.0, 0.8], 'external_force': [3.0, -2.0, 1.0]}
WORLD = {'gravity': [0.0, 0.0, -9.81], 'air_density': 1.2, 'wind': [2.0, 1.0, 0.0],
         'water_density': 1000.0, 'current': [-0.5, 0.3, 0.0], 'surface_z': 0.0}
# Thrown down and sideways from just above the water: it crosses the surface in both media's
# wind and current, with lift and a push of its own.
START, START_VELOCITY = [0.0, 0.0, 0.35], [1.0, -0.5, -2.0]


def crossing_scene(integrator, effects, rate_hz):
    return Scene({
        'sphere_names': ['b'], 'b.mass': SPHERE['mass'], 'b.radius': RADIUS,
        'b.drag_coefficient': SPHERE['drag_coefficient'],
        'b.lift_coefficient': SPHERE['lift_coefficient'], 'b.lift_area': SPHERE['lift_area'],
        'b.lift_normal': SPHERE['lift_normal'], 'b.position': START,
        'b.velocity': START_VELOCITY, 'gravity': WORLD['gravity'],
        'air.density': WORLD['air_density'], 'air.wind': WORLD['wind'],
        'water.density': WORLD['water_density'], 'water.current': WORLD['current'],
        'effects': list(effects), 'integrator': integrator, 'physics_rate_hz': float(rate_hz)})


def largest_error(integrator, effects, submerged_volume, rate_hz):
    """Largest distance (m) from the reference over 1 s, sampled every 0.1 s."""
    times = np.arange(1, 11) * 0.1
    reference = smooth_motion(times, np.array(START), np.array(START_VELOCITY), SPHERE, WORLD,
                              effects, submerged_volume)
    sim = Simulation(crossing_scene(integrator, effects, rate_hz), submerged_volume)
    sim.set_external_force('b', SPHERE['external_force'])
    errors = []
    for sample in range(len(times)):
        sim.advance(0.1)
        errors.append(np.linalg.norm(sim.spheres.position[:, 0] - reference[:, sample]))
    return max(errors)


# (error bound at 800 Hz in m, the least error ratio from 200 to 800 Hz). RK4 and the
# linear model's kinks: where a sphere's edge crosses the surface the force's derivative
# jumps, which costs any method above second order its full order.
EXPECTED = {'explicit_euler': (5e-3, 3.5), 'semi_implicit_euler': (5e-3, 3.5),
            'linearly_implicit_euler': (3e-3, 3.5), 'velocity_verlet': (1e-5, 12.0),
            'rk4': (2e-6, 5.0)}


@pytest.mark.parametrize('submerged_volume', ['cap', 'linear'])
@pytest.mark.parametrize('integrator', list(INTEGRATORS))
def test_every_integrator_with_every_smooth_effect_follows_the_reference(integrator,
                                                                          submerged_volume):
    errors = [largest_error(integrator, SMOOTH, submerged_volume, rate) for rate in (200, 800)]
    bound, least_ratio = EXPECTED[integrator]
    assert errors[1] < bound, errors
    assert errors[0] / errors[1] > least_ratio, errors  # it converges at its order


@pytest.mark.parametrize('submerged_volume', ['cap', 'linear'])
@pytest.mark.parametrize('integrator', list(INTEGRATORS))
def test_every_integrator_with_wave_radiation_too_follows_the_reference(integrator,
                                                                        submerged_volume):
    """At first order at least: where a sphere first touches the water the force of the
    water it takes on switches on at once (the added mass grows from nothing with a finite
    slope: a water-entry impact), which no method steps across above first order."""
    errors = [largest_error(integrator, WITH_WAVES, submerged_volume, rate)
              for rate in (200, 800)]
    assert errors[1] < 2e-3, errors
    assert errors[0] / errors[1] > 3.0, errors


@pytest.mark.parametrize('effects', [[], ['gravity'], ['gravity', 'buoyancy'], ['drag'],
                                     ['gravity', 'drag', 'lift'],
                                     ['gravity', 'buoyancy', 'added_mass']],
                         ids=lambda e: '+'.join(e) or 'nothing')
def test_each_effect_on_its_own_follows_the_reference(effects):
    # Lift with drag: without it the sphere speeds up until its velocity swings through the
    # lifting normal, where lift's direction turns over and DOP853's steps collapse.
    assert largest_error('rk4', effects, 'cap', 800) < 2e-6


def many_spheres(integrator, count, seed=3):
    """count spheres of every size and density, thrown about a pool with every effect."""
    rng = np.random.default_rng(seed)
    names = [f's{i}' for i in range(count)]
    params = {'sphere_names': names, 'effects': WITH_WAVES + ['contact', 'friction'],
              'integrator': integrator,
              'gravity': list(rng.normal(size=3) * 2.0 + [0.0, 0.0, -9.0]),
              'air.wind': list(rng.normal(size=3)), 'water.current': list(rng.normal(size=3)),
              'contact.restitution': 0.6, 'physics_rate_hz': 400.0}
    for name in names:
        radius = float(rng.uniform(0.01, 0.5))
        params[f'{name}.radius'] = radius
        params[f'{name}.mass'] = float(rng.uniform(100, 9000) * 4 / 3 * np.pi * radius**3)
        params[f'{name}.position'] = list(rng.uniform(-3.4, 3.4, 3))
        params[f'{name}.velocity'] = list(rng.normal(size=3) * 5.0)
        params[f'{name}.lift_coefficient'] = float(rng.uniform(0.0, 0.5))
        params[f'{name}.lift_normal'] = list(rng.normal(size=3))
    return Scene(params)


def near_the_surface(scene, share, seed=4):
    """The scene with `share` of its spheres, picked at random, centred within a radius of
    the water's surface (their vertical speeds kept)."""
    rng = np.random.default_rng(seed)
    radius, position = scene.sphere_array('radius'), scene.sphere_array('position')
    values = {}
    for i, name in enumerate(scene.sphere_names):
        if rng.uniform() < share:
            z = scene['water.surface_z'] + rng.uniform(-0.99, 0.99) * radius[i]
            values[f'{name}.position'] = [float(position[i, 0]), float(position[i, 1]), z]
    return scene.with_values(**values)


# The parallel build leaves wave radiation to a pass of its own over the spheres crossing
# the surface, where they are few (the default integrator's): the two ways agree with the
# plain build's to the bit, where few cross, where many do, and as spheres pass between.
@pytest.mark.parametrize('integrator, crossing', [
    *((name, 0.0) for name in INTEGRATORS), ('linearly_implicit_euler', 0.03),
    ('linearly_implicit_euler', 0.5), ('linearly_implicit_euler', 1.0)])
def test_the_plain_and_the_parallel_build_agree_bit_for_bit(integrator, crossing,
                                                            monkeypatch):
    count = 96
    runs = []
    for parallel_from in (count, count + 1):  # the parallel build, then the plain one
        monkeypatch.setattr(stepper, 'parallel_from_spheres', lambda: parallel_from)
        sim = Simulation(near_the_surface(many_spheres(integrator, count), crossing))
        sim.spheres.external_force[:] = np.random.default_rng(1).normal(size=(3, count)) * 20
        sim.advance(2.0)
        runs.append((sim.spheres.position.copy(), sim.spheres.velocity.copy()))
    assert np.all(np.isfinite(runs[0][0]))
    assert np.array_equal(runs[0][0], runs[1][0]) and np.array_equal(runs[0][1], runs[1][1])


def test_many_steps_in_one_call_are_the_same_steps_one_by_one():
    scene = many_spheres('linearly_implicit_euler', 20)
    together, one_by_one = Simulation(scene), Simulation(scene)
    together.run(300, 1e-3)
    for _ in range(300):
        one_by_one.step(1e-3)
    assert np.array_equal(together.spheres.position, one_by_one.spheres.position)
    assert np.array_equal(together.spheres.velocity, one_by_one.spheres.velocity)
    assert together.time == pytest.approx(0.3, rel=1e-12)


def test_a_build_is_compiled_once_per_configuration_and_shared():
    first = Simulation(crossing_scene('rk4', SMOOTH, 100.0)).stepper
    second = Simulation(crossing_scene('rk4', SMOOTH, 300.0)).stepper
    assert first.build(False) is second.build(False)
    other = Simulation(crossing_scene('rk4', ['gravity'], 100.0)).stepper
    assert other.build(False) is not first.build(False)


@pytest.mark.parametrize('layer, spheres', [('omp', 64), ('tbb', 64), ('workqueue', 4096)])
def test_the_parallel_build_starts_where_its_launch_pays_for_this_threading_layer(
        layer, spheres, monkeypatch):
    monkeypatch.setattr(stepper, '_threading_layer', layer)
    assert stepper.parallel_from_spheres() == spheres


@pytest.mark.parametrize('steps, dt', [(-1, 1e-3), (2.5, 1e-3), (True, 1e-3), ('3', 1e-3),
                                       (3, 0.0), (3, -1e-3), (3, float('nan')),
                                       (3, float('inf'))])
def test_run_refuses_a_count_or_step_that_is_not_one_and_changes_nothing(steps, dt):
    sim = Simulation(crossing_scene('rk4', SMOOTH, 100.0))
    before = sim.spheres.position.copy()
    with pytest.raises(InvalidInput):
        sim.run(steps, dt)
    assert sim.time == 0.0 and np.array_equal(sim.spheres.position, before)


def test_each_configuration_has_a_cache_name_of_its_own_that_carries_the_sources_digest():
    names = {stepper.Stepper(integrator, effects, volume).build(parallel).__name__
             for integrator in INTEGRATORS for volume in ('cap', 'linear')
             for effects in ([], ['gravity', 'contact'], SMOOTH) for parallel in (False, True)}
    assert len(names) == 5 * 2 * 3 * 2
    assert all(name.endswith(stepper.SOURCE_DIGEST) for name in names)


def test_the_sources_digest_covers_every_file_the_compiled_loop_is_made_of():
    physics = pathlib.Path(stepper.__file__).parent
    expected = {physics / 'stepper.py', *physics.glob('kernels/*.py'),
                *physics.glob('contacts/*.py')}
    assert set(stepper._SOURCES) == expected
    assert physics / 'kernels' / 'layout.py' in expected  # a kernel file found, not listed


def test_the_contact_solver_is_chosen_by_its_name_in_contacts_solvers():
    effects = ['gravity', 'contact', 'collisions']
    for name in SOLVERS:
        assert name in stepper.Stepper('rk4', effects, contact_solver=name).build(False).__name__
    with pytest.raises(ValueError, match='contact_solver'):
        stepper.Stepper('rk4', effects, contact_solver='no_such_solver')
