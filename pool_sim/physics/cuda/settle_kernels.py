"""The end of the soft step's collision pass on the GPU (device_collisions.py): the
contacts remembered for the next step's warm start (soft_rows.remember_range, one thread
a home row, its contacts in the CPU's order) and each member written back with the step
guard (soft_step.write_members, one thread a member: a member's sphere is its own).
"""
from ..contacts.soft_rows import remember_range
from ..contacts.soft_step import write_members
from . import load_cuda

# A global, not a local: numba's CUDA simulator swaps each thread's `cuda` into the
# kernel's globals.
cuda = load_cuda()


def remember_kernel(rows, slot, keys, homes, by_home, home_start, memory_keys,
                    memory_forces, memory_held, per_second):
    """Each home row's memory emptied, then its contacts (by_home[home_start[h]:
    home_start[h + 1]], in order) remembered, as soft_rows.remember does row by row."""
    home = cuda.grid(1)
    if home < memory_held.size:
        memory_held[home] = 0
        remember_range(rows, slot, keys, homes, by_home, memory_keys, memory_forces,
                       memory_held, per_second, home_start[home], home_start[home + 1])


def forget_kernel(memory_held):
    """No contacts this step: nothing remembered."""
    home = cuda.grid(1)
    if home < memory_held.size:
        memory_held[home] = 0


def write_back_kernel(sphere, moved, velocity_rows, old_position, position, velocity,
                      failed, flagged, put_back):
    """Each member's solved path into its sphere (soft_step.write_members); put_back[0]:
    += the spheres the step guard put back (an integer sum: the same in any order)."""
    k = cuda.grid(1)
    if k < sphere.size and write_members(sphere, moved, velocity_rows, old_position,
                                         position, velocity, failed, flagged, k, k + 1, 1):
        cuda.atomic.add(put_back, 0, 1)


KERNELS = (remember_kernel, forget_kernel, write_back_kernel)
