"""DeviceCollisions: the soft step's collision pass (contacts/soft_step.py's
resolve_collisions) on the GPU, every stage of it on device arrays: detection
(device_detect.py), the contacts' indices and rows (device_rows.py), their colouring and
support order (device_order.py), the substeps and restitution pass (device_solve.py), the
contacts remembered and the members written back with the step guard (settle_kernels.py).

It is resolve_collisions with the contacts coloured as colouring.colour_by_priority
colours them (the GPU's order, colouring.py says why): resolve_collisions on the CPU with
its settings' last entry 1 (soft_step.colouring: priority) makes the same step, to the bit
in numba's simulator. The step around it (the smooth step before, the faces of the spheres
in no pair after) is device_steps.py's.
"""
import math

import numpy as np

from ..contacts.soft_step import RESTING_FACTOR
from . import compiled, grid_for, load_cuda
from .device_detect import DeviceDetect, SortLibrary
from .device_order import DeviceOrder
from .device_rows import DeviceRows
from .device_solve import DeviceSolve
from .settle_kernels import KERNELS


def pass_constants(environment, pool, contact, settings, flags, dt):
    """resolve()'s constants of a scene's world (stepper.scene_constants' environment (12,),
    pool (6,), contact (4,) and settings (5,)), flags (has_contact, has_friction, whether
    gravity is listed) and a step of dt s; the resting speed is run_steps', a step's worth
    of gravity, sqrt(g . g) dt."""
    has_contact, has_friction, with_gravity = flags
    gx, gy, gz = (float(g) for g in environment[:3])
    resting_speed = math.sqrt(gx * gx + gy * gy + gz * gz) * dt if with_gravity else 0.0
    return (tuple(map(float, pool)), has_contact, tuple(map(float, contact)), has_friction,
            resting_speed, tuple(map(float, settings)), dt)


class DeviceCollisions:
    """resolve() takes one step's collision pass on device arrays, in place."""

    def __init__(self, mode='cooperative'):
        self.cuda = load_cuda()
        self.library = SortLibrary(self.cuda)
        self.detection = DeviceDetect(self.library)
        self.rows = DeviceRows(self.library)
        self.order = DeviceOrder(self.library)
        self.solver = DeviceSolve(mode)
        self.kernels = compiled(KERNELS)

    def resolve(self, step, spheres, identity, memory, flagged, failed, constants):
        """Find and resolve the step's contacts in place, as soft_step.resolve_collisions
        does: step (old_position, old_velocity, position, velocity), (3, n) device arrays,
        the step's start and the smooth step's end (written: the members' solved ends);
        spheres (mass kg, radius m) (n,); identity (n,) int64; memory (keys, forces, held):
        last step's contacts (memory.contact_memory's arrays), replaced by this step's;
        flagged and failed (n,) uint8 (a member's flag cleared; failed set for a sphere the
        step guard put back); constants: (faces (6,) m, has_faces, contact (4,),
        has_friction, resting_speed m/s, settings (5,), dt s), as resolve_collisions takes
        them. Returns how many spheres the step guard put back."""
        cuda, kernels = self.cuda, self.kernels
        faces, has_faces, contact, has_friction, resting_speed, settings, dt = constants
        mass, radius = spheres
        count = radius.shape[0]
        detected = self.detection.detect(*step, radius, dt) if count >= 2 else None
        if detected is None or detected['pairs'].shape[1] == 0:
            kernels['forget_kernel'][grid_for(count)](memory[2])
            return 0
        threshold = RESTING_FACTOR * resting_speed
        pairs, state = detected['pairs'], detected['state']
        made = self.rows.indices(pairs, detected['order'], state, identity, faces, has_faces)
        members = made['sphere'].shape[0]
        slot, colour_start = self.order.colour(made['ends'], members)
        filled = self.rows.fill((pairs, detected['facts'][:3], state), made, slot, spheres,
                                memory, step, (faces, contact, has_friction, settings, dt,
                                               threshold))
        support = self.order.support(filled['rows'], made['ends'], pairs.shape[1],
                                     made['faces_of'], slot, made['sphere'], step[0], radius)
        arrays = {**filled, **support,
                  'supported': cuda.to_device(np.zeros(members, dtype=np.bool_))}
        self.solver.solve(arrays, colour_start, settings, dt, threshold, contact[0])
        home_start = self.library.starts(made['homes'], made['by_home'], count)
        kernels['remember_kernel'][grid_for(count)](
            filled['rows'], slot, made['keys'], made['homes'], made['by_home'], home_start,
            *memory, float(settings[0]) / dt)
        put_back = cuda.to_device(np.zeros(1, dtype=np.int64))
        kernels['write_back_kernel'][grid_for(members)](
            made['sphere'], filled['moved'], filled['velocity'], step[0], step[2], step[3],
            failed, flagged, put_back)
        return int(put_back.copy_to_host()[0])
