"""DeviceRows: the soft step's rows made on the GPU (rows_kernels.py). indices() makes the
members, the face contacts, the keys and the sort by home; fill() fills the members'
velocities and velocity changes, each contact's row and its warm start, the face crossings
and the solve order, from those indices and a colouring's slots (DeviceOrder.colour's,
device_order.py). Given the same slots, what they make is what soft_step.contact_rows
makes, to the bit in numba's simulator; DeviceSolve (device_solve.py) takes it from there.
"""
import numpy as np

from ..contacts.soft_contact import COLUMNS
from . import compiled, grid_for, load_cuda
from .device_detect import SortLibrary
from .rows_kernels import KERNELS


class DeviceRows:
    """indices() then fill() make a step's rows on the GPU."""

    def __init__(self, library=None):
        self.cuda = load_cuda()
        self.kernels = compiled(KERNELS)
        self.library = library or SortLibrary(self.cuda)

    def indices(self, pairs, order, state, identity, faces, has_faces):
        """{sphere, row_of, state_row, faces_of, face_start, ends, keys, homes, by_home}:
        device arrays as soft_step.contact_rows makes them (soft_rows.members_of,
        face_contacts, contact_keys, the sort by home; face_start (members + 1,): where each
        member's face contacts begin in faces_of), from detection's pairs, order and state on
        the device, identity (n,) int64 there, faces (6,) m and has_faces."""
        cuda, kernels, count = self.cuda, self.kernels, order.shape[0]
        found = pairs.shape[1]
        row_of = cuda.to_device(np.full(count, -1, dtype=np.int64))
        kernels['mark_members_kernel'][grid_for(found)](pairs, row_of)
        flags = cuda.device_array(count, dtype=np.int64)
        kernels['flag_members_kernel'][grid_for(count)](row_of, flags)
        offsets, members = self.library.offsets(flags)
        sphere = cuda.device_array(members, dtype=np.int64)
        state_row = cuda.device_array(members, dtype=np.int64)
        kernels['place_members_kernel'][grid_for(count)](row_of, offsets, order, sphere,
                                                         state_row)
        counts = cuda.to_device(np.zeros(members, dtype=np.int64))
        nothing = cuda.device_array((0, 2), dtype=np.int64)
        if has_faces:
            kernels['faces_kernel'][grid_for(members)](state_row, state, faces, counts, counts,
                                                       nothing)
        face_start, face_count = self.library.offsets(counts)
        faces_of = cuda.device_array((face_count, 2), dtype=np.int64)
        if face_count:
            kernels['faces_kernel'][grid_for(members)](state_row, state, faces, counts,
                                                       face_start, faces_of)
        total = found + face_count
        ends = cuda.device_array((total, 2), dtype=np.int64)
        keys, homes = (cuda.device_array(total, dtype=np.int64) for _ in range(2))
        kernels['keys_kernel'][grid_for(total)](pairs, faces_of, row_of, sphere, identity,
                                                ends, keys, homes)
        by_home = self.library.stable_order(homes)
        return {'sphere': sphere, 'row_of': row_of, 'state_row': state_row,
                'faces_of': faces_of, 'face_start': face_start, 'ends': ends, 'keys': keys,
                'homes': homes, 'by_home': by_home}

    def fill(self, detected, made, slot, spheres, memory, step, constants):
        """{rows, velocity, moved, change, inverse_mass, bounces, solve_order}: device
        arrays as soft_step.contact_rows' Prepared has them. detected: detection's pairs,
        normal (3, m) and state on the device (Contacts' arrays, device_detect's); made:
        indices()'s; slot (contacts,) int64: each contact's place in the sweep (on the
        device, DeviceOrder.colour's; or on the host, a colouring's); spheres: (mass,
        radius) (n,) device arrays; memory: (keys, forces, held), last step's, on the
        device; step: (old_position, old_velocity, position, velocity) (3, n) device
        arrays; constants: (faces (6,), contact (4,), has_friction, settings (5,), dt s,
        threshold m/s) as contact_rows takes them."""
        cuda, kernels = self.cuda, self.kernels
        if not hasattr(slot, 'copy_to_host'):  # a host array
            slot = cuda.to_device(np.ascontiguousarray(slot, dtype=np.int64))
        pairs, normal, state = detected
        mass, radius = spheres
        faces, contact, has_friction, settings, dt, threshold = constants
        sphere, state_row, faces_of, ends = (made[name] for name in (
            'sphere', 'state_row', 'faces_of', 'ends'))
        members, total = sphere.shape[0], slot.shape[0]
        velocity, moved, change = (cuda.to_device(np.zeros((members + 1, 4)))
                                   for _ in range(3))
        inverse_mass = cuda.to_device(np.zeros(members + 1))
        kernels['body_kernel'][grid_for(members)](
            sphere, state_row, state, mass, float(settings[0]), velocity, change, inverse_mass)
        rows = cuda.device_array((total, COLUMNS))
        bounces = cuda.device_array(total, dtype=np.bool_)
        kernels['fill_kernel'][grid_for(total)](
            rows, slot, ends, pairs, normal, state, faces_of, state_row, inverse_mass, mass,
            sphere, faces, contact, has_friction, settings, dt, threshold, bounces)
        kernels['warm_kernel'][grid_for(total)](
            rows, slot, made['keys'], made['homes'], made['by_home'], *memory, ends, sphere,
            radius, settings, dt)
        kernels['crossings_kernel'][grid_for(members)](
            change, faces_of, made['face_start'], sphere, *step, radius, faces,
            float(settings[0]), dt)
        solve_order = cuda.device_array((total, 2), dtype=np.int64)
        kernels['order_kernel'][grid_for(total)](slot, ends, solve_order)
        return {'rows': rows, 'velocity': velocity, 'moved': moved, 'change': change,
                'inverse_mass': inverse_mass, 'bounces': bounces, 'solve_order': solve_order}
