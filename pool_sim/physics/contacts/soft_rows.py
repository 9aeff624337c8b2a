"""The rows soft_step.py solves on, made each step from detection's Contacts and carried
to the next through the memory (memory.py): a row per sphere in a pair (a member), in
detection's cell order, and a row per contact (soft_contact.COLUMNS), at its colour's slot.

The rows are filled from detection's state (a member's row there: the step's start and the
smooth step's end, the radius), in cell order like the members, which detection has just
written: 10 000 spheres at rest, 118 against 181 µs a step read from the spheres' own
arrays (in node_rate's scene 266 against 339). Later passes read the spheres' arrays,
which stay in cache where the state (16 columns a sphere) does not.
"""
import math

import numba
import numpy as np

from .detection import take, END_POSITION, END_VELOCITY, RADIUS, START_POSITION, \
    START_VELOCITY
from .memory import CONTACTS_PER_SPHERE, remembered_slot
from .soft_contact import APPROACH, BIAS_RATE, FX, FY, FZ, GAP, IMPULSE_SCALE, MASS, \
    MASS_SCALE, MU_K, MU_S, NORMAL, NX, NY, NZ, may_bounce, soft_coefficients

# The contact's own frequency is held below this fraction of the substep rate (Box2D's
# quarter): stiffer than that an implicit spring only rings.
MOST_HZ_PER_SUBSTEP_RATE = 0.25
# A face is a contact of a sphere's within this fraction of its radius of its path.
_FACE_REACH = 0.5
# A contact stiffens with the load it carried last step, up to a quarter of the substep
# rate, toward the spring that load would press no more than this fraction of the smaller
# radius: at 120 Hz a column of heavy spheres on a light one sank 21 % of its radius into
# it (10 000 spheres landing), at the quarter 7.6 %. Real contacts stiffen under load too
# (Hertz: F ~ d^1.5). Beyond the quarter (twice it, tried) the landed pile jittered: rms
# 0.12 m/s after 10 s against 0.01.
LOADED_OVERLAP = 0.002
# Identity keys: the pair's identities in the high and low 32 bits (smaller first); a
# sphere and a face: its identity, then _FACE_KEY + the face (0-5: low x, y, z, high).
_FACE_KEY = (1 << 32) - 8


@numba.njit(error_model='numpy')
def members_of(pairs, order, count, wholes, used_whole):
    """(sphere (members,) int64: the sphere of each member row, in cell order; row_of (n,)
    int64: detection's state row -> member row (-1: in no pair); state_row (members,)
    int64: each member's row of detection's state; used wholes)."""
    row_of, used_whole = take(wholes, used_whole, count)
    row_of[:] = -1
    for c in range(pairs.shape[1]):
        row_of[pairs[0, c]], row_of[pairs[1, c]] = 0, 0
    sphere, used_whole = take(wholes, used_whole, count)
    state_row, used_whole = take(wholes, used_whole, count)
    members = 0
    for k in range(count):
        if row_of[k] == 0:
            row_of[k] = members
            sphere[members], state_row[members] = order[k], k
            members += 1
    return sphere[:members], row_of, state_row[:members], used_whole


@numba.njit(error_model='numpy')
def face_contacts(state_row, state, faces, has_faces, found):
    """(faces_of (f, 2) int64: each face contact's member row and face 0-5; found + f): the
    faces within _FACE_REACH of a radius of a member's path (start or smooth end)."""
    members = state_row.size
    faces_of = np.empty((6 * members if has_faces else 0, 2), dtype=np.int64)
    f = member_faces(state_row, state, faces, 0, members if has_faces else 0, 1, faces_of, 0)
    return faces_of[:f], found + f


# member_faces, pair_keys and face_keys, like the fills below, take a range with a stride:
# a GPU thread (physics/cuda/rows_kernels.py) takes its share with the CPU's loop.
@numba.njit(error_model='numpy')
def member_faces(state_row, state, faces, start, stop, step, out, f):
    """The face contacts (member row, face) of members start, start + step, ... below stop,
    written into out (rows, 2) from row f on, as many as fit; returns f past them all."""
    for k in range(start, stop, step):
        r = state[state_row[k], RADIUS]
        for axis in range(3):
            first = state[state_row[k], START_POSITION + axis]
            last = state[state_row[k], END_POSITION + axis]
            if min(first, last) - r - faces[axis] < _FACE_REACH * r:
                if f < out.shape[0]:
                    out[f, 0], out[f, 1] = k, axis
                f += 1
            if faces[axis + 3] - r - max(first, last) < _FACE_REACH * r:
                if f < out.shape[0]:
                    out[f, 0], out[f, 1] = k, axis + 3
                f += 1
    return f


