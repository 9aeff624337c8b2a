"""Every number a client or a file can set has a range; outside it the core refuses, naming
the key and the range. Within the ranges the default integrator never makes a NaN."""
import math

from hypothesis import given, HealthCheck, settings, strategies as st
import numpy as np
import pytest

from pool_sim.physics import InvalidInput, Scene, Simulation
from pool_sim.physics.params_file import read_params_document
from pool_sim.physics.schema import SPHERE_KEYS
from pool_sim.ros.node_keys import NODE_SCENE
from pool_sim.ros.parameters import SCENE_KEYS
from pool_sim.physics.spheres import FORCE_LIMIT_N, MASS_RANGE_KG, RADIUS_RANGE_M

RANGED_NUMBERS = {name: key for name, key in SCENE_KEYS.items() if key.kind == 'number'}
RANGED_NUMBERS.update({f'ball.{name}': key for name, key in SPHERE_KEYS.items()
                       if key.kind == 'number'})
RANGED_VECTORS = {name: key for name, key in SCENE_KEYS.items() if key.kind == 'vector'}
RANGED_VECTORS.update({f'ball.{name}': key for name, key in SPHERE_KEYS.items()
                       if key.kind == 'vector'})
HOSTILE_NUMBERS = [math.nan, math.inf, -math.inf, 1e308, -1e308]


def test_every_number_and_vector_key_has_a_range():
    for name, key in {**RANGED_NUMBERS, **RANGED_VECTORS}.items():
        assert key.low is not None and key.high is not None, name
        assert math.isfinite(key.low) and math.isfinite(key.high) and key.low < key.high


def scene_with(name, value):
    return Scene({'sphere_names': ['ball'], name: value}, extension=NODE_SCENE)


@pytest.mark.parametrize('name', sorted(RANGED_NUMBERS))
def test_a_number_outside_its_range_is_refused_naming_the_key_and_the_range(name):
    key = RANGED_NUMBERS[name]
    span = key.high - key.low
    for value in (key.low - 0.01 * span - 1e-9, key.high + 0.01 * span + 1e-9, *HOSTILE_NUMBERS):
        with pytest.raises(InvalidInput, match=rf'^{name}: must be (within|finite)'):
            scene_with(name, value)


@pytest.mark.parametrize('name', sorted(RANGED_VECTORS))
def test_a_vector_component_outside_its_range_is_refused_naming_the_key(name):
    key = RANGED_VECTORS[name]
    for value in (key.high * 1.01, key.low * 1.01, *HOSTILE_NUMBERS):
        with pytest.raises(InvalidInput, match=rf'^{name}: every component must be'):
            scene_with(name, [0.0, value, 0.0])


@pytest.mark.parametrize('value', [[True, False, True], np.array([True, False, True]),
                                   [1, 2], [1, 2, 3, 4], 'abc', [[1, 2, 3]], None, 3.0,
                                   [1.0, '2', 3.0]])
def test_a_vector_that_is_not_three_numbers_is_refused(value):
    with pytest.raises(InvalidInput, match=r'^ball.position: expected 3 numbers'):
        scene_with('ball.position', value)


def test_values_at_the_ends_of_a_range_are_accepted():
    assert scene_with('ball.mass', MASS_RANGE_KG[0])['ball.mass'] == MASS_RANGE_KG[0]
    assert scene_with('ball.mass', MASS_RANGE_KG[1])['ball.mass'] == MASS_RANGE_KG[1]
    assert scene_with('ball.radius', RADIUS_RANGE_M[0])['ball.radius'] == RADIUS_RANGE_M[0]
    assert scene_with('physics_rate_hz', 1e5)['physics_rate_hz'] == 1e5
    assert scene_with('real_time_factor', 0)['real_time_factor'] == 0.0
    # A subnormal is a number like any other: accepted where the range takes it.
    assert scene_with('air.density', 5e-324)['air.density'] == 5e-324
    with pytest.raises(InvalidInput, match='ball.mass: must be within'):
        scene_with('ball.mass', 5e-324)


