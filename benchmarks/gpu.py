"""`backend: cuda` measured: the default effects' step on one GPU, by size, against the CPU
step of the same host on one core and on every core, and how far the two backends agree.

    python3 -m benchmarks.gpu [--sizes 10000 1000000 10000000 100000000] [--out results/gpu]

Needs only numpy, numba, numba-cuda, PyYAML, and for the collisions CuPy and scipy (no
ROS): made to run as one prepared script on a GPU machine in a few minutes. Writes gpu.md
(the tables) and gpu.csv to --out.
Under NUMBA_ENABLE_CUDASIM=1 (and NUMBA_DISABLE_JIT=1) it runs in numba's CUDA simulator,
which the tests do with a few spheres to keep it working; its figures then mean nothing.

What it measures, every figure a median:
- one step per launch (the node's pattern at a high publish rate, and what a contact solver
  with a pass per launch pays), and STEPS_PER_LAUNCH steps per launch (a sphere kept in
  registers between its steps), in ns per sphere-step; the bytes the one-step launch moves
  (its arrays read and written once) over its time;
- the launch itself from Python at 10 000 spheres: a call of the kernel (numba-cuda types
  every argument), and a call of a launch configuration built once;
- the CPU step of the same spheres on one core and on every core (numba's threads), for the
  ratio, where its arrays fit the host (sizes up to CPU_MAX_SPHERES);
- CPU-GPU agreement: the same scene stepped by Simulation on both backends, the largest
  difference in position after AGREEMENT_STEPS steps;
- colliding spheres stepped whole on the GPU, at rest and landing, at --colliding-sizes
  (benchmarks/gpu_colliding.py: its section of gpu.md, and gpu_colliding.csv);
- the collision pass by stage, at rest and landing, at --solve-sizes (benchmarks/
  gpu_solve.py: its section of gpu.md, and gpu_solve.csv).
"""
import argparse
import os
import pathlib
import statistics
import time
import types

import numba
import numpy as np

from benchmarks import gpu_colliding, gpu_solve
from benchmarks.common import provenance, write_csv
from pool_sim.physics import DEFAULT_EFFECTS, Scene, Simulation, Spheres, stepper
from pool_sim.physics.cuda import blocks_for, load_cuda, simulated, THREADS_PER_BLOCK
from pool_sim.physics.cuda.device import DeviceState
from pool_sim.physics.spheres import LIFT_SLOPE, STALL_ANGLE

STEPS_PER_LAUNCH = 100
DT = 0.005  # s: the default physics_rate_hz
CPU_MAX_SPHERES = 10_000_000
AGREEMENT_SPHERES, AGREEMENT_STEPS = 10_000, 400
# The bytes a one-step launch reads and writes per sphere: position and velocity read and
# written (2 x 48), the properties read (PROPERTIES: 9 scalars and 2 vectors, 15 doubles).
BYTES_PER_SPHERE_STEP = 2 * 48 + 15 * 8


def scattered_arrays(count, seed=0):
    """`count` spheres of random size and density scattered through the default pool's air
    and water, moving: their arrays by their names on Spheres (cuda.device.ARRAYS), and
    count. No names: a scene's lists, or Spheres' names, would not scale to 1e8."""
    rng = np.random.default_rng(seed)
    radius = rng.uniform(0.02, 0.1, count)
    density = rng.uniform(100.0, 3000.0, count)
    volume, cross_section = 4.0 / 3.0 * np.pi * radius**3, np.pi * radius**2
    position = rng.uniform(-3.8, 3.8, (3, count))
    lift_normal = np.zeros((3, count))
    lift_normal[2] = 1.0
    return types.SimpleNamespace(
        count=count, position=position, velocity=rng.normal(0.0, 1.0, (3, count)),
        mass=density * volume, radius=radius, volume=volume, cross_section=cross_section,
        drag_coefficient=np.full(count, 0.47), lift_coefficient=np.zeros(count),
        lift_area=cross_section, lift_normal=lift_normal, external_force=np.zeros((3, count)),
        lift_slope=np.full(count, LIFT_SLOPE), stall_angle=np.full(count, STALL_ANGLE))