@numba.njit(error_model='numpy')
def contact_keys(pairs, faces_of, row_of, sphere, identity, total, wholes, used_whole):
    """(ends (total, 2) int64: each contact's two member rows, the faces' second the ground
    (a row past the members); keys (total,) int64: its identity key; homes (total,) int64:
    the memory's row it belongs to, the sphere with the smaller identity; used wholes): the
    pairs first, then faces_of's."""
    found, ground = pairs.shape[1], sphere.size
    ends, used_whole = take(wholes, used_whole, 2 * total)
    ends = ends.reshape((total, 2))
    keys, used_whole = take(wholes, used_whole, total)
    homes, used_whole = take(wholes, used_whole, total)
    pair_keys(pairs, row_of, sphere, identity, ends, keys, homes, 0, found, 1)
    face_keys(faces_of, sphere, identity, found, ground, ends, keys, homes, 0, total - found, 1)
    return ends, keys, homes, used_whole


@numba.njit(error_model='numpy')
def pair_keys(pairs, row_of, sphere, identity, ends, keys, homes, start, stop, step):
    """contact_keys for pairs start, start + step, ... below stop."""
    for c in range(start, stop, step):
        a, b = row_of[pairs[0, c]], row_of[pairs[1, c]]
        ends[c, 0], ends[c, 1] = a, b
        i, j = sphere[a], sphere[b]
        lower = i if identity[i] < identity[j] else j
        keys[c] = (identity[lower] << 32) | identity[i + j - lower]
        homes[c] = lower


@numba.njit(error_model='numpy')
def face_keys(faces_of, sphere, identity, found, ground, ends, keys, homes, start, stop, step):
    """contact_keys for face contacts start, start + step, ... below stop (contacts found +
    those)."""
    for f in range(start, stop, step):
        c, i = found + f, sphere[faces_of[f, 0]]
        ends[c, 0], ends[c, 1] = faces_of[f, 0], ground
        keys[c] = (identity[i] << 32) | (_FACE_KEY + faces_of[f, 1])
        homes[c] = i


@numba.njit(error_model='numpy')
def fill_rows(rows, slot, ends, contacts, faces_of, state_row, inverse_mass, mass, sphere,
              faces, contact, has_friction, settings, dt, threshold, bounces):
    """Each contact's row (the COLUMNS) at its slot, from the step's start (detection's
    state); impulses zero and the scene's spring (warm_start puts last step's impulses
    in). inverse_mass: body_rows'. bounces (contacts,) bool, by slot: whether the
    restitution pass looks at the contact (soft_contact.restitute_contact's first test, on
    its approach: faster than threshold m/s, or not a number), so that it reads those
    rows only."""
    fill_row_range(rows, slot, ends, contacts.pairs, contacts.normal, contacts.state,
                   faces_of, state_row, inverse_mass, mass, sphere, faces, contact,
                   has_friction, settings, dt, threshold, bounces, 0, ends.shape[0], 1)


