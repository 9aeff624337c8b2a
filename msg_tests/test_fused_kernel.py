"""The fused kernel computes what the numpy pipeline computes, wherever it is used."""
import itertools

import numpy as np
import pytest

from pool_sim.physics import InvalidInput, Scene, Simulation
from pool_sim.physics import fused as fused_module
from pool_sim.physics.fused import FUSED_EFFECTS, numba

pytestmark = pytest.mark.skipif(numba is None, reason='numba is not installed')

EFFECT_SETS = [list(s) for n in (0, 2, 3, 5)
               for s in itertools.combinations(sorted(FUSED_EFFECTS), n)
               if not ('friction' in s and 'contact' not in s)]


def random_scene(effects, seed, count=40):
    rng = np.random.default_rng(seed)
    names = [f's{i}' for i in range(count)]
    params = {'sphere_names': names, 'effects': effects,
              'gravity': list(rng.normal(size=3) * 5.0 + [0.0, 0.0, -5.0]),
              'air.wind': list(rng.normal(size=3)), 'water.current': list(rng.normal(size=3)),
              'contact.restitution': float(rng.uniform()),
              'contact.static_friction': 0.7, 'contact.kinetic_friction': 0.3,
              'contact.rolling_friction': 0.05, 'physics_rate_hz': float(rng.uniform(10, 500))}
    for name in names:
        radius = float(rng.uniform(0.01, 0.5))
        params[f'{name}.radius'] = radius
        params[f'{name}.mass'] = float(rng.uniform(10, 9000) * 4 / 3 * np.pi * radius**3)
        params[f'{name}.position'] = list(rng.uniform(-3.5, 3.5, 3))
        params[f'{name}.velocity'] = list(rng.normal(size=3) * 5.0)
        params[f'{name}.drag_coefficient'] = float(rng.uniform(0.1, 1.5))
    return Scene(params)


# Both builds of the kernel: the plain loop below the threshold, the parallel one above (held
# at 64 spheres whichever threading layer this machine has).
@pytest.mark.parametrize('count', [32, 192])
@pytest.mark.parametrize('effects', EFFECT_SETS, ids='+'.join)
def test_fused_and_numpy_agree_step_for_step(effects, count, monkeypatch):
    monkeypatch.setattr(fused_module, 'parallel_from_spheres', lambda: 64)
    scene = random_scene(effects, seed=len(effects), count=count)
    fused, plain = Simulation(scene, backend='fused'), Simulation(scene, backend='numpy')
    force = np.random.default_rng(1).normal(size=(3, count)) * 20.0
    fused.spheres.external_force[:] = force
    plain.spheres.external_force[:] = force
    for _ in range(300):
        fused.step()
        plain.step()
        np.testing.assert_allclose(fused.spheres.position, plain.spheres.position,
                                   rtol=1e-12, atol=1e-12)
        np.testing.assert_allclose(fused.spheres.velocity, plain.spheres.velocity,
                                   rtol=1e-12, atol=1e-12)


@pytest.mark.parametrize('keys, backend', [
    ({}, 'fused'),
    ({'effects': ['gravity', 'lift']}, 'numpy'),
    ({'effects': ['gravity', 'added_mass']}, 'numpy'),
    ({'integrator': 'rk4'}, 'numpy'),
])
def test_auto_takes_the_kernel_only_where_it_computes_the_same_thing(keys, backend):
    assert Simulation(Scene.default().with_values(**keys)).backend == backend


def test_asking_for_the_kernel_where_it_does_not_apply_is_refused():
    with pytest.raises(InvalidInput, match='fused kernel needs'):
        Simulation(Scene.default().with_values(integrator='rk4'), backend='fused')


@pytest.mark.parametrize('layer, spheres', [('omp', 64), ('tbb', 64), ('workqueue', 4096)])
def test_the_parallel_build_starts_where_its_launch_pays_for_this_threading_layer(
        layer, spheres, monkeypatch):
    monkeypatch.setattr(fused_module, '_threading_layer', layer)
    assert fused_module.parallel_from_spheres() == spheres
