"""Per-sphere keys as arrays over sphere_names (spheres.<key>), a lift area that follows the
radius until it is set, and spawn and remove in the core (Simulation.change_spheres,
Scene.with_spheres)."""
import math
import time

from hypothesis import given, HealthCheck, settings, strategies as st
import numpy as np
import pytest

from pool_sim.physics import InvalidInput, Scene, Simulation, stepper
from pool_sim.physics.schema import GLOBAL_KEYS, SPHERE_KEYS
from pool_sim.physics.spheres import LIFT_AREA_RANGE_M2

SETTINGS = settings(deadline=None, suppress_health_check=[HealthCheck.too_slow])
VECTOR_KEYS = [key for key, spec in SPHERE_KEYS.items() if spec.kind == 'vector']
# Every array of a Spheres, the derived ones and the lift area's flag included.
SPHERE_FIELDS = ('position', 'velocity', 'mass', 'radius', 'drag_coefficient', 'lift_area',
                 'lift_normal', 'lift_coefficient', 'external_force', 'volume',
                 'cross_section', 'lift_area_follows_radius', 'lift_slope', 'stall_angle')
NAMES = ['a', 'b', 'cork', 'd', 'e']


def assert_same_bits(first, second):
    first, second = np.asarray(first), np.asarray(second)
    assert first.dtype == second.dtype and first.shape == second.shape
    assert first.tobytes() == second.tobytes()


def assert_same_spheres(first, second):
    assert first.names == second.names
    for field in SPHERE_FIELDS:
        assert_same_bits(getattr(first, field), getattr(second, field))


def flat(rows):
    return [component for row in rows for component in row]


def column_of(spheres, field, i):
    """One sphere's entry of a Spheres array: a scalar, or a (3,) column."""
    array = getattr(spheres, field)
    return array[..., i].copy()


# -- the array form is the per-sphere form, bit for bit --------------------------------------

def sphere_values(count):
    """{key: [value per sphere]}: valid values, integers among the numbers, inside the pool."""
    number = st.one_of(st.floats(0.01, 50.0), st.integers(1, 50))
    radius = st.floats(0.01, 0.5)
    normal = st.tuples(*[st.floats(-2.0, 2.0)] * 3).filter(
        lambda v: math.sqrt(sum(c * c for c in v)) > 1e-3)
    coordinate = st.one_of(st.floats(-3.4, 3.4), st.integers(-3, 3))
    per_key = {
        'mass': number, 'radius': radius, 'drag_coefficient': st.floats(0.0, 10.0),
        'lift_area': st.one_of(st.floats(0.0, 1e6), st.integers(0, 10)),
        'lift_coefficient': st.floats(-10.0, 10.0), 'lift_normal': normal,
        'lift_slope': st.floats(0.0, 100.0), 'stall_angle': st.floats(0.01, 1.5),
        'position': st.tuples(coordinate, coordinate, coordinate),
        'velocity': st.tuples(*[st.floats(-1e4, 1e4)] * 3),
    }
    return st.fixed_dictionaries({key: st.lists(values, min_size=count, max_size=count)
                                  for key, values in per_key.items()})


@st.composite
def scenes_in_both_forms(draw):
    """(names, {key: values}, keys given, keys of those given as arrays)."""
    count = draw(st.integers(1, len(NAMES)))
    names = NAMES[:count]
    values = draw(sphere_values(count))
    given = draw(st.sets(st.sampled_from(sorted(SPHERE_KEYS))))
    array_keys = draw(st.sets(st.sampled_from(sorted(given)))) if given else set()
    return names, values, given, array_keys


def one_by_one(names, values, keys):
    return {f'{name}.{key}': (list(values[key][i]) if key in VECTOR_KEYS
                              else values[key][i])
            for key in keys for i, name in enumerate(names)}


def as_arrays(values, keys):
    return {f'spheres.{key}': flat(values[key]) if key in VECTOR_KEYS else list(values[key])
            for key in keys}


