"""What each effect costs per step: a scene pays only for the effects it lists.

    .venv/bin/python -m benchmarks.effect_cost [--spheres 1000] [--at-surface]

Prints ns per sphere-step of the compiled step (one thread, as the node runs it), all rows
measured in one run. A sphere's cost depends on where it
is (one resting on the floor takes the friction branch), so every scene is timed over the
same STEPS steps from its start, the scenes taking turns (common.seconds_per_step_in_turns).
--at-surface starts every sphere crossing the water surface, where wave_radiation acts.
"""
import argparse

import numpy as np

from benchmarks.common import many_spheres_scene, seconds_per_step_in_turns
from pool_sim.physics import DEFAULT_EFFECTS, Simulation, stepper

SCENES = [
    ('default: ' + ', '.join(DEFAULT_EFFECTS), DEFAULT_EFFECTS),
    ('default without wave_radiation', [e for e in DEFAULT_EFFECTS if e != 'wave_radiation']),
    ('default without buoyancy', [e for e in DEFAULT_EFFECTS if e != 'buoyancy']),
    ('default + lift', [*DEFAULT_EFFECTS, 'lift']),
    ('gravity, drag', ['gravity', 'drag']),
    ('gravity', ['gravity']),
    ('nothing (external forces only)', []),
]
STEPS, REPEATS = 20, 31


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument('--spheres', type=int, default=1000)
    parser.add_argument('--at-surface', action='store_true')
    arguments = parser.parse_args()
    count = arguments.spheres
    stepper.use_threads(1)  # as the node runs it
    simulations = []
    for _, effects in SCENES:
        scene = many_spheres_scene(count, effects)
        if arguments.at_surface:
            scene = at_the_surface(scene)
        simulations.append(Simulation(scene))
    seconds = seconds_per_step_in_turns(simulations, STEPS, REPEATS, restart=True)
    cost = [s / count * 1e9 for s in seconds]
    where = ', every one crossing the surface' if arguments.at_surface else ''
    print(f'{count} spheres{where}, default integrator; ns per sphere-step, median of '
          f'{REPEATS} turns of {STEPS} steps (one call) from the same start')
    print(f'| {"effects":<55} | ns/sphere-step | vs default |')
    print(f'|{"-" * 57}|---------------:|-----------:|')
    for (label, _), each in zip(SCENES, cost):
        print(f'| {label:<55} | {each:14.1f} | {each / cost[0]:10.2f} |')


def at_the_surface(scene):
    """The scene with every sphere's centre within half a radius of the water surface."""
    rng = np.random.default_rng(1)
    radius, position = scene.sphere_array('radius'), scene.sphere_array('position').copy()
    position[:, 2] = scene['water.surface_z'] + rng.uniform(-0.5, 0.5, radius.size) * radius
    return scene.with_values(**{f'{name}.position': [float(v) for v in position[i]]
                                for i, name in enumerate(scene.sphere_names)})


if __name__ == '__main__':
    main()
