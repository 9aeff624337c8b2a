"""Only the effects a scene lists run: what it does not list is never called.

The compiled step is this package's Python code with the scene's choices as compile-time
constants, each branch on them folded away before the loop is built. Run as plain Python
(numba's NUMBA_DISABLE_JIT, in a process of its own), the same code lets every call of an
effect's function be counted."""
import json
import os
import pathlib
import subprocess
import sys

import pytest

ROOT = pathlib.Path(__file__).resolve().parent.parent

COUNT_CALLS = r'''
import json, sys
from pool_sim.physics import Simulation
from pool_sim.physics.kernels import effects
from scenes import one_sphere

# Every function of the core that computes an effect, and the effect it belongs to.
EFFECT_OF = {'gravity_force': 'gravity', 'buoyancy_force': 'buoyancy',
             'buoyancy_stiffness': 'buoyancy', 'lift_force': 'lift', 'drag_factors': 'drag',
             'drag_force': 'drag', 'added_mass': 'added_mass',
             'heave_radiation': 'wave_radiation', 'submerged_fraction': 'water fraction'}
counts = {}
for name, effect in EFFECT_OF.items():
    def counted(*args, _original=getattr(effects, name), _effect=effect):
        counts[_effect] = counts.get(_effect, 0) + 1
        return _original(*args)
    setattr(effects, name, counted)
for module in ('kernels.integrators', 'stepper'):  # names they imported from effects
    imported = sys.modules['pool_sim.physics.' + module]
    for name in EFFECT_OF:
        if hasattr(imported, name):
            setattr(imported, name, getattr(effects, name))
results = []
for listed, integrator in json.loads(sys.argv[1]):
    counts.clear()
    sim = Simulation(one_sphere(0.1, 500.0, position=(0.0, 0.0, 0.05), effects=listed,
                                integrator=integrator, physics_rate_hz=100.0))
    sim.advance(0.2)
    results.append(sorted(counts))
print(json.dumps(results))
'''

CASES = [
    (['gravity', 'drag', 'contact'], {'gravity', 'drag', 'water fraction'}),
    (['gravity'], {'gravity'}),
    (['gravity', 'contact', 'friction'], {'gravity'}),  # no water fraction computed
    ([], set()),
    (['buoyancy'], {'buoyancy', 'water fraction'}),
    (['gravity', 'lift'], {'gravity', 'lift', 'water fraction'}),
    (['gravity', 'added_mass'], {'gravity', 'added_mass', 'water fraction'}),
    (['gravity', 'wave_radiation'], {'gravity', 'wave_radiation'}),
    (['gravity', 'buoyancy', 'drag', 'wave_radiation', 'contact', 'friction'],
     {'gravity', 'buoyancy', 'drag', 'wave_radiation', 'water fraction'}),
    (['gravity', 'buoyancy', 'drag', 'lift', 'added_mass', 'wave_radiation', 'contact',
      'friction'],
     {'gravity', 'buoyancy', 'lift', 'drag', 'added_mass', 'wave_radiation', 'water fraction'}),
]
INTEGRATOR_NAMES = ['linearly_implicit_euler', 'rk4', 'explicit_euler', 'semi_implicit_euler',
                    'velocity_verlet']


@pytest.fixture(scope='module')
def called():
    """{(effects, integrator): the effects whose functions were called}, from one process."""
    runs = [(listed, integrator) for listed, _ in CASES for integrator in INTEGRATOR_NAMES]
    environment = {**os.environ, 'NUMBA_DISABLE_JIT': '1',
                   'PYTHONPATH': os.pathsep.join([str(ROOT), str(ROOT / 'msg_tests')])}
    done = subprocess.run([sys.executable, '-c', COUNT_CALLS, json.dumps(runs)], cwd=ROOT,
                          env=environment, capture_output=True, text=True, timeout=300)
    assert done.returncode == 0, done.stderr
    return {(tuple(listed), integrator): set(result)
            for (listed, integrator), result in zip(runs, json.loads(done.stdout))}


@pytest.mark.parametrize('integrator', INTEGRATOR_NAMES)
@pytest.mark.parametrize('listed, expected_called', CASES, ids=lambda c: str(c))
def test_a_scene_calls_exactly_the_effects_it_lists(called, listed, expected_called,
                                                   integrator):
    assert called[(tuple(listed), integrator)] == expected_called