@SETTINGS
@given(scenes_in_both_forms())
def test_the_array_form_builds_the_same_spheres_as_the_per_sphere_form(case):
    names, values, given_keys, array_keys = case
    single = Scene({'sphere_names': names, **one_by_one(names, values, given_keys)})
    arrays = Scene({'sphere_names': names, **as_arrays(values, given_keys)})
    mixed = Scene({'sphere_names': names, **as_arrays(values, array_keys),
                   **one_by_one(names, values, given_keys - array_keys)})
    for scene in (arrays, mixed):
        assert_same_spheres(single.build_spheres(), scene.build_spheres())
        assert scene.values == single.values
        for key in SPHERE_KEYS:
            assert_same_bits(scene.sphere_array(key), single.sphere_array(key))
        assert_same_bits(scene.lift_area_given,
                         np.full(len(names), 'lift_area' in given_keys))


def test_a_scene_reads_as_before_key_by_key():
    scene = Scene({'sphere_names': ['a', 'cork'], 'spheres.mass': [1, 2.5],
                   'spheres.position': [0, 0, 0, 1.0, -2.0, 3], 'cork.radius': 0.2})
    assert scene['cork.mass'] == 2.5 and type(scene['cork.mass']) is float
    assert scene['cork.position'] == (1.0, -2.0, 3.0)
    assert all(type(c) is float for c in scene['cork.position'])
    assert scene['cork.radius'] == 0.2 and scene['a.radius'] == 0.1
    assert scene['cork.lift_area'] == math.pi * 0.2 * 0.2
    assert scene['gravity'] == (0.0, 0.0, -9.81)
    assert scene.sphere_names == ('a', 'cork')
    assert scene.sphere_array('position').shape == (2, 3)
    assert scene.sphere_array('mass').tolist() == [1.0, 2.5]
    with pytest.raises(KeyError):
        scene['moon.mass']
    with pytest.raises(InvalidInput, match='^colour: unknown per-sphere key'):
        scene.sphere_array('colour')


def test_sphere_array_is_a_copy_and_the_scene_does_not_change():
    scene = Scene({'sphere_names': ['a'], 'a.mass': 2.0})
    scene.sphere_array('mass')[0] = 5.0
    scene.build_spheres().mass[0] = 5.0
    assert scene['a.mass'] == 2.0
    with pytest.raises(ValueError):
        scene.lift_area_given[0] = False


def test_global_values_are_the_keys_that_are_not_per_sphere():
    scene = Scene.default()
    assert set(scene.global_values()) == set(GLOBAL_KEYS)
    assert scene.global_values()['sphere_names'] == ('cork', 'steel', 'ice')
    per_sphere = {f'{n}.{k}' for n in scene.sphere_names for k in SPHERE_KEYS}
    assert set(scene.values) == set(GLOBAL_KEYS) | per_sphere


def test_a_scene_of_no_spheres_takes_empty_arrays():
    for empty in ([], None):
        scene = Scene({'spheres.mass': empty, 'spheres.position': empty})
        assert scene.sphere_array('mass').shape == (0,)
        assert scene.sphere_array('position').shape == (0, 3)
        assert scene.build_spheres().position.shape == (3, 0)


def test_a_params_file_may_give_the_spheres_as_arrays(tmp_path):
    path = tmp_path / 'arrays.yaml'
    path.write_text(
        '/**:\n'
        '  ros__parameters:\n'
        '    sphere_names: [cork, steel, ice]\n'
        '    spheres:\n'
        '      mass: [8.3776, 32.882, 12.964]\n'
        '      radius: [0.2, 0.1, 0.15]\n'
        '      position: [-2.0, 0.0, 3.7, 0.0, 0.0, 3.8, 2.0, 0.0, 3.75]\n'
        '    ice:\n'
        '      drag_coefficient: 0.3\n'
        '    effects: [gravity, buoyancy, drag, wave_radiation, contact, friction]\n'
        '    contact:\n'
        '      restitution: 0.5\n'
        '      static_friction: 0.6\n'
        '      kinetic_friction: 0.4\n'
        '      rolling_friction: 0.01\n')
    from_arrays = Scene.from_yaml(path)
    expected = Scene.default().with_values(**{'ice.drag_coefficient': 0.3})
    assert_same_spheres(from_arrays.build_spheres(), expected.build_spheres())
    assert from_arrays.values == expected.values


