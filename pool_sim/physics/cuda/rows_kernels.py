"""The soft step's rows filled on the GPU (device_rows.py), from the CPU's own loops over a
range with a stride (contacts/soft_rows.py's fill_body_rows, fill_row_range and
warm_start_range, face_crossing.py's bound_crossing_range): each thread takes its share of
members or contacts, which write only their own rows, so no atomics and the CPU's numbers.
"""
from ..contacts.face_crossing import bound_crossing_range
from ..contacts.soft_rows import fill_body_rows, fill_row_range, warm_start_range
from . import load_cuda

# A global, not a local: numba's CUDA simulator swaps each thread's `cuda` into the
# kernel's globals.
cuda = load_cuda()


def body_kernel(sphere, state_row, state, mass, substeps, velocity_rows, change,
                inverse_mass):
    """Each member's velocity, velocity change per substep and inverse mass."""
    fill_body_rows(sphere, state_row, state, mass, substeps, velocity_rows, change,
                   inverse_mass, cuda.grid(1), sphere.size, cuda.gridsize(1))


def fill_kernel(rows, slot, ends, pairs, normal, state, faces_of, state_row, inverse_mass,
                mass, sphere, faces, contact, has_friction, settings, dt, threshold, bounces):
    """Each contact's row at its slot (soft_rows.fill_rows)."""
    fill_row_range(rows, slot, ends, pairs, normal, state, faces_of, state_row, inverse_mass,
                   mass, sphere, faces, contact, has_friction, settings, dt, threshold,
                   bounces, cuda.grid(1), ends.shape[0], cuda.gridsize(1))


def warm_kernel(rows, slot, keys, homes, by_home, memory_keys, memory_forces, memory_held,
                ends, sphere, radius, settings, dt):
    """Last step's forces into the rows of the contacts that persist (soft_rows.warm_start):
    a contact reads its home's memory row and writes its own row."""
    warm_start_range(rows, slot, keys, homes, by_home, memory_keys, memory_forces,
                     memory_held, ends, sphere, radius, settings, dt, cuda.grid(1), keys.size,
                     cuda.gridsize(1))


def crossings_kernel(change, faces_of, face_start, sphere, old_position, old_velocity,
                     position, velocity, radius, faces, substeps, dt):
    """Each member's face crossings (face_crossing.bound_face_crossings), its faces
    face_start[k]..face_start[k + 1] - 1 in order, by one thread: they share its change."""
    k = cuda.grid(1)
    if k < face_start.size - 1:
        bound_crossing_range(change, faces_of, sphere, old_position, old_velocity, position,
                             velocity, radius, faces, substeps, dt, face_start[k],
                             face_start[k + 1], 1)


def order_kernel(slot, ends, solve_order):
    """Each slot's two member rows (soft_step.contact_rows' solve_order)."""
    c = cuda.grid(1)
    if c < slot.size:
        solve_order[slot[c], 0], solve_order[slot[c], 1] = ends[c, 0], ends[c, 1]


KERNELS = (body_kernel, fill_kernel, warm_kernel, crossings_kernel, order_kernel)
