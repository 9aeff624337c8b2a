"""DeviceSolve: a step's soft-step substeps and restitution pass (what soft_step.py's
_substeps and restitution_pass do on the CPU) on the GPU, on the rows contact_rows made.

It is the solve stage of the collision pass on the GPU (device_collisions.py), measured and
tested on its own too. solve() takes its support arrays from DeviceOrder.support (the
pass) or from upload() (a Prepared made on the CPU: the tests and benchmarks).
"""
import math

import numpy as np

from ..contacts.colouring import COLOURS
from ..contacts.layers import sweep_waves
from . import compiled, load_cuda, THREADS_PER_BLOCK
from .contact_kernels import CARRY, KERNELS, RESTITUTE, SOLVE

MODES = ('launches', 'cooperative')


def colour_bounds(colour_start):
    """(bounds (k + 1,) int64: where each of the k non-empty colours' slots begin, then the
    end; serial: the index among them of the last colour, whose contacts may share a sphere
    (-1 if it has none)) of colouring.colour_contacts' colour_start."""
    starts = np.asarray(colour_start, dtype=np.int64)
    kept = [c for c in range(COLOURS) if starts[c + 1] > starts[c]]
    bounds = np.array([starts[c] for c in kept] + [starts[COLOURS]], dtype=np.int64)
    serial = kept.index(COLOURS - 1) if COLOURS - 1 in kept else -1
    return bounds, serial


def _threads_for(count):
    """Threads a block for a launch over count items: a warp's multiple, at most
    THREADS_PER_BLOCK (a colour of a few contacts launches few threads)."""
    return min(THREADS_PER_BLOCK, max(32, 32 * math.ceil(count / 32)))


class DeviceSolve:
    """The soft step's substeps and restitution pass on the GPU (contact_kernels.py), in
    either of MODES. run() takes a soft_step.Prepared and returns what the CPU's passes
    leave in it."""

    def __init__(self, mode='cooperative'):
        if mode not in MODES:
            raise ValueError(f'mode must be one of {MODES}, not {mode!r}')
        self.cuda = load_cuda()
        self.mode = mode
        self.kernels = compiled(KERNELS)
        self._configured = {}  # (kernel name, blocks, threads) -> its launch configuration

    def upload(self, ready):
        """The device's copies of a Prepared's arrays (a dict by name)."""
        to_device = self.cuda.to_device
        names = ('rows', 'solve_order', 'velocity', 'moved', 'change', 'inverse_mass',
                 'bounces')
        arrays = {name: to_device(np.ascontiguousarray(getattr(ready, name)))
                  for name in names}
        ends, facts, floor_member, floor_gap = ready.support
        # The support sweep wave by wave: contacts of a wave touch no sphere another writes.
        order, wave_bounds = sweep_waves(ends, ready.sphere.size)
        support = {'ends': ends[order], 'facts': facts[order], 'wave_bounds': wave_bounds,
                   'floor_member': floor_member, 'floor_gap': floor_gap}
        for name, array in support.items():
            arrays[name] = to_device(np.ascontiguousarray(array))
        arrays['supported'] = to_device(np.zeros(ready.sphere.size, dtype=np.bool_))
        return arrays

    def run(self, ready, settings, dt, threshold, restitution):
        """A step's substeps and restitution pass on ready (a soft_step.Prepared; settings,
        dt s, threshold m/s and restitution as soft_step.resolve_collisions has them).
        Returns the (rows, velocity, moved) they leave, host arrays."""
        arrays = self.upload(ready)
        self.solve(arrays, ready.colour_start, settings, dt, threshold, restitution)
        self.cuda.synchronize()
        return tuple(arrays[name].copy_to_host() for name in ('rows', 'velocity', 'moved'))

    def solve(self, arrays, colour_start, settings, dt, threshold, restitution):
        """Enqueues a step's substeps and restitution pass on uploaded arrays."""
        substeps = int(settings[0])
        h = dt / substeps
        scalars = (float(settings[3]), 1.0 / h, float(threshold), float(restitution))
        bounds, serial = colour_bounds(colour_start)
        fastest = self.cuda.to_device(np.zeros(substeps))
        if self.mode == 'cooperative':
            self._cooperative(arrays, bounds, serial, fastest, substeps, h, scalars)
        else:
            self._launches(arrays, bounds, serial, fastest, substeps, h, scalars)

    def _cooperative(self, arrays, bounds, serial, fastest, substeps, h, scalars):
        device = arrays
        arguments = (*(device[name] for name in (
            'rows', 'solve_order', 'velocity', 'moved', 'change', 'inverse_mass', 'bounces')),
            self.cuda.to_device(bounds), serial,
            *(device[name] for name in (
                'ends', 'facts', 'wave_bounds', 'floor_member', 'floor_gap', 'supported')),
            fastest, substeps, h, scalars)
        # Compiled for these arguments' types first: a cooperative grid may be no larger
        # than the compiled kernel's blocks the device holds at once.
        kernel = self.kernels['substeps_kernel'].specialize(*arguments)
        overloads = kernel.overloads
        overload = next(iter(overloads.values()), None) or overloads[None]  # the simulator's
        work = max(device['rows'].shape[0], device['velocity'].shape[0])
        threads = _threads_for(work)
        blocks = min(math.ceil(work / threads),
                     max(1, overload.max_cooperative_grid_blocks(threads)))
        kernel[blocks, threads](*arguments)

    def _launch(self, name, count):
        """Kernel `name` configured for one thread an item over count items (at least
        one), made once per configuration: kernel[blocks, threads] makes one on every call."""
        threads = _threads_for(count)
        key = (name, max(1, math.ceil(count / threads)), threads)
        configured = self._configured.get(key)
        if configured is None:
            configured = self._configured[key] = self.kernels[name][key[1], key[2]]
        return configured

    def _launches(self, arrays, bounds, serial, fastest, substeps, h, scalars):
        device, launch = arrays, self._launch
        velocity, moved, change = device['velocity'], device['moved'], device['change']
        members = velocity.shape[0] - 1

        def colours(kind, use_bias, hold_apart):
            for c in range(bounds.size - 1):
                first, last = int(bounds[c]), int(bounds[c + 1])
                launch('contacts_kernel', 1 if c == serial else last - first)(
                    kind, device['rows'], device['solve_order'], velocity, moved,
                    device['inverse_mass'], device['bounces'], first, last, c == serial,
                    use_bias, hold_apart, scalars)
        waves, floors = device['wave_bounds'].copy_to_host(), device['floor_member'].shape[0]
        # The support sweep's parts: supported cleared, the floor, then wave by wave.
        support_parts = [(0, 0, 0), (1, 0, 0)] + [(2, int(waves[w]), int(waves[w + 1]))
                                                   for w in range(waves.size - 1)]
        for substep in range(substeps):
            launch('members_kernel', members)(False, velocity, change, moved, h)
            colours(CARRY, True, True)
            colours(SOLVE, True, True)
            launch('fastest_kernel', members)(velocity, fastest, substep)
            for part, first, last in support_parts:
                launch('support_kernel', (members, floors, last - first)[part])(
                    part, device['ends'], device['facts'], device['floor_member'],
                    device['floor_gap'], velocity, moved, scalars[1], scalars[2],
                    device['supported'], fastest, substep, first, last)
            launch('members_kernel', members)(True, velocity, change, moved, h)
            colours(SOLVE, False, substep < substeps - 1)
        colours(RESTITUTE, False, False)