def test_a_hundred_thousand_spheres_from_arrays_build_quickly():
    count = 100_000
    rng = np.random.default_rng(3)
    params = {'sphere_names': [f's{i}' for i in range(count)],
              'spheres.mass': rng.uniform(0.1, 10.0, count).tolist(),
              'spheres.radius': [0.05] * count,
              'spheres.position': rng.uniform(-3.9, 3.9, 3 * count).tolist(),
              'spheres.velocity': [0, 0, 1] * count,
              'spheres.drag_coefficient': [0.47] * count,
              'spheres.lift_area': [0.01] * count,
              'spheres.lift_normal': [0.0, 0.0, 1.0] * count,
              'spheres.lift_coefficient': [0.0] * count}
    start = time.perf_counter()
    spheres = Scene(params).build_spheres()
    assert time.perf_counter() - start < 2.0  # a loose sanity bound: ~0.3 s here
    assert spheres.position.shape == (3, count)


# -- refusals ------------------------------------------------------------------------------

def three(**keys):
    return Scene({'sphere_names': ['a', 'b', 'cork'], **keys})


@pytest.mark.parametrize('key', sorted(SPHERE_KEYS))
def test_an_array_of_the_wrong_length_is_refused_saying_how_many(key):
    width = 3 if key in VECTOR_KEYS else 1
    per = ('one per name in sphere_names' if width == 1
           else r'3 per name in sphere_names, flattened \[x0, y0, z0, x1, \.\.\.\]')
    for length in (0, 3 * width - 1, 3 * width + 1):
        with pytest.raises(InvalidInput,
                           match=rf'^spheres.{key}: expected {3 * width} numbers '
                                 rf'\({per}\), got {length}$'):
            three(**{f'spheres.{key}': [0.5] * length})


@pytest.mark.parametrize('value', [3.0, 'heavy', (1.0 for _ in range(3)), np.zeros((3, 1))])
def test_an_array_key_that_is_not_a_flat_list_is_refused(value):
    with pytest.raises(InvalidInput, match='^spheres.mass: expected one flat list'):
        three(**{'spheres.mass': value})


def valid_row(key):
    return list(SPHERE_KEYS[key].default) if key in VECTOR_KEYS else 0.5


@pytest.mark.parametrize('key', sorted(SPHERE_KEYS))
@pytest.mark.parametrize('bad', ['below', 'above', math.nan, math.inf, -math.inf])
def test_a_value_out_of_range_is_refused_naming_the_first_sphere_and_its_index(key, bad):
    spec = SPHERE_KEYS[key]
    span = spec.high - spec.low
    number = {'below': spec.low - 0.01 * span - 1e-9,
              'above': spec.high + 0.01 * span + 1e-9}.get(bad, bad)
    rows = [valid_row(key) for _ in range(3)]
    if key in VECTOR_KEYS:
        rows[2] = [0.0, number, 1.0]
        rows[1] = list(rows[1])
        values = flat(rows)
        wording = 'every component must be'
    else:
        rows[2] = number
        values = rows
        wording = 'must be (within|finite)'
    with pytest.raises(InvalidInput,
                       match=rf'^spheres.{key}: cork \(index 2\): {wording}') as refused:
        three(**{f'spheres.{key}': values})
    # The same wording as the key given alone, after the sphere.
    alone = str(refused.value).split(': ', 2)[2]
    with pytest.raises(InvalidInput) as single:
        three(**{f'cork.{key}': rows[2]})
    assert str(single.value) == f'cork.{key}: {alone}'


def test_the_first_of_several_bad_values_is_named():
    with pytest.raises(InvalidInput, match=r'^spheres.mass: b \(index 1\): must be finite'):
        three(**{'spheres.mass': [1.0, math.nan, -1.0]})
    with pytest.raises(InvalidInput, match=r'^spheres.velocity: a \(index 0\): every '):
        three(**{'spheres.velocity': [0, 0, 1e9, math.nan, 0, 0, 0, 0, 0]})


