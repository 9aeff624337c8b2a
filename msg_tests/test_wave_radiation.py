"""Wave radiation: the BEM coefficients against published values, the free decay against
the Cummins equation, the seed's pool at rest, and the hard cases stable."""
import math
import pathlib
import sys

import numpy as np
import pytest

from benchmarks import free_decay
from benchmarks.reference import decay_period_and_damping
from pool_sim.physics import DEFAULT_EFFECTS, Simulation
from pool_sim.physics.kernels import wave_table
from scenes import floating_draft_ratio, one_sphere

ROOT = pathlib.Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT / 'scripts'))
import radiation_coefficients  # noqa: E402

HEMISPHERE_VOLUME = 2.0 / 3.0 * math.pi  # of the unit sphere, m^3


def test_the_bem_hemisphere_matches_hulmes_limits():
    """Hulme (1982, J. Fluid Mech. 121) for the floating hemisphere in heave: added mass
    0.8310 (zero frequency) and 0.5 (infinite frequency) of the displaced mass."""
    data = radiation_coefficients.load_bem()
    row = list(data['drafts']).index(1.0)
    added = data['added_mass'][row] / HEMISPHERE_VOLUME
    assert added[0] == pytest.approx(0.8310, rel=0.02)
    assert added[-1] == pytest.approx(0.5, rel=0.02)
    # Damping: zero at both ends, positive between; the panels resolve the waves up to
    # nu ~ 10 (beyond, it is below 1e-3 of the peak's 0.71 and within the BEM's noise).
    damping, nu = data['damping'][row], data['frequencies']
    assert damping[0] == 0.0 and damping[-1] == 0.0
    assert np.all(damping[(nu > 0.0) & (nu <= 10.0)] > 0.0)
    assert np.all(np.abs(damping[nu > 10.0]) < 2e-3)
    assert damping.max() / HEMISPHERE_VOLUME == pytest.approx(0.342, abs=0.01)


def test_the_shipped_table_is_what_the_script_makes_of_the_bem_results():
    drafts, mass_axis, added, rate = radiation_coefficients.build_table(
        radiation_coefficients.load_bem())
    np.testing.assert_allclose(wave_table.DRAFTS, drafts, atol=1e-12)
    np.testing.assert_allclose(wave_table.MASS_AXIS, mass_axis, atol=1e-12)
    np.testing.assert_allclose(wave_table.ADDED_MASS, added, rtol=1e-5, atol=1e-9)
    np.testing.assert_allclose(wave_table.DAMPING_RATE, rate, rtol=1e-5, atol=1e-9)
    np.testing.assert_allclose(wave_table.ADDED_MASS_SLOPE,
                               radiation_coefficients.added_mass_slopes(drafts, added),
                               rtol=1e-5, atol=1e-5)


@pytest.mark.parametrize('draft', free_decay.DRAFTS)
def test_the_free_decay_matches_the_cummins_equation_within_ten_percent(draft):
    times, z = free_decay.cummins_decay(draft)
    period, damping_ratio = decay_period_and_damping(times, z)
    sim_times, sim_z = free_decay.simulated_decay(draft, duration=times[-1])
    sim_period, sim_damping_ratio = decay_period_and_damping(sim_times, sim_z)
    assert sim_period == pytest.approx(period, rel=0.10)
    assert sim_damping_ratio == pytest.approx(damping_ratio, rel=0.10)
    # Without the effect there is no damping at all: it is the effect that decays.
    _, undamped = free_decay.simulated_decay(draft, ('gravity', 'buoyancy'), times[-1])
    assert decay_period_and_damping(sim_times, undamped)[1] < 0.1 * damping_ratio


