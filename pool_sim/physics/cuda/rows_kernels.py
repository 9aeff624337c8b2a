"""The soft step's rows made on the GPU (device_rows.py), from the CPU's own loops over a
range with a stride (contacts/soft_rows.py's member_faces, pair_keys, face_keys,
fill_body_rows, fill_row_range and warm_start_range, face_crossing.py's
bound_crossing_range): each thread takes its share of members or contacts, which write only
their own rows, so no atomics and the CPU's numbers. The members are a compaction (marked,
then placed at their offsets: the CPU's order).
"""
from ..contacts.face_crossing import bound_crossing_range
from ..contacts.soft_rows import face_keys, fill_body_rows, fill_row_range, member_faces, \
    pair_keys, warm_start_range
from . import load_cuda

# A global, not a local: numba's CUDA simulator swaps each thread's `cuda` into the
# kernel's globals.
cuda = load_cuda()


def mark_members_kernel(pairs, row_of):
    """row_of (n,) -1 but 0 for each sphere (state row) in a pair: many threads may write a
    sphere's 0."""
    c = cuda.grid(1)
    if c < pairs.shape[1]:
        row_of[pairs[0, c]], row_of[pairs[1, c]] = 0, 0


def flag_members_kernel(row_of, flags):
    """flags (n,) int64: 1 for each state row in a pair."""
    k = cuda.grid(1)
    if k < row_of.size:
        flags[k] = 1 if row_of[k] == 0 else 0


def place_members_kernel(row_of, offsets, order, sphere, state_row):
    """Each state row in a pair made a member, at its offset (soft_rows.members_of)."""
    k = cuda.grid(1)
    if k < row_of.size and row_of[k] == 0:
        m = offsets[k]
        row_of[k] = m
        sphere[m], state_row[m] = order[k], k


def faces_kernel(state_row, state, faces, counts, offsets, faces_of):
    """Each member's face contacts: counted into counts while faces_of is empty (the count
    pass), else written into faces_of at its offset."""
    k = cuda.grid(1)
    if k < state_row.size:
        if faces_of.shape[0] == 0:
            counts[k] = member_faces(state_row, state, faces, k, k + 1, 1, faces_of, 0)
        else:
            member_faces(state_row, state, faces, k, k + 1, 1,
                         faces_of[offsets[k]:offsets[k] + counts[k]], 0)


def keys_kernel(pairs, faces_of, row_of, sphere, identity, ends, keys, homes):
    """Each contact's ends, key and home (soft_rows.contact_keys): the pairs, then the
    faces."""
    thread, threads, found = cuda.grid(1), cuda.gridsize(1), pairs.shape[1]
    pair_keys(pairs, row_of, sphere, identity, ends, keys, homes, thread, found, threads)
    face_keys(faces_of, sphere, identity, found, sphere.size, ends, keys, homes, thread,
              faces_of.shape[0], threads)


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


KERNELS = (mark_members_kernel, flag_members_kernel, place_members_kernel, faces_kernel,
           keys_kernel, body_kernel, fill_kernel, warm_kernel, crossings_kernel, order_kernel)