@pytest.mark.parametrize('values, message', [
    ([1.0, True, 2.0], r'^spheres.mass: b \(index 1\): expected a number, got bool True'),
    ([1.0, 2.0, 'x'], r"^spheres.mass: cork \(index 2\): expected a number, got str 'x'"),
    ([None, 1.0, 2.0], r'^spheres.mass: a \(index 0\): expected a number'),
    (np.array([True, False, True]), r'^spheres.mass: a \(index 0\): expected a number'),
    ([1.0, 2.0, 10**400], r'^spheres.mass: cork \(index 2\): must be finite'),
])
def test_an_entry_that_is_not_a_number_is_refused_naming_its_sphere(values, message):
    with pytest.raises(InvalidInput, match=message):
        three(**{'spheres.mass': values})


def test_a_zero_lift_normal_is_refused_naming_its_sphere():
    with pytest.raises(InvalidInput,
                       match=r'^spheres.lift_normal: b \(index 1\): must be a non-zero vector'):
        three(**{'spheres.lift_normal': [0, 0, 1, 0, 0, 0, 1, 0, 0]})
    with pytest.raises(InvalidInput, match=r'^spheres.position: b \(index 1\): expected 3 '):
        three(**{'spheres.position': [0, 0, 0, 0, False, 0, 0, 0, 0]})


def test_a_sphere_outside_the_pool_is_refused_naming_the_array_and_the_sphere():
    with pytest.raises(InvalidInput, match=r'^spheres.position: b \(index 1\): the sphere '
                                           r'\(radius 0.1 m\) must start inside the pool'):
        three(**{'spheres.position': [0, 0, 0, 0, 0, 3.95, 9, 9, 9]})
    with pytest.raises(InvalidInput, match=r'^spheres.radius: cork \(index 2\): 5.0 m does '
                                           'not fit the pool'):
        three(**{'spheres.radius': [0.1, 0.1, 5]})
    # given one by one, as ever
    with pytest.raises(InvalidInput, match=r'^b.position: the sphere'):
        three(**{'spheres.radius': [0.1, 0.1, 0.2], 'b.position': [0, 0, 3.95]})


def test_a_key_given_both_ways_is_refused_naming_both():
    with pytest.raises(InvalidInput, match=r'^spheres.mass: given both as spheres.mass and as '
                                           r'cork.mass; give each key one way$'):
        three(**{'spheres.mass': [1, 2, 3], 'cork.mass': 3.0})
    # different keys may take different forms
    assert three(**{'spheres.mass': [1, 2, 3], 'cork.radius': 0.3})['cork.radius'] == 0.3


@pytest.mark.parametrize('name', ['spheres.colour', 'spheres.mass.x', 'spheres.'])
def test_an_unknown_array_key_is_refused(name):
    with pytest.raises(InvalidInput, match=f'^{name}: unknown key; per-sphere keys are'):
        three(**{name: [1.0, 2.0, 3.0]})


def test_a_nested_unknown_array_key_is_refused():
    with pytest.raises(InvalidInput, match='^spheres.colour: unknown key'):
        three(spheres={'mass': [1, 2, 3], 'colour': ['red'] * 3})


def test_no_sphere_may_be_called_spheres():
    with pytest.raises(InvalidInput, match="^sphere_names: 'spheres' is taken by a parameter"):
        Scene({'sphere_names': ['a', 'spheres']})


@pytest.mark.parametrize('name', ['a\nb', 'a\n', '\nb', 'ok\n\nok', 'x_' * 33])
def test_names_checked_all_at_once_are_refused_as_one_by_one(name):
    # 100 000 names are checked in one match; a newline in a name must not split it in two.
    with pytest.raises(InvalidInput, match='^sphere_names: .* (not a valid ROS name token|'
                                           'longer than 64)'):
        Scene({'sphere_names': ['a', name, 'b']})