def scattered_spheres(count, seed=0):
    """scattered_arrays as a Spheres, named, for a Simulation."""
    arrays = scattered_arrays(count, seed)
    return Spheres([f's{i}' for i in range(count)], **{
        name: getattr(arrays, name) for name in (
            'position', 'velocity', 'mass', 'radius', 'drag_coefficient', 'lift_area',
            'lift_normal', 'lift_coefficient', 'external_force', 'lift_slope',
            'stall_angle')})


def default_scene(backend):
    return Scene({'sphere_names': ['s0'], 'effects': list(DEFAULT_EFFECTS),
                  'backend': backend})


def simulation(spheres, backend):
    """A Simulation of the default effects over these spheres on this backend."""
    return Simulation(default_scene(backend), initial_spheres=spheres)


def median_seconds(function, repeats):
    """Median wall seconds of function() over repeats calls (after one not counted)."""
    function()
    samples = []
    for _ in range(repeats):
        start = time.perf_counter()
        function()
        samples.append(time.perf_counter() - start)
    return statistics.median(samples)


def gpu_row(count, repeats):
    """The GPU's figures at `count` spheres. A call of DeviceState.run is a launch, then
    the step guard's count back, which waits for it."""
    device, arrays = DeviceState.for_scene(default_scene('cuda')), scattered_arrays(count)
    one = median_seconds(lambda: device.run(arrays, 1, DT), repeats)
    many = median_seconds(lambda: device.run(arrays, STEPS_PER_LAUNCH, DT),
                          max(1, repeats // 4))
    return {'spheres': count,
            'one_step_per_launch_ns': one / count * 1e9,
            'gigabytes_per_s': BYTES_PER_SPHERE_STEP * count / one / 1e9,
            f'{STEPS_PER_LAUNCH}_steps_per_launch_ns': many / STEPS_PER_LAUNCH / count * 1e9}


def launch_rows(cuda, count, repeats):
    """What one launch of one step costs from Python at `count` spheres, waited for: the
    kernel called with its arguments (kernel[grid, block] makes a launch configuration on
    every call, and numba-cuda types every argument), and a configuration made once."""
    device, arrays = DeviceState.for_scene(default_scene('cuda')), scattered_arrays(count)
    device.run(arrays, 1, DT)
    configured, arguments = device.launch(count, 1, DT)
    grid, block = blocks_for(count), THREADS_PER_BLOCK

    def called():
        device.kernel[grid, block](*arguments)
        cuda.synchronize()

    def preconfigured():
        configured(*arguments)
        cuda.synchronize()
    return [{'launch': 'kernel[grid, block](...)',
             'us': median_seconds(called, repeats) * 1e6},
            {'launch': 'a configuration made once',
             'us': median_seconds(preconfigured, repeats) * 1e6}]


def cpu_row(count, repeats):
    """The CPU step of the same spheres on one core and on every core, ns per sphere-step."""
    row = {'spheres': count}
    sim = simulation(scattered_spheres(count), 'cpu')
    for label, threads in (('cpu_one_core_ns', 1), ('cpu_all_cores_ns', os.cpu_count())):
        stepper.use_threads(min(threads, numba.config.NUMBA_NUM_THREADS))
        sim.reset()
        row[label] = (median_seconds(lambda: sim.run(10, DT), max(1, repeats // 4))
                      / 10 / count * 1e9)
    stepper.use_threads(1)
    return row


def agreement(count, steps):
    """The largest difference (m, m/s) between the two backends after `steps` steps of the
    same spheres."""
    spheres = scattered_spheres(count, seed=3)
    on_cpu, on_gpu = simulation(spheres, 'cpu'), simulation(spheres, 'cuda')
    on_cpu.run(steps, DT)
    on_gpu.run(steps, DT)
    return (float(np.max(np.abs(on_cpu.spheres.position - on_gpu.spheres.position))),
            float(np.max(np.abs(on_cpu.spheres.velocity - on_gpu.spheres.velocity))))


def table(rows, columns):
    """A markdown table of rows' columns (floats to 4 significant figures)."""
    shown = [[f'{row[c]:.4g}' if isinstance(row.get(c), float) else str(row.get(c, '-'))
              for c in columns] for row in rows]
    lines = ['| ' + ' | '.join(columns) + ' |', '|' + '---:|' * len(columns)]
    return '\n'.join(lines + ['| ' + ' | '.join(r) + ' |' for r in shown])


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument('--sizes', type=int, nargs='+',
                        default=[10_000, 1_000_000, 10_000_000, 100_000_000])
    parser.add_argument('--agreement-spheres', type=int, default=AGREEMENT_SPHERES)
    parser.add_argument('--agreement-steps', type=int, default=AGREEMENT_STEPS)
    parser.add_argument('--launch-spheres', type=int, default=10_000)
    parser.add_argument('--repeats', type=int, default=21, help='of each one-step timing')
    parser.add_argument('--solve-sizes', type=int, nargs='*',
                        default=[100_000, 1_000_000])
    parser.add_argument('--solve-repeats', type=int, default=11)
    parser.add_argument('--colliding-sizes', type=int, nargs='*',
                        default=[100_000, 1_000_000])
    parser.add_argument('--colliding-steps', type=int, default=20)
    parser.add_argument('--settle-s', type=float, default=1.0)
    parser.add_argument('--out', default='results/gpu')
    arguments = parser.parse_args()
    cuda = load_cuda()
    device = 'numba CUDA simulator' if simulated() else cuda.get_current_device().name
    device = device.decode() if isinstance(device, bytes) else device
    rows = []
    for count in arguments.sizes:
        row = gpu_row(count, arguments.repeats)
        if count <= CPU_MAX_SPHERES:
            row.update(cpu_row(count, arguments.repeats))
        rows.append(row)
        print(row, flush=True)
    launches = launch_rows(cuda, arguments.launch_spheres, 10 * arguments.repeats)
    print(launches, flush=True)
    position_gap, velocity_gap = agreement(arguments.agreement_spheres,
                                           arguments.agreement_steps)
    out = pathlib.Path(arguments.out)
    out.mkdir(parents=True, exist_ok=True)
    write_csv(rows, out / 'gpu.csv')
    columns = list(rows[0]) + [c for c in ('cpu_one_core_ns', 'cpu_all_cores_ns')
                               if c not in rows[0]]
    command = ('python3 -m benchmarks.gpu --sizes ' + ' '.join(map(str, arguments.sizes))
               + ' --solve-sizes ' + ' '.join(map(str, arguments.solve_sizes))
               + ' --colliding-sizes ' + ' '.join(map(str, arguments.colliding_sizes)))
    text = '\n\n'.join([
        provenance(command) + f' GPU: {device}.',
        f'The default effects ({", ".join(DEFAULT_EFFECTS)}), no collisions; dt {DT} s; '
        'ns per sphere-step, medians. gigabytes_per_s: what the one-step launch reads and '
        f'writes ({BYTES_PER_SPHERE_STEP} B a sphere) over its time.',
        table(rows, columns),
        f'One launch from Python at {arguments.launch_spheres} spheres, one step, waited '
        'for (us):',
        table(launches, ['launch', 'us']),
        f'CPU-GPU agreement: {arguments.agreement_spheres} spheres, '
        f'{arguments.agreement_steps} steps: largest difference {position_gap:.3g} m in '
        f'position, {velocity_gap:.3g} m/s in velocity.'])
    (out / 'gpu.md').write_text(text + '\n')  # before the collisions: kept if they fail
    print(text, flush=True)
    if arguments.colliding_sizes:  # first: the whole step, which needs no CPU's rows
        _, colliding_text = gpu_colliding.measure(
            arguments.colliding_sizes, arguments.colliding_steps, arguments.settle_s, out,
            command)
        text += '\n\n' + colliding_text
        (out / 'gpu.md').write_text(text + '\n')
        print(colliding_text, flush=True)
    if arguments.solve_sizes:
        _, solve_text = gpu_solve.measure(arguments.solve_sizes, arguments.solve_repeats,
                                          gpu_solve.CPU_MAX, out, command)
        (out / 'gpu.md').write_text(text + '\n\n' + solve_text + '\n')
        print(solve_text)


if __name__ == '__main__':
    main()
