"""Run a scene without ROS and print a table of the spheres over time.

    python -m pool_sim.headless [params.yaml] [--seconds 20] [--every 1]
    python -m pool_sim.headless [params.yaml] --animate pool.gif [--seconds 10] [--fps 20]
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
    parser.add_argument('--animate', metavar='PATH.gif',
                        help='write a side-view GIF (pool_sim.picture) instead of the table')
    parser.add_argument('--fps', type=float, default=20.0,
                        help='GIF frames per simulated s (dividing 100: real-time playback)')
    args = parser.parse_args(argv)
    try:
        if args.animate:  # refused before any simulating, as a bad params file is
            from pool_sim.picture import checked_animation
            checked_animation(args.animate, args.seconds, args.fps)
        # A params file written for the node: its keys are checked, the node's read by none.
        scene = (Scene.from_yaml(args.params_file, extension=NODE_SCENE) if args.params_file
                 else Scene.default())
    except InvalidInput as error:  # as the node refuses a params file: one line, exit 1
        print(f'pool_sim.headless: refusing to start: {error}', file=sys.stderr)
        return 1
    if args.animate:
        from pool_sim.picture import write_gif
        sim = write_gif(scene, args.animate, args.seconds, args.fps)
        print(f'{args.animate}: {sim.time:.2f} s simulated, {args.fps:g} frames/s')
        return 0
    sim = Simulation(scene)
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