def test_a_refusal_stays_short_with_a_hundred_thousand_spheres():
    names = [f's{i}' for i in range(100_000)]
    masses = [1.0] * 100_000
    masses[-1] = -1.0
    with pytest.raises(InvalidInput, match=r'^spheres.mass: s99999 \(index 99999\)') as refused:
        Scene({'sphere_names': names, 'spheres.mass': masses})
    assert len(str(refused.value)) < 200
    with pytest.raises(InvalidInput, match=r'^spheres.mass: expected 100000 numbers'):
        Scene({'sphere_names': names, 'spheres.mass': masses[:-1]})


# -- the lift area follows the radius until it is set ---------------------------------------

def lift_scene(**keys):
    return Scene({'sphere_names': ['free', 'pinned'], 'pinned.lift_area': 0.5,
                  'effects': ['gravity', 'lift'], **keys})


def test_the_scene_says_where_the_lift_area_was_given():
    assert lift_scene().lift_area_given.tolist() == [False, True]
    assert lift_scene().build_spheres().lift_area_follows_radius.tolist() == [True, False]
    scene = Scene({'sphere_names': ['a', 'b'], 'spheres.lift_area': [0.1, 0.2]})
    assert scene.lift_area_given.tolist() == [True, True]
    # None for a sphere's lift_area: not given, as before
    assert not Scene({'sphere_names': ['a'], 'a.lift_area': None}).lift_area_given[0]


def test_a_lift_area_not_given_follows_the_radius():
    sim = Simulation(lift_scene())
    sim.set_radius('free', 0.3)
    sim.set_radius('pinned', 0.3)
    assert sim.spheres.lift_area[0] == math.pi * 0.3 * 0.3
    assert sim.spheres.lift_area[1] == 0.5
    # what the scene would have built for that radius, bit for bit
    rebuilt = lift_scene(**{'free.radius': 0.3}).build_spheres()
    assert_same_bits(sim.spheres.lift_area[0], rebuilt.lift_area[0])


def test_set_lift_area_pins_the_area():
    sim = Simulation(lift_scene())
    sim.set_lift_area('free', 0.25)
    sim.set_radius('free', 0.3)
    assert sim.spheres.lift_area[0] == 0.25
    assert not sim.spheres.lift_area_follows_radius[0]
    sim.set_lift_area('free', 3)  # an integer is a number
    assert sim.spheres.lift_area[0] == 3.0


@pytest.mark.parametrize('area', [-1.0, 2e7, math.nan, math.inf, 'big', None, True])
def test_a_bad_lift_area_is_refused_naming_the_key_and_changes_nothing(area):
    sim = Simulation(lift_scene())
    before = sim.spheres.copy()
    with pytest.raises(InvalidInput, match='^free.lift_area: (must be|expected a number)'):
        sim.set_lift_area('free', area)
    assert_same_spheres(sim.spheres, before)
    with pytest.raises(InvalidInput, match="^unknown sphere 'moon'"):
        sim.set_lift_area('moon', 0.1)
    assert sim.spheres.check_lift_area('free', LIFT_AREA_RANGE_M2[1]) == LIFT_AREA_RANGE_M2[1]


def test_a_copy_of_the_spheres_is_independent_and_the_same_bits():
    sim = Simulation(lift_scene())
    sim.set_radius('free', 0.123456789)
    copied = sim.spheres.copy()
    assert_same_spheres(copied, sim.spheres)
    copied.lift_area_follows_radius[0] = False
    assert sim.spheres.lift_area_follows_radius[0]


def test_with_values_lets_a_free_lift_area_follow_a_new_radius():
    scene = lift_scene().with_values(**{'free.radius': 0.3, 'pinned.radius': 0.3})
    assert scene['free.lift_area'] == math.pi * 0.3 * 0.3
    assert scene['pinned.lift_area'] == 0.5
    assert scene.lift_area_given.tolist() == [False, True]


# -- spawn and remove ------------------------------------------------------------------------

