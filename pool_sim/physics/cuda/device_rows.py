"""DeviceRows: the soft step's rows filled on the GPU (rows_kernels.py) - the members'
velocities and velocity changes, each contact's row and its warm start, the face crossings
and the solve order - from the contacts' indices the CPU made (soft_step.contact_rows: the
members, face contacts, keys, the sort by home and the colouring, which have no GPU form
yet: docs/gpu.md). What it fills is what contact_rows fills, to the bit in numba's
simulator; DeviceSolve (device_solve.py) takes it from there.
"""
import math

import numpy as np

from ..contacts.soft_contact import COLUMNS
from . import load_cuda
from .rows_kernels import KERNELS

THREADS_PER_BLOCK = 128
INDICES = ('sphere', 'state_row', 'faces_of', 'slot', 'keys', 'homes', 'by_home')


def _grid(count):
    """(blocks, threads) of a launch of one thread an item over count items."""
    return max(1, math.ceil(count / THREADS_PER_BLOCK)), THREADS_PER_BLOCK


class DeviceRows:
    """fill() makes a step's rows on the GPU."""

    _compiled = {}  # kernel name -> the kernel, shared by every DeviceRows

    def __init__(self):
        self.cuda = load_cuda()
        for kernel in KERNELS:
            if kernel.__name__ not in self._compiled:
                self._compiled[kernel.__name__] = self.cuda.jit(kernel)
        self.kernels = self._compiled

    def fill(self, detected, indices, spheres, memory, step, constants):
        """{rows, velocity, moved, change, inverse_mass, bounces, solve_order}: device
        arrays as soft_step.contact_rows' Prepared has them. detected: detection's pairs,
        normal (3, m) and state on the device (Contacts' arrays, device_detect's);
        indices: the Prepared's INDICES (host arrays); spheres: (mass, radius) (n,)
        device arrays; memory: (keys, forces, held), last step's, on the device; step:
        (old_position, old_velocity, position, velocity) (3, n) device arrays; constants:
        (faces (6,), contact (4,), has_friction, settings (4,), dt s, threshold m/s) as
        contact_rows takes them."""
        cuda, kernels = self.cuda, self.kernels
        index = {name: cuda.to_device(np.ascontiguousarray(indices[name]))
                 for name in INDICES}
        pairs, normal, state = detected
        mass, radius = spheres
        faces, contact, has_friction, settings, dt, threshold = constants
        members, total = indices['sphere'].size, indices['slot'].size
        # Each contact's two member rows, the ground (members) last for a face.
        ends = np.empty((total, 2), dtype=np.int64)
        found = total - indices['faces_of'].shape[0]
        ends[:found] = np.searchsorted(indices['state_row'], _host(pairs).T)
        ends[found:, 0], ends[found:, 1] = indices['faces_of'][:, 0], members
        ends = cuda.to_device(ends)
        velocity, moved, change = (cuda.to_device(np.zeros((members + 1, 4)))
                                   for _ in range(3))
        inverse_mass = cuda.to_device(np.zeros(members + 1))
        kernels['body_kernel'][_grid(members)](
            index['sphere'], index['state_row'], state, mass, float(settings[0]), velocity,
            change, inverse_mass)
        rows = cuda.device_array((total, COLUMNS))
        bounces = cuda.device_array(total, dtype=np.bool_)
        kernels['fill_kernel'][_grid(total)](
            rows, index['slot'], ends, pairs, normal, state, index['faces_of'],
            index['state_row'], inverse_mass, mass, index['sphere'], faces, contact,
            has_friction, settings, dt, threshold, bounces)
        kernels['warm_kernel'][_grid(total)](
            rows, index['slot'], index['keys'], index['homes'], index['by_home'], *memory,
            ends, index['sphere'], radius, settings, dt)
        face_start = cuda.to_device(np.searchsorted(indices['faces_of'][:, 0],
                                                    np.arange(members + 1)))
        kernels['crossings_kernel'][_grid(members)](
            change, index['faces_of'], face_start, index['sphere'], *step, radius, faces,
            float(settings[0]), dt)
        solve_order = cuda.device_array((total, 2), dtype=np.int64)
        kernels['order_kernel'][_grid(total)](index['slot'], ends, solve_order)
        return {'rows': rows, 'velocity': velocity, 'moved': moved, 'change': change,
                'inverse_mass': inverse_mass, 'bounces': bounces, 'solve_order': solve_order}


def _host(array):
    """A device array's contents on the host (a host array as it is)."""
    return array.copy_to_host() if hasattr(array, 'copy_to_host') else np.asarray(array)