# fill_row_range, warm_start_range and fill_body_rows take a range with a stride, so that a
# GPU thread (physics/cuda/rows_kernels.py) fills its share with the loop the CPU runs.
@numba.njit(error_model='numpy')
def fill_row_range(rows, slot, ends, pairs, normal, state, faces_of, state_row, inverse_mass,
                   mass, sphere, faces, contact, has_friction, settings, dt, threshold, bounces,
                   start, stop, step):
    """fill_rows for contacts start, start + step, ... below stop (detection's pairs,
    normal and state as Contacts has them)."""
    found = pairs.shape[1]
    h = dt / settings[0]
    soft = soft_coefficients(min(settings[1], MOST_HZ_PER_SUBSTEP_RATE / h), settings[2], h)
    mu_s = contact[1] if has_friction else 0.0
    mu_k = contact[2] if has_friction else 0.0
    rolling = contact[3] if has_friction else 0.0
    for c in range(start, stop, step):
        s = slot[c]
        rows[s, :] = 0.0
        if c < found:
            i, j = pairs[0, c], pairs[1, c]  # rows of state
            nx, ny, nz = normal[0, c], normal[1, c], normal[2, c]
            rows[s, GAP] = ((state[i, START_POSITION] - state[j, START_POSITION]) * nx
                            + (state[i, START_POSITION + 1] - state[j, START_POSITION + 1]) * ny
                            + (state[i, START_POSITION + 2] - state[j, START_POSITION + 2]) * nz
                            - state[i, RADIUS] - state[j, RADIUS])
            rows[s, MASS] = 1.0 / (inverse_mass[ends[c, 0]] + inverse_mass[ends[c, 1]])
            rows[s, APPROACH] = (
                (state[i, START_VELOCITY] - state[j, START_VELOCITY]) * nx
                + (state[i, START_VELOCITY + 1] - state[j, START_VELOCITY + 1]) * ny
                + (state[i, START_VELOCITY + 2] - state[j, START_VELOCITY + 2]) * nz)
            rows[s, MU_S], rows[s, MU_K] = mu_s, mu_k
        else:
            k, face = faces_of[c - found, 0], faces_of[c - found, 1]
            i, axis = state_row[k], face % 3
            inward = 1.0 if face < 3 else -1.0  # the face's normal, into the pool
            nx, ny, nz = (inward if axis == 0 else 0.0, inward if axis == 1 else 0.0,
                          inward if axis == 2 else 0.0)
            at = state[i, START_POSITION + axis]
            rows[s, GAP] = (at - state[i, RADIUS] - faces[axis] if face < 3
                            else faces[face] - state[i, RADIUS] - at)
            rows[s, MASS] = mass[sphere[k]]
            rows[s, APPROACH] = inward * state[i, START_VELOCITY + axis]
            # Rolling resistance on a face, as the per-sphere face rule has it.
            rows[s, MU_S], rows[s, MU_K] = mu_s, mu_k + rolling
        rows[s, NX], rows[s, NY], rows[s, NZ] = nx, ny, nz
        rows[s, BIAS_RATE], rows[s, MASS_SCALE], rows[s, IMPULSE_SCALE] = soft
        bounces[s] = may_bounce(rows, s, threshold)


@numba.njit(error_model='numpy')
def warm_start(rows, slot, keys, homes, by_home, memory_keys, memory_forces, memory_held,
               ends, sphere, radius, settings, dt):
    """Last step's forces (memory_*: each key looked up in its home row, the contacts in
    by_home's order) into the rows of the contacts that persist, as impulses over this
    step's substep, friction turned into the new tangent plane, the spring stiffened if
    that load would press it more than LOADED_OVERLAP (ends, sphere, radius: for the
    smaller radius; the spheres' own radius (n,) m, which stays in cache where detection's
    state, 16 times its size, does not)."""
    warm_start_range(rows, slot, keys, homes, by_home, memory_keys, memory_forces,
                     memory_held, ends, sphere, radius, settings, dt, 0, keys.size, 1)


@numba.njit(error_model='numpy')
def warm_start_range(rows, slot, keys, homes, by_home, memory_keys, memory_forces,
                     memory_held, ends, sphere, radius, settings, dt, start, stop, step):
    """warm_start for the contacts by_home[start], by_home[start + step], ... below stop."""
    h = dt / settings[0]
    ground = sphere.size
    for q in range(start, stop, step):
        c = by_home[q]
        home = homes[c]
        j = remembered_slot(memory_keys, memory_held, home, keys[c])
        if j < 0:
            continue
        s = slot[c]
        nx, ny, nz = rows[s, NX], rows[s, NY], rows[s, NZ]
        normal = memory_forces[home, j, 0]
        fx, fy, fz = (memory_forces[home, j, 1] * h, memory_forces[home, j, 2] * h,
                      memory_forces[home, j, 3] * h)
        along = fx * nx + fy * ny + fz * nz
        rows[s, NORMAL] = normal * h
        rows[s, FX], rows[s, FY], rows[s, FZ] = (fx - along * nx, fy - along * ny,
                                                 fz - along * nz)
        a, b = ends[c, 0], ends[c, 1]
        smaller = radius[sphere[a]] if b == ground else min(radius[sphere[a]],
                                                            radius[sphere[b]])
        # The frequency whose spring the load presses LOADED_OVERLAP x smaller.
        needed = math.sqrt(max(normal, 0.0) / (
            rows[s, MASS] * LOADED_OVERLAP * smaller)) / (2.0 * math.pi)
        most = MOST_HZ_PER_SUBSTEP_RATE / h
        if needed > min(settings[1], most):
            soft = soft_coefficients(min(needed, most), settings[2], h)
            rows[s, BIAS_RATE], rows[s, MASS_SCALE], rows[s, IMPULSE_SCALE] = soft