def running(seconds=0.5):
    """The default pool after `seconds`, with a force on ice and cork changed live."""
    sim = Simulation(Scene.default())
    sim.set_external_force('ice', [1.0, 2.0, 3.0])
    sim.set_mass('cork', 9.5)
    sim.set_radius('cork', 0.25)
    sim.set_lift_area('ice', 0.07)
    sim.advance(seconds)
    return sim


def snapshot(spheres, name):
    i = spheres.index[name]
    return {field: column_of(spheres, field, i) for field in SPHERE_FIELDS}


def assert_state(spheres, name, expected):
    for field, value in expected.items():
        assert_same_bits(column_of(spheres, field, spheres.index[name]), value)


def test_change_spheres_keeps_the_kept_adds_the_new_and_removes_the_rest():
    sim = running()
    kept = {name: snapshot(sim.spheres, name) for name in ('ice', 'cork')}
    time_before = sim.time
    scene = sim.scene.with_spheres(['ice', 'new', 'cork'],
                                   {'new.mass': 2.0, 'new.position': [1.0, 1.0, 1.0]})
    sim.change_spheres(scene)
    assert sim.spheres.names == ('ice', 'new', 'cork') and sim.time == time_before
    for name, state in kept.items():
        assert_state(sim.spheres, name, state)
    assert_state(sim.spheres, 'new', snapshot(scene.build_spheres(), 'new'))
    assert sim.spheres.external_force[:, 1].tolist() == [0.0, 0.0, 0.0]
    with pytest.raises(InvalidInput, match="unknown sphere 'steel'"):
        sim.set_mass('steel', 1.0)
    for _ in range(200):
        sim.step()
    assert np.all(np.isfinite(sim.spheres.position)) and sim.recoveries == 0
    sim.reset()
    assert sim.time == 0.0
    assert_same_spheres(sim.spheres, scene.build_spheres())


def test_the_builds_agree_bit_for_bit_after_a_change_of_spheres(monkeypatch):
    # From 3 spheres to 120: the plain build, then the parallel one (or the plain one again).
    names = ['steel'] + [f'n{i}' for i in range(118)] + ['cork']
    rng = np.random.default_rng(7)
    given = {'spheres.position': rng.uniform(-3.5, 3.5, 3 * len(names)).tolist(),
             'spheres.velocity': rng.normal(size=3 * len(names)).tolist()}
    runs = []
    for parallel_from in (64, 10**9):
        monkeypatch.setattr(stepper, 'parallel_from_spheres', lambda: parallel_from)
        sim = running()
        scene = sim.scene.with_spheres(names, given)
        sim.change_spheres(scene)
        sim.spheres.external_force[:, 5] = [0.0, 0.0, 30.0]
        for _ in range(100):
            sim.step()
        assert np.all(np.isfinite(sim.spheres.velocity)) and sim.recoveries == 0
        runs.append(sim.spheres.position.copy())
        sim.change_spheres(scene.with_spheres(['cork'], {}))  # back down to one
        sim.step()
        assert sim.spheres.position.shape == (3, 1)
    assert np.array_equal(runs[0], runs[1])


@SETTINGS
@given(st.permutations(['cork', 'steel', 'ice', 'x', 'y']), st.integers(1, 5))
def test_any_spawn_remove_and_reorder_keeps_every_kept_sphere_exactly(order, count):
    names = order[:count]
    sim = running(seconds=0.2)
    before = {name: snapshot(sim.spheres, name) for name in sim.spheres.names}
    scene = sim.scene.with_spheres(names, {'x.position': [0.5, 0.0, 1.0],
                                           'spheres.drag_coefficient': [0.3] * count}
                                   if 'x' in names else {})
    sim.change_spheres(scene)
    initial = scene.build_spheres()
    for name in names:
        assert_state(sim.spheres, name, before.get(name) or snapshot(initial, name))
    sim.advance(0.2)
    assert np.all(np.isfinite(sim.spheres.position))
    sim.reset()
    assert_same_spheres(sim.spheres, initial)


