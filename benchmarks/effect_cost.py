"""What each effect costs per step: a scene pays only for the effects it lists.

    .venv/bin/python -m benchmarks.effect_cost [--spheres 1000]

Prints ns per sphere-step (median of repeats, all rows measured in one run).
"""
import argparse

from benchmarks.common import many_spheres_scene, timed
from pool_sim.physics import DEFAULT_EFFECTS, Simulation

SCENES = [
    ('default: ' + ', '.join(DEFAULT_EFFECTS), DEFAULT_EFFECTS),
    ('default without buoyancy', [e for e in DEFAULT_EFFECTS if e != 'buoyancy']),
    ('gravity, drag', ['gravity', 'drag']),
    ('gravity', ['gravity']),
    ('nothing (external forces only)', []),
]


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument('--spheres', type=int, default=1000)
    count = parser.parse_args().spheres
    print(f'{count} spheres, default integrator; ns per sphere-step, median of 7 repeats')
    print(f'| {"effects":<55} | ns/sphere-step | vs default |')
    print(f'|{"-" * 57}|---------------:|-----------:|')
    baseline = None
    for label, effects in SCENES:
        sim = Simulation(many_spheres_scene(count, effects))
        cost = timed(sim.step) / count * 1e9
        baseline = baseline or cost
        print(f'| {label:<55} | {cost:14.1f} | {cost / baseline:10.2f} |')


if __name__ == '__main__':
    main()