@pytest.mark.parametrize('name, reason', [
    ('a-b', 'not a valid ROS name token'), ('kugel_ü', 'not a valid ROS name token'),
    ('a~b', 'not a valid ROS name token'), ('a:b', 'not a valid ROS name token'),
    ('{ns}', 'not a valid ROS name token'), ('{node}', 'not a valid ROS name token'),
    ('a b', 'not a valid ROS name token'), ('a/b', 'not a valid ROS name token'),
    ('a.b', 'not a valid ROS name token'), ('1ball', 'not a valid ROS name token'),
    ('', 'not a valid ROS name token'), ('a__b', 'not a valid ROS name token'),
    ('x' * 300, 'longer than 64 characters'),
    ('qos_overrides', 'is taken by a parameter'), ('use_sim_time', 'is taken by a parameter'),
    ('gravity', 'is taken by a parameter'), ('water', 'is taken by a parameter'),
    ('sphere_names', 'is taken by a parameter'),
])
def test_a_sphere_name_that_is_not_a_free_ros_name_token_is_refused(name, reason):
    # The node's scene: the physics' keys, the node's and rclpy's names are all taken.
    with pytest.raises(InvalidInput, match=f'^sphere_names: .*{reason}'):
        Scene({'sphere_names': [name]}, extension=NODE_SCENE)
    # and its refusal is short, whatever the name's length
    with pytest.raises(InvalidInput) as refused:
        Scene({'sphere_names': [name]}, extension=NODE_SCENE)
    assert len(str(refused.value)) < 400


def test_the_core_reserves_its_own_keys_and_the_node_adds_its_own_and_rclpys():
    for name in ('gravity', 'water', 'spheres', 'sphere_names'):
        with pytest.raises(InvalidInput, match='is taken by a parameter'):
            Scene({'sphere_names': [name]})
    for name in ('use_sim_time', 'lockstep', 'forces', 'publish_rate_hz'):
        assert Scene({'sphere_names': [name]}).sphere_names == (name,)
        with pytest.raises(InvalidInput, match='is taken by a parameter'):
            Scene({'sphere_names': [name]}, extension=NODE_SCENE)


def test_valid_tokens_are_accepted():
    names = ['cork', '_hidden', 'ball_2', 'Ball', 'x' * 64]
    assert Scene({'sphere_names': names}).sphere_names == tuple(names)


def test_repeated_names_are_refused_with_a_short_reason():
    with pytest.raises(InvalidInput, match=r'names must be unique; repeated: a$') as refused:
        Scene({'sphere_names': ['a'] + [f's{i}' for i in range(5000)] + ['a']})
    assert len(str(refused.value)) < 200


@pytest.mark.parametrize('position', [(0, 0, 3.95), (0, 0, 5.0), (-4.0, 0, 0), (0, 3.91, 0)])
def test_a_sphere_starting_outside_the_pool_or_through_a_wall_is_refused(position):
    with pytest.raises(InvalidInput, match='^ball.position: the sphere .* must start inside'):
        Scene({'sphere_names': ['ball'], 'ball.radius': 0.1, 'ball.position': list(position)})


def test_a_sphere_touching_a_wall_from_inside_is_accepted_where_it_is():
    scene = Scene({'sphere_names': ['ball'], 'ball.radius': 0.1, 'ball.position': [3.9, 0, -3.9]})
    assert Simulation(scene).spheres.position[:, 0].tolist() == [3.9, 0.0, -3.9]


def test_air_denser_than_water_is_refused():
    with pytest.raises(InvalidInput, match='^water.density: must be at least air.density'):
        Scene({'air.density': 2000.0})


@pytest.mark.parametrize('text, reason', [
    ('42\n', 'expected a mapping of node names'),
    ('- a\n- b\n', 'expected a mapping of node names'),
    ('pool_sim:\n  ros__parameters:\n    a: [1, 2\n', 'cannot read it as YAML'),
    ('pool_sim: [1, 2]\n', 'pool_sim: expected a ros__parameters mapping'),
    ('pool_sim:\n  ros__parameters: [1, 2]\n', 'pool_sim: expected a ros__parameters mapping'),
    ('pool_sim:\n  ros__parameters:\n    sphere_names: [a-b]\n', 'not a valid ROS name'),
])
def test_a_params_file_that_is_not_a_params_mapping_is_refused_naming_the_problem(
        tmp_path, text, reason):
    path = tmp_path / 'bad.yaml'
    path.write_text(text)
    with pytest.raises(InvalidInput, match=reason):
        Scene.from_yaml(path)