def test_put_backs_not_yet_taken_follow_their_spheres():
    sim = Simulation(Scene.default())
    sim.spheres.external_force[2, 1] = 1e300  # steel; past every setter's check
    sim.step()
    sim.change_spheres(sim.scene.with_spheres(['ice', 'new', 'steel'], {}))
    assert sim.take_recovered() == [2]
    assert 'forces beyond what float arithmetic can hold' in sim.likely_cause(2)
    sim.spheres.external_force[:, 2] = 0.0
    sim.spheres.external_force[2, 0] = 1e300  # ice
    sim.step()
    sim.change_spheres(sim.scene.with_spheres(['steel'], {}))  # ice removed, not yet taken
    assert sim.take_recovered() == []


def test_change_spheres_from_spheres_given_as_arrays():
    template = Simulation(Scene.default())
    sim = Simulation(Scene.default().with_values(sphere_names=[]),
                     initial_spheres=template.spheres.copy())
    sim.advance(0.1)
    steel = snapshot(sim.spheres, 'steel')
    scene = Scene.default().with_spheres(['steel', 'new'], {})
    sim.change_spheres(scene)
    assert_state(sim.spheres, 'steel', steel)
    sim.reset()
    assert_same_spheres(sim.spheres, scene.build_spheres())


def test_change_spheres_refuses_a_scene_with_other_global_keys_and_changes_nothing():
    sim = running()
    before = sim.spheres.copy()
    with pytest.raises(InvalidInput, match='^gravity: change_spheres changes the spheres only'):
        sim.change_spheres(sim.scene.with_values(gravity=[0.0, 0.0, -1.0]))
    assert_same_spheres(sim.spheres, before)
    assert sim.scene.sphere_names == ('cork', 'steel', 'ice')


# -- with_spheres ----------------------------------------------------------------------------

def test_with_spheres_keeps_the_kept_and_defaults_the_new():
    base = Scene.default().with_values(**{'cork.lift_area': 0.3, 'ice.drag_coefficient': 0.2})
    scene = base.with_spheres(['ice', 'plain', 'cork', 'given'],
                              {'given': {'mass': 4.0, 'position': [1, 2, 3]},
                               'cork.mass': 3.0})
    assert scene.sphere_names == ('ice', 'plain', 'cork', 'given')
    assert scene['ice.drag_coefficient'] == 0.2 and scene['ice.mass'] == base['ice.mass']
    assert scene['cork.mass'] == 3.0 and scene['cork.lift_area'] == 0.3
    assert scene['cork.radius'] == base['cork.radius']
    for key, spec in SPHERE_KEYS.items():
        if key != 'lift_area':
            assert scene[f'plain.{key}'] == spec.default
    assert scene['plain.lift_area'] == math.pi * 0.1 * 0.1
    assert scene['given.mass'] == 4.0 and scene['given.position'] == (1.0, 2.0, 3.0)
    assert scene.lift_area_given.tolist() == [False, False, True, False]
    assert scene.global_values() == {**base.global_values(),
                                     'sphere_names': scene.sphere_names}
    for key in SPHERE_KEYS:  # the kept spheres' rows, bit for bit, but for what is given
        assert_same_bits(scene.sphere_array(key)[0], base.sphere_array(key)[2])  # ice
        if key != 'mass':
            assert_same_bits(scene.sphere_array(key)[2], base.sphere_array(key)[0])  # cork


def test_with_spheres_takes_arrays_over_the_new_names():
    scene = Scene.default().with_spheres(['steel', 'new'], {'spheres.mass': [5, 6],
                                                           'new.radius': 0.3})
    assert scene.sphere_array('mass').tolist() == [5.0, 6.0]
    assert scene['new.radius'] == 0.3 and scene['steel.radius'] == 0.1
    # a kept sphere whose lift area follows its radius follows a new one
    grown = Scene.default().with_spheres(['steel'], {'steel.radius': 0.15})
    assert grown['steel.lift_area'] == math.pi * 0.15 * 0.15