@numba.njit(error_model='numpy')
def remember(rows, slot, keys, homes, by_home, memory_keys, memory_forces, memory_held,
             settings, dt):
    """This step's contacts as forces (N) in memory_* for the next step, each in its home
    row, in contact order (by_home's: contacts of one home in the order they come; as
    many as a row holds: the rest start from none)."""
    memory_held[:] = 0
    remember_range(rows, slot, keys, homes, by_home, memory_keys, memory_forces, memory_held,
                   settings[0] / dt, 0, keys.size)


@numba.njit(error_model='numpy')
def remember_range(rows, slot, keys, homes, by_home, memory_keys, memory_forces,
                   memory_held, per_second, first, last):
    """remember's contacts by_home[first:last], in order: each as forces (N: its impulses
    x per_second) in the next free slot of its home row, if the row has one, and if they
    are finite (a step the guard undid leaves no NaN to warm-start the next one with). (A
    GPU thread takes one home row's range.)"""
    for q in range(first, last):
        c = by_home[q]
        home = homes[c]
        k = memory_held[home]
        s = slot[c]
        normal, fx = rows[s, NORMAL] * per_second, rows[s, FX] * per_second
        fy, fz = rows[s, FY] * per_second, rows[s, FZ] * per_second
        # v * 0 is 0 for a finite v, NaN otherwise (step_guard.finite's test).
        if k == CONTACTS_PER_SPHERE or (normal * 0.0 + fx * 0.0 + fy * 0.0
                                        + fz * 0.0) != 0.0:
            continue
        memory_keys[home, k] = keys[c]
        memory_forces[home, k, 0] = normal
        memory_forces[home, k, 1] = fx
        memory_forces[home, k, 2] = fy
        memory_forces[home, k, 3] = fz
        memory_held[home] = k + 1


@numba.njit(error_model='numpy')
def body_rows(sphere, state_row, state, mass, settings, reals, used_real):
    """(velocity (rows, 4) m/s from the step's start, moved (rows, 4) m since it,
    change (rows, 4) m/s: the smooth step's velocity change per substep, inverse_mass
    (rows,) 1/kg) for the members and, last, the ground (at rest, no inverse mass)."""
    members = sphere.size
    block, used_real = take(reals, used_real, 13 * (members + 1))
    velocity_rows = block[:4 * (members + 1)].reshape((members + 1, 4))
    moved = block[4 * (members + 1):8 * (members + 1)].reshape((members + 1, 4))
    change = block[8 * (members + 1):12 * (members + 1)].reshape((members + 1, 4))
    inverse_mass = block[12 * (members + 1):]
    velocity_rows[:, :] = 0.0
    moved[:, :] = 0.0
    change[:, :] = 0.0
    inverse_mass[members] = 0.0
    fill_body_rows(sphere, state_row, state, mass, settings[0], velocity_rows, change,
                   inverse_mass, 0, members, 1)
    return velocity_rows, moved, change, inverse_mass


@numba.njit(error_model='numpy')
def fill_body_rows(sphere, state_row, state, mass, substeps, velocity_rows, change,
                   inverse_mass, start, stop, step):
    """body_rows' rows of members start, start + step, ... below stop (their velocity,
    velocity change per substep and inverse mass; the rest stays as body_rows set it)."""
    for k in range(start, stop, step):
        r = state_row[k]
        for axis in range(3):
            velocity_rows[k, axis] = state[r, START_VELOCITY + axis]
            change[k, axis] = (state[r, END_VELOCITY + axis]
                               - state[r, START_VELOCITY + axis]) / substeps
        inverse_mass[k] = 1.0 / mass[sphere[k]]
