"""Only the effects a scene lists run: what it does not list is never called."""
import pytest

from pool_sim.physics import effects, Simulation
from scenes import one_sphere


@pytest.fixture
def call_counts(monkeypatch):
    """Wrap every force function of the core so each call is counted."""
    counts = {}
    for name in ('gravity_force', 'buoyancy_force', 'lift_force', 'drag_gains', 'added_mass'):
        original = getattr(effects, name)

        def counted(*args, _original=original, _name=name, **kwargs):
            counts[_name] = counts.get(_name, 0) + 1
            return _original(*args, **kwargs)
        monkeypatch.setattr(effects, name, counted)
    return counts


@pytest.mark.parametrize('listed, expected_called', [
    (['gravity', 'drag', 'contact'], {'gravity_force', 'drag_gains'}),
    (['gravity'], {'gravity_force'}),
    ([], set()),
    (['gravity', 'buoyancy', 'drag', 'lift', 'added_mass', 'contact', 'friction'],
     {'gravity_force', 'buoyancy_force', 'lift_force', 'drag_gains', 'added_mass'}),
])
@pytest.mark.parametrize('integrator', ['linearly_implicit_euler', 'rk4'])
def test_a_scene_calls_exactly_the_effects_it_lists(call_counts, listed, expected_called,
                                                   integrator):
    # Dynamics looks the functions up when it is built, after the wrapping.
    sim = Simulation(one_sphere(0.1, 500.0, effects=listed, integrator=integrator))
    sim.advance(0.5)
    assert set(call_counts) == expected_called


def test_without_buoyancy_the_water_fraction_is_not_even_computed(monkeypatch):
    calls = []
    sim = Simulation(one_sphere(0.1, 500.0, effects=['gravity', 'contact']))
    monkeypatch.setattr(sim.dynamics, 'fraction_of', lambda *a: calls.append(a))
    sim.advance(0.5)
    assert calls == []
    assert sim.dynamics.water_fraction(sim.spheres, sim.spheres.position) is None