def test_a_missing_or_binary_params_file_is_refused_naming_it(tmp_path):
    with pytest.raises(InvalidInput, match='missing.yaml: cannot read it'):
        read_params_document(tmp_path / 'missing.yaml')
    binary = tmp_path / 'binary.yaml'
    binary.write_bytes(b'\xff\xfe\x00\x81')
    with pytest.raises(InvalidInput, match='binary.yaml: cannot read it'):
        read_params_document(binary)


@pytest.mark.parametrize('force', [[1e160, 0, 0], [0, -1e10, 0], [0, 0, 1.0000001e9],
                                   [math.nan, 0, 0], [0, 0, -math.inf], [True, 0, 0]])
def test_a_force_beyond_the_limit_or_not_finite_is_refused_and_changes_nothing(force):
    sim = Simulation(Scene.default())
    sim.set_external_force('ice', [1.0, 2.0, 3.0])
    with pytest.raises(InvalidInput, match='ice wrench force'):
        sim.set_external_force('ice', force)
    assert sim.spheres.external_force[:, 2].tolist() == [1.0, 2.0, 3.0]


def test_unknown_names_get_a_short_reason_with_thousands_of_spheres():
    names = [f's{i}' for i in range(5000)]
    sim = Simulation(Scene({'sphere_names': names, 'effects': []}))
    with pytest.raises(InvalidInput) as refused:
        sim.set_mass('moon' * 10_000, 1.0)
    assert str(refused.value).endswith('known spheres: s0, s1, s2, s3 and 4996 more')
    assert len(str(refused.value)) < 200


def log_uniform(low, high):
    return st.floats(math.log10(low), math.log10(high)).map(lambda e: 10.0**e)


def signed(limit):
    return st.one_of(st.just(0.0), st.just(limit), st.just(-limit), st.floats(-limit, limit))


@st.composite
def extreme_scenes(draw):
    """Scenes at and near the corners of the ranges: huge and tiny, light and heavy."""
    half = draw(st.sampled_from([1.0, 100.0, 1e4]))
    radius = min(draw(log_uniform(*RADIUS_RANGE_M)), 0.49 * half)
    room = half - radius
    return {
        'sphere_names': ['ball'], 'pool.min': [-half] * 3, 'pool.max': [half] * 3,
        'ball.mass': draw(st.one_of(st.sampled_from(MASS_RANGE_KG), log_uniform(*MASS_RANGE_KG))),
        'ball.radius': radius,
        'ball.position': [draw(st.floats(-room, room)) for _ in range(3)],
        'ball.velocity': [draw(signed(1e4)) for _ in range(3)],
        'ball.drag_coefficient': draw(st.sampled_from([0.0, 0.47, 10.0])),
        'gravity': [draw(signed(1e3)) for _ in range(3)],
        'water.density': draw(st.sampled_from([0.0, 1000.0, 1e5])),
        'air.density': 0.0, 'water.surface_z': draw(st.floats(-half, half)),
        'water.current': [draw(signed(1e4)), 0.0, 0.0],
        'physics_rate_hz': draw(st.sampled_from([1.0, 200.0, 1e5])),
    }


@settings(deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(extreme_scenes(), st.lists(signed(FORCE_LIMIT_N), min_size=3, max_size=3))
def test_within_the_ranges_the_default_integrator_never_leaves_the_numbers(params, force):
    sim = Simulation(Scene(params))
    sim.set_external_force('ball', force)
    for _ in range(200):
        sim.step()
        assert np.all(np.isfinite(sim.spheres.position))
        assert np.all(np.isfinite(sim.spheres.velocity))
    assert sim.recoveries == 0  # the step guard was never needed