@pytest.mark.parametrize('names, given, message', [
    ([], {}, r'^sphere_names: the node needs at least one sphere, got \[\]$'),
    (None, {}, r'^sphere_names: the node needs at least one sphere'),
    (['a', 'a'], {}, '^sphere_names: names must be unique'),
    (['spheres'], {}, "^sphere_names: 'spheres' is taken"),
    (['a-b'], {}, '^sphere_names: .* is not a valid ROS name token'),
    ('cork', {}, '^sphere_names: expected a list of strings'),
    (['cork'], {'gravity': [0, 0, -1]}, '^gravity: a global key; with_spheres changes the '
                                        'spheres'),
    (['cork'], {'sphere_names': ['steel']}, r"^sphere_names: \['steel'\] is not the names"),
    (['cork'], {'steel.mass': 1.0}, '^steel.mass: unknown key'),
    (['cork'], {'cork.mass': -1.0}, r'^cork.mass: must be within \[1e-06, 1e\+09\] kg'),
    (['cork', 'b'], {'spheres.mass': [1.0]}, '^spheres.mass: expected 2 numbers'),
    (['cork', 'b'], {'spheres.mass': [1.0, 0.0]}, r'^spheres.mass: b \(index 1\): must be'),
    (['cork', 'b'], {'b.position': [0, 0, 9]}, '^b.position: the sphere .* must start inside'),
    (['cork'], {'spheres.mass': [1.0], 'cork.mass': 2.0}, '^spheres.mass: given both'),
])
def test_with_spheres_refuses_naming_the_key(names, given, message):
    with pytest.raises(InvalidInput, match=message):
        Scene.default().with_spheres(names, given)


def test_with_spheres_accepts_its_own_names_as_sphere_names():
    scene = Scene.default().with_spheres(['cork'], {'sphere_names': ['cork']})
    assert scene.sphere_names == ('cork',)


def test_with_values_may_add_and_remove_spheres_too():
    scene = Scene.default().with_values(sphere_names=['steel', 'new'], gravity=[0, 0, -1])
    assert scene['steel.mass'] == Scene.default()['steel.mass']
    assert scene['new.mass'] == 1.0 and scene['gravity'] == (0.0, 0.0, -1.0)


def test_a_vector_key_as_three_component_lists_is_the_flat_list():
    rows = [[0.5, -1.0, 2.0], [1.0, 0.0, -2.5], [-3.0, 3.0, 0.25]]
    columns = {f'spheres.position.{c}': [row[i] for row in rows]
               for i, c in enumerate('xyz')}
    by_components = Scene({'sphere_names': ['a', 'b', 'c'], **columns})
    flat_list = Scene({'sphere_names': ['a', 'b', 'c'], 'spheres.position': flat(rows)})
    assert_same_bits(by_components.sphere_array('position'), np.array(rows))
    assert_same_spheres(by_components.build_spheres(), flat_list.build_spheres())


@pytest.mark.parametrize('keys, reason', [
    ({'spheres.position.x': [0.0] * 3, 'spheres.position.y': [0.0] * 3},
     '^spheres.position.z: give all three'),
    ({'spheres.position.x': [0.0] * 3, 'spheres.position.y': [0.0] * 2,
      'spheres.position.z': [0.0] * 3}, '^spheres.position.y: 2 numbers against 3'),
    ({'spheres.velocity.x': [0.0] * 3, 'spheres.velocity.y': [0.0] * 3,
      'spheres.velocity.z': [0.0] * 3, 'spheres.velocity': [0.0] * 9},
     '^spheres.velocity: given both'),
    ({'spheres.position.x': 1.0, 'spheres.position.y': [0.0] * 3,
      'spheres.position.z': [0.0] * 3}, '^spheres.position.x: expected a list'),
    ({'spheres.position.x': [0.0] * 2, 'spheres.position.y': [0.0] * 2,
      'spheres.position.z': [0.0] * 2}, '^spheres.position: expected 9 numbers'),
])
def test_component_lists_that_do_not_fit_are_refused_naming_the_key(keys, reason):
    with pytest.raises(InvalidInput, match=reason):
        Scene({'sphere_names': ['a', 'b', 'c'], **keys})