def test_the_seeds_pool_comes_to_rest_as_its_figure_9_shows():
    """The cork within 1 mm of its draft from 10 s on (without the effect it still swings
    3 mm after three minutes); the ice, lightly damped at its deep draft (damping ratio
    0.0036 by the BEM), swings less than half as much as without the effect in 10-20 s
    and rests within 1 mm of its draft from 100 s on (89 s measured); the steel on the
    floor."""
    times, with_it, sim = free_decay.pool_heights(DEFAULT_EFFECTS, duration=110.0)
    assert 'wave_radiation' in sim.scene['effects']
    without_times, without, _ = free_decay.pool_heights(
        [e for e in DEFAULT_EFFECTS if e != 'wave_radiation'], duration=20.0)
    for name, from_s in (('cork', 10.0), ('ice', 100.0), ('steel', 10.0)):
        rest = free_decay.rest_height(sim, name)
        assert np.max(np.abs(with_it[name][times >= from_s] - rest)) < 1e-3, name

    def swing(found, at, start, end):
        window = found[(at >= start) & (at <= end)]
        return window.max() - window.min()
    assert swing(with_it['ice'], times, 10, 20) < 0.5 * swing(without['ice'], without_times,
                                                              10, 20)


@pytest.mark.parametrize('rate_hz', [1.0, 2.0, 5.0, 10.0, 30.0, 200.0, 1e4])
@pytest.mark.parametrize('density', [50.0, 250.0, 917.0, 990.0, 7850.0])
def test_floating_and_sinking_spheres_stay_stable_at_any_step(rate_hz, density):
    """Dropped from 1 m into the water with the default effects and integrator: finite,
    inside the pool, the energy (the water carried counted) never above its start, and
    the floating ones at their draft after 60 s: within 1 mm where the waves damp the
    heave strongly (density up to 250), within 5 mm at the deep drafts where they hardly
    do (917 and 990: damping ratio below 0.004)."""
    sim = Simulation(one_sphere(0.15, density, position=(0.0, 0.0, 1.0),
                                physics_rate_hz=rate_hz))
    start = sim.mechanical_energy()[0]
    highest = start
    dt = 1.0 / rate_hz
    for _ in range(int(math.ceil(60.0 / dt)) if rate_hz <= 200 else 20000):
        sim.step()
        assert np.all(np.isfinite(sim.spheres.position))
        highest = max(highest, sim.mechanical_energy()[0])
    assert highest <= start + 1e-9 * abs(start)
    if density < 1000.0 and rate_hz <= 200.0:
        draft = floating_draft_ratio((density - 1.2) / (1000.0 - 1.2))
        tolerance = 1e-3 if density <= 250.0 else 5e-3
        assert sim.spheres.position[2, 0] == pytest.approx(0.15 * (1.0 - draft),
                                                           abs=tolerance)
        assert abs(sim.spheres.velocity[2, 0]) < 1e-2


@pytest.mark.parametrize('mass', [1e-6, 1e-3, 1.0, 1e3, 1e9])
@pytest.mark.parametrize('radius', [1e-4, 0.01, 0.5, 3.0])
def test_extreme_spheres_at_the_surface_stay_finite(mass, radius):
    """A milligram to a ship, a tenth of a millimetre to 3 m, thrown through the surface
    at 100 m/s at 200 Hz and 1 Hz."""
    for rate_hz in (200.0, 1.0):
        sim = Simulation(one_sphere(radius, mass=mass, position=(0.0, 0.0, 0.0),
                                    velocity=(0.0, 0.0, -100.0), physics_rate_hz=rate_hz))
        start = sim.mechanical_energy()[0]
        for _ in range(400):
            sim.step()
            assert np.all(np.isfinite(sim.spheres.position))
            assert np.all(np.isfinite(sim.spheres.velocity))
        assert sim.mechanical_energy()[0] <= start + 1e-9 * abs(start)


def test_a_scene_without_it_steps_as_before_bit_for_bit_with_a_zero_table_effect():
    """Off the surface (wholly under water) the effect adds nothing: the same steps with
    and without it listed."""
    params = dict(position=(0.0, 0.0, -2.0), velocity=(0.3, 0.1, -0.2))
    with_it = Simulation(one_sphere(0.1, 1500.0, effects=list(DEFAULT_EFFECTS), **params))
    without = Simulation(one_sphere(0.1, 1500.0, effects=[e for e in DEFAULT_EFFECTS
                                                           if e != 'wave_radiation'],
                                    **params))
    with_it.advance(0.5)
    without.advance(0.5)
    assert with_it.spheres.position[2, 0] < -1.0
    np.testing.assert_array_equal(with_it.spheres.position, without.spheres.position)
    np.testing.assert_array_equal(with_it.spheres.velocity, without.spheres.velocity)
