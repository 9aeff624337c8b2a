"""Bad input to the core: a clear error that names the key, and the state unchanged."""
import math

import numpy as np
import pytest

from pool_sim.physics import InvalidInput, Scene, Simulation
from pool_sim.ros.node_keys import NODE_SCENE


def snapshot(sim):
    s = sim.spheres
    return [a.copy() for a in (s.position, s.velocity, s.mass, s.radius, s.volume,
                               s.cross_section, s.external_force)]


def assert_unchanged(sim, before):
    for old, new in zip(before, snapshot(sim)):
        np.testing.assert_array_equal(old, new)


BAD_NUMBERS = [0.0, -1.0, math.nan, math.inf, -math.inf, 'heavy', None, True, [1.0]]


@pytest.mark.parametrize('value', BAD_NUMBERS)
@pytest.mark.parametrize('setter', ['set_mass', 'set_radius'])
def test_bad_mass_or_radius_is_refused_and_changes_nothing(setter, value):
    sim = Simulation(Scene.default())
    sim.advance(0.1)
    before = snapshot(sim)
    with pytest.raises(InvalidInput, match='steel'):
        getattr(sim, setter)('steel', value)
    assert_unchanged(sim, before)


@pytest.mark.parametrize('setter', ['set_mass', 'set_radius'])
def test_unknown_sphere_is_refused_naming_the_known_ones(setter):
    sim = Simulation(Scene.default())
    before = snapshot(sim)
    with pytest.raises(InvalidInput,
                       match="unknown sphere 'moon'; known spheres: cork, steel, ice$"):
        getattr(sim, setter)('moon', 1.0)
    assert_unchanged(sim, before)


def test_a_radius_that_does_not_fit_the_pool_is_refused():
    sim = Simulation(Scene.default())
    before = snapshot(sim)
    with pytest.raises(InvalidInput, match='does not fit'):
        sim.set_radius('cork', 4.0)
    assert_unchanged(sim, before)


@pytest.mark.parametrize('force', [[math.nan, 0, 0], [0, math.inf, 0], [1, 2], 'up',
                                   [1, 2, 3, 4]])
def test_bad_external_force_is_refused_and_changes_nothing(force):
    sim = Simulation(Scene.default())
    sim.set_external_force('ice', [1.0, 2.0, 3.0])
    before = snapshot(sim)
    with pytest.raises(InvalidInput, match='ice'):
        sim.set_external_force('ice', force)
    assert_unchanged(sim, before)


def test_good_changes_take_effect_and_keep_derived_values_in_step():
    sim = Simulation(Scene.default())
    sim.set_mass('cork', 2.5)
    sim.set_radius('cork', 0.3)
    i = sim.spheres.lookup('cork')
    assert sim.spheres.mass[i] == 2.5
    assert sim.spheres.volume[i] == pytest.approx(4 / 3 * math.pi * 0.027)
    assert sim.spheres.cross_section[i] == pytest.approx(math.pi * 0.09)


def test_growing_a_sphere_on_the_floor_pushes_it_out_of_the_floor():
    sim = Simulation(Scene.default())
    sim.advance(10.0)
    sim.set_radius('steel', 0.5)
    assert sim.sphere_state('steel')[0][2] == pytest.approx(-3.5)


BAD_SCENES = [
    ({'sphere_names': ['a'], 'a.mas': 1.0}, 'a.mas: unknown key'),
    ({'sphere_names': ['a'], 'b.mass': 1.0}, 'b.mass: unknown key'),
    ({'gravty': [0, 0, -9.81]}, 'gravty: unknown key'),
    ({'sphere_names': ['a'], 'a.mass': -1.0}, r'a.mass: must be within \[1e-06, 1e\+09\] kg'),
    ({'sphere_names': ['a'], 'a.mass': 'heavy'}, 'a.mass: expected a number'),
    ({'sphere_names': ['a'], 'a.radius': math.nan}, 'a.radius: must be finite'),
    ({'sphere_names': ['a'], 'a.position': [0, 0]}, 'a.position: expected 3 numbers'),
    ({'gravity': [0, math.inf, 0]}, 'gravity: every component must be finite'),
    ({'effects': ['gravity', 'magic']}, 'effects: must be a subset'),
    ({'effects': ['gravity', 'friction']}, 'effects: friction acts through floor contact'),
    ({'integrator': 'leapfrog'}, 'integrator: must be one of'),
    ({'physics_rate_hz': 0.0}, r'physics_rate_hz: must be within \[1, 100000\] Hz'),
    ({'contact.restitution': 1.5}, r'contact.restitution: must be within \[0, 1\]'),
    ({'contact.kinetic_friction': 0.9}, 'contact.kinetic_friction: must not exceed'),
    ({'publish_clock': 'yes'}, 'publish_clock: expected true or false'),
    ({'contact_solver': 'projected_gauss_seidel'},
     r"contact_solver: must be one of \['sequential_impulses', 'soft_step'\]"),
    ({'sphere_names': 'a'}, 'sphere_names: expected a list of strings'),
    ({'sphere_names': ['a', 'a']}, 'sphere_names: names must be unique'),
    ({'sphere_names': ['a.b']}, 'sphere_names: .* is not a valid ROS name token'),
    ({'pool.min': [0, 0, 0], 'pool.max': [1, 1, -1]}, 'pool.max: must exceed pool.min'),
    ({'sphere_names': ['a'], 'a.radius': 5.0}, 'a.radius: 5.0 m does not fit the pool'),
    ({'sphere_names': ['a'], 'a.lift_normal': [0, 0, 0]}, 'a.lift_normal: must be a non-zero'),
]


@pytest.mark.parametrize('params, message', BAD_SCENES)
def test_a_bad_scene_fails_naming_the_key_and_what_is_allowed(params, message):
    # As the node reads a scene: the physics' keys and its own.
    with pytest.raises(InvalidInput, match=message):
        Scene(params, extension=NODE_SCENE)


def test_the_core_knows_nothing_of_the_nodes_keys():
    with pytest.raises(InvalidInput, match='publish_clock: unknown key'):
        Scene({'publish_clock': False})
    assert 'publish_clock' not in Scene.default().global_values()
    assert Scene.default(NODE_SCENE)['publish_clock'] is False


def test_an_empty_effects_list_handed_over_untyped_means_no_effects():
    assert Scene({'effects': None})['effects'] == ()


def test_a_params_file_with_a_wrong_key_names_it(tmp_path):
    path = tmp_path / 'bad.yaml'
    path.write_text('pool_sim:\n  ros__parameters:\n    sphere_names: [a]\n'
                    '    a:\n      mass: 1.0\n      colour: red\n')
    with pytest.raises(InvalidInput, match='a.colour: unknown key'):
        Scene.from_yaml(path)


def test_bad_duration_is_refused():
    sim = Simulation(Scene.default())
    with pytest.raises(InvalidInput, match='duration'):
        sim.advance(math.nan)
    assert sim.time == 0.0


def test_a_sphere_given_only_a_name_gets_every_default():
    scene = Scene({'sphere_names': ['plain']})
    assert scene['plain.radius'] == 0.1 and scene['plain.mass'] == 1.0
    assert scene['plain.lift_area'] == pytest.approx(math.pi * 0.01)
