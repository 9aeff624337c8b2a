"""What each effect costs per step: a scene pays only for the effects it lists.

    .venv/bin/python -m benchmarks.effect_cost [--spheres 1000]

Prints ns per sphere-step of the compiled step (one thread, as the node runs it), all rows
measured in one run. A sphere's cost depends on where it
is (one resting on the floor takes the friction branch), so every scene is timed over the
same STEPS steps from its start, the scenes taking turns (common.seconds_per_step_in_turns).
"""
import argparse

from benchmarks.common import many_spheres_scene, seconds_per_step_in_turns
from pool_sim.physics import DEFAULT_EFFECTS, Simulation, stepper

SCENES = [
    ('default: ' + ', '.join(DEFAULT_EFFECTS), DEFAULT_EFFECTS),
    ('default without buoyancy', [e for e in DEFAULT_EFFECTS if e != 'buoyancy']),
    ('gravity, drag', ['gravity', 'drag']),
    ('gravity', ['gravity']),
    ('nothing (external forces only)', []),
]
STEPS, REPEATS = 20, 31


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument('--spheres', type=int, default=1000)
    count = parser.parse_args().spheres
    stepper.use_threads(1)  # as the node runs it
    seconds = seconds_per_step_in_turns(
        [Simulation(many_spheres_scene(count, effects)) for _, effects in SCENES], STEPS,
        REPEATS, restart=True)
    cost = [s / count * 1e9 for s in seconds]
    print(f'{count} spheres, default integrator; ns per sphere-step, median of {REPEATS} '
          f'turns of {STEPS} steps (one call) from the same start')
    print(f'| {"effects":<55} | ns/sphere-step | vs default |')
    print(f'|{"-" * 57}|---------------:|-----------:|')
    for (label, _), each in zip(SCENES, cost):
        print(f'| {label:<55} | {each:14.1f} | {each / cost[0]:10.2f} |')


if __name__ == '__main__':
    main()
