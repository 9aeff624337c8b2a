"""Run a scene without ROS and print a table of the spheres over time.

    python -m pool_sim.headless [params.yaml] [--seconds 20] [--every 1] [--foxglove [PORT]]
"""
import argparse
import sys

from pool_sim.physics import InvalidInput, Scene, Simulation
from pool_sim.ros.node_keys import NODE_SCENE


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument('params_file', nargs='?', help='ROS params YAML (default: the pool)')
    parser.add_argument('--seconds', type=float, default=20.0, help='simulated time, s')
    parser.add_argument('--every', type=float, default=1.0, help='table row interval, s')
    parser.add_argument('--foxglove', type=int, nargs='?', const=8765, metavar='PORT',
                        help='serve a live view to Foxglove on PORT (default 8765) and run '
                        'in real time instead of printing the table')
    args = parser.parse_args(argv)
    try:
        # A params file written for the node: its keys are checked, the node's read by none.
        scene = (Scene.from_yaml(args.params_file, extension=NODE_SCENE) if args.params_file
                 else Scene.default(extension=NODE_SCENE))
    except InvalidInput as error:  # as the node refuses a params file: one line, exit 1
        print(f'pool_sim.headless: refusing to start: {error}', file=sys.stderr)
        return 1
    sim = Simulation(scene)
    if args.foxglove is not None:
        from pool_sim.ros.foxglove_view import serve_headless
        try:
            return serve_headless(scene, sim, args.seconds, args.foxglove)
        except InvalidInput as error:
            print(f'pool_sim.headless: refusing to start: {error}', file=sys.stderr)
            return 1
    names = sim.spheres.names
    print('   t [s] ' + ''.join(f'| {n:>8} z [m]  vz [m/s] ' for n in names))
    rows = round(args.seconds / args.every)
    for row in range(rows + 1):
        sim.advance(row * args.every - sim.time)
        cells = ''.join(f'| {z:>15.3f} {vz:>9.3f} ' for z, vz in zip(
            sim.spheres.position[2], sim.spheres.velocity[2]))
        print(f'{sim.time:8.2f} {cells}')
    return 0


if __name__ == '__main__':
    sys.exit(main())
