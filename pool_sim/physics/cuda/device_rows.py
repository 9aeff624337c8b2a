"""DeviceRows: the soft step's rows made on the GPU (rows_kernels.py). indices() makes the
members, the face contacts, the keys and the sort by home; fill() fills the members'
velocities and velocity changes, each contact's row and its warm start, the face crossings
and the solve order, from the indices (the colouring has no GPU form yet: the CPU's slots
are given; docs/gpu.md). What they make is what soft_step.contact_rows makes, to the bit in
numba's simulator; DeviceSolve (device_solve.py) takes it from there.
"""
import math

import numpy as np

from ..contacts.soft_contact import COLUMNS
from . import load_cuda
from .device_detect import SortLibrary
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
        self.library = SortLibrary(self.cuda)

    def indices(self, pairs, order, state, identity, faces, has_faces):
        """{sphere, row_of, state_row, faces_of, ends, keys, homes, by_home}: device arrays
        as soft_step.contact_rows makes them (soft_rows.members_of, face_contacts,
        contact_keys, the sort by home), from detection's pairs, order and state on the
        device, identity (n,) int64 there, faces (6,) m and has_faces."""
        cuda, kernels, count = self.cuda, self.kernels, order.shape[0]
        found = pairs.shape[1]
        row_of = cuda.to_device(np.full(count, -1, dtype=np.int64))
        kernels['mark_members_kernel'][_grid(found)](pairs, row_of)
        flags = cuda.device_array(count, dtype=np.int64)
        kernels['flag_members_kernel'][_grid(count)](row_of, flags)
        offsets, members = self.library.offsets(flags)
        sphere = cuda.device_array(members, dtype=np.int64)
        state_row = cuda.device_array(members, dtype=np.int64)
        kernels['place_members_kernel'][_grid(count)](row_of, offsets, order, sphere, state_row)
        counts = cuda.to_device(np.zeros(members, dtype=np.int64))
        nothing = cuda.device_array((0, 2), dtype=np.int64)
        if has_faces:
            kernels['faces_kernel'][_grid(members)](state_row, state, faces, counts, counts,
                                                    nothing)
        face_offsets, face_count = self.library.offsets(counts)
        faces_of = cuda.device_array((face_count, 2), dtype=np.int64)
        if face_count:
            kernels['faces_kernel'][_grid(members)](state_row, state, faces, counts,
                                                    face_offsets, faces_of)
        total = found + face_count
        ends = cuda.device_array((total, 2), dtype=np.int64)
        keys, homes = (cuda.device_array(total, dtype=np.int64) for _ in range(2))
        kernels['keys_kernel'][_grid(total)](pairs, faces_of, row_of, sphere, identity, ends,
                                             keys, homes)
        by_home = self.library.stable_order(homes)
        return {'sphere': sphere, 'row_of': row_of, 'state_row': state_row,
                'faces_of': faces_of, 'ends': ends, 'keys': keys, 'homes': homes,
                'by_home': by_home}

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
