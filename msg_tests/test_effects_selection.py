"""Only the effects a scene lists run: what it does not list is never called."""
import pytest

from pool_sim.physics import effects, Simulation
from scenes import one_sphere


# Every function of the core that computes an effect, and the effect it belongs to.
EFFECT_OF = {'gravity_force': 'gravity', 'buoyancy_force': 'buoyancy', 'lift_force': 'lift',
             'drag_gains': 'drag', 'drag_factors': 'drag', 'added_mass': 'added_mass'}


@pytest.fixture
def call_counts(monkeypatch):
    """Wrap every effect function of the core so each call is counted, by effect."""
    counts = {}
    for name, effect in EFFECT_OF.items():
        original = getattr(effects, name)

        def counted(*args, _original=original, _effect=effect, **kwargs):
            counts[_effect] = counts.get(_effect, 0) + 1
            return _original(*args, **kwargs)
        monkeypatch.setattr(effects, name, counted)
    return counts


@pytest.mark.parametrize('listed, expected_called', [
    (['gravity', 'drag', 'contact'], {'gravity', 'drag'}),
    (['gravity'], {'gravity'}),
    ([], set()),
    (['gravity', 'buoyancy', 'drag', 'lift', 'added_mass', 'contact', 'friction'],
     {'gravity', 'buoyancy', 'lift', 'drag', 'added_mass'}),
])
@pytest.mark.parametrize('integrator', ['linearly_implicit_euler', 'rk4'])
def test_a_scene_calls_exactly_the_effects_it_lists(call_counts, listed, expected_called,
                                                   integrator):
    # The numpy pipeline: the fused kernel skips an unlisted effect by a branch instead, which
    # benchmarks/effect_cost.py shows costs nothing measurable.
    sim = Simulation(one_sphere(0.1, 500.0, effects=listed, integrator=integrator),
                     backend='numpy')
    sim.advance(0.5)
    assert set(call_counts) == expected_called


def test_without_buoyancy_the_water_fraction_is_not_even_computed(monkeypatch):
    calls = []
    sim = Simulation(one_sphere(0.1, 500.0, effects=['gravity', 'contact']), backend='numpy')
    monkeypatch.setattr(sim.dynamics, 'fraction_of', lambda *a: calls.append(a))
    sim.advance(0.5)
    assert calls == []
    assert sim.dynamics.water_fraction(sim.spheres, sim.spheres.position) is None
