"""Soft step (after Box2D v3, Catto 2024): a contact solver of the `collisions` effect
(SOLVERS in contacts/__init__.py) that remembers each contact's impulse from one step to
the next. For the spheres in contact with another (detection.py finds the pairs), every
step:

1. Contacts: the sphere pairs, and each such sphere's floor, walls and ceiling within half
   its radius of its path as static contacts (a partner of infinite mass at rest; a
   sphere touching no other keeps the per-sphere face rule, kernels/faces.py). Each is
   keyed by the identities of its two spheres (or its sphere and face), never by index or
   cell: a spawn or a remove cannot hand one pair's impulse to another.
2. Warm start: each key is looked up in its sphere's row of last step's (memory.py), so
   a contact that persists starts from the force it carried (stored per second, so a
   change of step size scales it); its friction is turned into the new tangent plane.
3. Colours: greedily, so that no two contacts of a colour share a sphere (static
   partners do not count); contacts are swept colour by colour in a fixed order, which
   is then also a legal parallel order.
4. Substeps (soft_step.substeps of them): the smooth step's own velocity change (gravity,
   buoyancy, drag, ...; face_crossing.py's bound where its path crossed a face of the
   pool) in equal parts, the remembered impulses applied, a solve with soft constraints
   (an implicit spring-damper per contact, soft_step.stiffness_hz and damping_ratio, its
   push-out no faster than push_out_speed), a support sweep bottom up (_support_sweep: a
   sphere the floor holds up stops a landing sphere above it), the positions moved, and a
   relax pass without the spring's bias. A contact still apart may close no more than
   its gap (speculative) before the last move. Friction is Coulomb's on the *accumulated* impulse.
5. Restitution, once at the end: a contact that pushed while touching and approached at
   the step's start faster than RESTING_FACTOR x |g| dt leaves at restitution x that
   approach (the approach before the step's own gravity: bouncing that adds energy).

Impulses are equal and opposite (momentum is kept to rounding). Point masses do not spin:
friction slows relative sliding, nothing rolls.
"""
import math

import numba
import numpy as np

from ..kernels.step_guard import finite, put_back
from .colouring import colour_contacts
from .layers import bottom_up_order
from .face_crossing import bound_face_crossings
from .soft_contact import APPROACH, BIAS_RATE, COLUMNS, FX, FY, FZ, GAP, IMPULSE_SCALE, \
    MASS, MASS_SCALE, MU_K, MU_S, NORMAL, NX, NY, NZ, restitute_contact, soft_coefficients, \
    solve_contact
from .memory import CONTACTS_PER_SPHERE, home_order, remembered_slot
from .detection import detect_contacts, take, END_POSITION, END_VELOCITY, RADIUS, \
    START_POSITION, START_VELOCITY

# Scene keys' defaults (schema.py gives their ranges): chosen in results/collisions.
SUBSTEPS = 4
STIFFNESS_HZ = 120.0
DAMPING_RATIO = 10.0
PUSH_OUT_SPEED = 0.5  # m/s
# The contact's own frequency is held below this fraction of the substep rate (Box2D's
# quarter): stiffer than that an implicit spring only rings.
_MOST_HZ_PER_SUBSTEP_RATE = 0.25
# A face is a contact of a sphere's within this fraction of its radius of its path.
_FACE_REACH = 0.5
# A restitution pass bounces an approach faster than this x |g| dt only (slower ones rest).
RESTING_FACTOR = 2.0
# A contact whose normal is at least this steep (its z part) bears weight: one sphere
# holds the other up (sequential_impulses' _BEARING).
_BEARING = 0.3
# Touching, for _support_sweep: apart by no more than this, m.
_HOLDING_GAP = 1e-9
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
def resolve_collisions(old_position, old_velocity, position, velocity, mass, radius, faces,
                       has_faces, contact, has_friction, resting_speed, gravity_step,
                       floor_supports, failed, reals, wholes, dt, flagged, identity, memory_keys,
                       memory_forces, memory_held, settings):
    """Find and resolve this step's contacts in place (position, velocity: the smooth
    step's end, before the faces' pass; old_*: the step's start); the arguments as
    sequential_impulses.resolve_collisions takes them, and: flagged (n,) uint8, cleared for
    the spheres solved here (their faces are solved here too); identity (n,) int64, each
    sphere's, unique over the run; memory_keys, memory_forces and memory_held: last step's
    contacts (memory.contact_memory's arrays, a row per sphere), replaced by this step's;
    settings: (substeps, stiffness_hz, damping_ratio, push_out_speed m/s).

    Returns how many spheres the step guard put back (flagged in failed)."""
    count = radius.size
    if count < 2:
        memory_held[:] = 0
        return 0
    contacts, used_real, used_whole = detect_contacts(old_position, old_velocity, position,
                                                     velocity, radius, dt, reals, wholes)
    pairs, order = contacts.pairs, contacts.order
    if pairs.shape[1] == 0:
        memory_held[:] = 0
        return 0
    sphere, row_of, used_whole = _members(pairs, order, count, wholes, used_whole)
    members = sphere.size
    ground = members  # a row at rest with no inverse mass: the faces' partner
    faces_of, total = _face_contacts(sphere, old_position, position, radius, faces, has_faces,
                                     pairs.shape[1])
    ends, used_whole = take(wholes, used_whole, 2 * total)
    ends = ends.reshape((total, 2))
    keys, used_whole = take(wholes, used_whole, total)
    homes, used_whole = take(wholes, used_whole, total)  # the memory's row of each
    for c in range(pairs.shape[1]):
        a, b = row_of[pairs[0, c]], row_of[pairs[1, c]]
        ends[c, 0], ends[c, 1] = a, b
        i, j = sphere[a], sphere[b]
        lower = i if identity[i] < identity[j] else j
        keys[c] = (identity[lower] << 32) | identity[i + j - lower]
        homes[c] = lower
    for f in range(total - pairs.shape[1]):
        c = pairs.shape[1] + f
        ends[c, 0], ends[c, 1] = faces_of[f, 0], ground
        keys[c] = (identity[sphere[faces_of[f, 0]]] << 32) | (_FACE_KEY + faces_of[f, 1])
        homes[c] = sphere[faces_of[f, 0]]
    by_home, used_whole = home_order(homes, count, wholes, used_whole)
    rows, used_real = take(reals, used_real, COLUMNS * total)
    rows = rows.reshape((total, COLUMNS))
    slot, _ = colour_contacts(ends, ground, wholes, used_whole)
    _fill_rows(rows, slot, ends, contacts, faces_of, sphere, ground, old_position,
               old_velocity, radius, mass, faces, contact, has_friction, settings, dt)
    _warm_start(rows, slot, keys, homes, by_home, memory_keys, memory_forces, memory_held,
                ends, sphere, radius, settings, dt)
    velocity_rows, moved, change, inverse_mass = _body_rows(sphere, old_velocity, velocity,
                                                            mass, settings, reals, used_real)
    bound_face_crossings(change, faces_of, sphere, old_position, old_velocity, position,
                         velocity, radius, faces, settings[0], dt)
    solve_order = np.empty_like(ends)  # each slot's two rows
    for c in range(total):
        solve_order[slot[c], 0], solve_order[slot[c], 1] = ends[c, 0], ends[c, 1]
    threshold = RESTING_FACTOR * resting_speed
    support = _support_order(rows, ends[:pairs.shape[1]], faces_of, slot, sphere,
                             old_position, radius)
    supported = np.zeros(members, dtype=np.bool_)  # _support_sweep's scratch
    _substeps(rows, solve_order, velocity_rows, moved, change, inverse_mass, settings, dt,
              support, threshold, supported)
    for s in range(total):
        restitute_contact(rows, s, solve_order[s, 0], solve_order[s, 1], velocity_rows,
                          inverse_mass, threshold, contact[0])
    _remember(rows, slot, keys, homes, by_home, memory_keys, memory_forces, memory_held,
              settings, dt)
    put_back_count = 0
    for k in range(members):
        i = sphere[k]
        for axis in range(3):
            position[axis, i] = old_position[axis, i] + moved[k, axis]
            velocity[axis, i] = velocity_rows[k, axis]
        flagged[i] = 0  # its faces are done
        if failed[i] or finite((position[0, i], position[1, i], position[2, i],
                                velocity[0, i], velocity[1, i], velocity[2, i])):
            continue
        put_back(position, velocity, old_position, failed, i)
        put_back_count += 1
    return put_back_count


@numba.njit(error_model='numpy')
def _members(pairs, order, count, wholes, used_whole):
    """(sphere (members,) int64: the sphere of each row, in cell order; row_of (n,) int64:
    detection's state row -> our row; used wholes)."""
    row_of, used_whole = take(wholes, used_whole, count)
    row_of[:] = -1
    for c in range(pairs.shape[1]):
        row_of[pairs[0, c]], row_of[pairs[1, c]] = 0, 0
    sphere, used_whole = take(wholes, used_whole, count)
    members = 0
    for k in range(count):
        if row_of[k] == 0:
            row_of[k] = members
            sphere[members] = order[k]
            members += 1
    return sphere[:members], row_of, used_whole


@numba.njit(error_model='numpy')
def _face_contacts(sphere, old_position, position, radius, faces, has_faces, found):
    """(faces_of (f, 2) int64: each face contact's row and face 0-5; found + f): the faces
    within _FACE_REACH of a radius of a member's path (start or smooth end)."""
    members = sphere.size
    faces_of = np.empty((6 * members if has_faces else 0, 2), dtype=np.int64)
    f = 0
    for k in range(members if has_faces else 0):
        i = sphere[k]
        r = radius[i]
        for axis in range(3):
            low = min(old_position[axis, i], position[axis, i]) - r - faces[axis]
            high = faces[axis + 3] - r - max(old_position[axis, i], position[axis, i])
            if low < _FACE_REACH * r:
                faces_of[f, 0], faces_of[f, 1] = k, axis
                f += 1
            if high < _FACE_REACH * r:
                faces_of[f, 0], faces_of[f, 1] = k, axis + 3
                f += 1
    return faces_of[:f], found + f


@numba.njit(error_model='numpy')
def _fill_rows(rows, slot, ends, contacts, faces_of, sphere, ground, old_position,
               old_velocity, radius, mass, faces, contact, has_friction, settings, dt):
    """Each contact's row (the COLUMNS) at its slot, from the step's start; impulses
    zero and the scene's spring (_warm_start puts last step's impulses in)."""
    found = contacts.pairs.shape[1]
    h = dt / settings[0]
    soft = soft_coefficients(min(settings[1], _MOST_HZ_PER_SUBSTEP_RATE / h), settings[2], h)
    mu_s = contact[1] if has_friction else 0.0
    mu_k = contact[2] if has_friction else 0.0
    rolling = contact[3] if has_friction else 0.0
    for c in range(ends.shape[0]):
        s = slot[c]
        rows[s, :] = 0.0
        i = sphere[ends[c, 0]]
        if c < found:
            j = sphere[ends[c, 1]]
            nx, ny, nz = (contacts.normal[0, c], contacts.normal[1, c],
                          contacts.normal[2, c])
            rows[s, GAP] = ((old_position[0, i] - old_position[0, j]) * nx
                             + (old_position[1, i] - old_position[1, j]) * ny
                             + (old_position[2, i] - old_position[2, j]) * nz
                             - radius[i] - radius[j])
            rows[s, MASS] = 1.0 / (1.0 / mass[i] + 1.0 / mass[j])
            rows[s, APPROACH] = ((old_velocity[0, i] - old_velocity[0, j]) * nx
                                  + (old_velocity[1, i] - old_velocity[1, j]) * ny
                                  + (old_velocity[2, i] - old_velocity[2, j]) * nz)
            rows[s, MU_S], rows[s, MU_K] = mu_s, mu_k
        else:
            face = faces_of[c - found, 1]
            axis = face % 3
            inward = 1.0 if face < 3 else -1.0  # the face's normal, into the pool
            nx, ny, nz = (inward if axis == 0 else 0.0, inward if axis == 1 else 0.0,
                          inward if axis == 2 else 0.0)
            rows[s, GAP] = (old_position[axis, i] - radius[i] - faces[axis] if face < 3
                             else faces[face] - radius[i] - old_position[axis, i])
            rows[s, MASS] = mass[i]
            rows[s, APPROACH] = inward * old_velocity[axis, i]
            # Rolling resistance on a face, as the per-sphere face rule has it.
            rows[s, MU_S], rows[s, MU_K] = mu_s, mu_k + rolling
        rows[s, NX], rows[s, NY], rows[s, NZ] = nx, ny, nz
        rows[s, BIAS_RATE], rows[s, MASS_SCALE], rows[s, IMPULSE_SCALE] = soft


@numba.njit(error_model='numpy')
def _warm_start(rows, slot, keys, homes, by_home, memory_keys, memory_forces, memory_held,
                ends, sphere, radius, settings, dt):
    """Last step's forces (memory_*: each key looked up in its home row, the contacts in
    by_home's order) into the rows of the contacts that persist, as impulses over this
    step's substep, friction turned into the new tangent plane, the spring stiffened if
    that load would press it more than LOADED_OVERLAP (ends, sphere, radius: for the
    smaller radius)."""
    h = dt / settings[0]
    ground = sphere.size
    for q in range(keys.size):
        c = by_home[q]
        home = homes[c]
        j = remembered_slot(memory_keys, memory_held, home, keys[c])
        if j < 0:
            continue
        held = memory_forces[home, j]
        s = slot[c]
        nx, ny, nz = rows[s, NX], rows[s, NY], rows[s, NZ]
        fx, fy, fz = held[1] * h, held[2] * h, held[3] * h
        along = fx * nx + fy * ny + fz * nz
        rows[s, NORMAL] = held[0] * h
        rows[s, FX], rows[s, FY], rows[s, FZ] = (fx - along * nx, fy - along * ny,
                                                    fz - along * nz)
        a, b = ends[c, 0], ends[c, 1]
        smaller = radius[sphere[a]] if b == ground else min(radius[sphere[a]],
                                                            radius[sphere[b]])
        # The frequency whose spring the load presses LOADED_OVERLAP x smaller.
        needed = math.sqrt(max(held[0], 0.0) / (
            rows[s, MASS] * LOADED_OVERLAP * smaller)) / (2.0 * math.pi)
        most = _MOST_HZ_PER_SUBSTEP_RATE / h
        if needed > min(settings[1], most):
            soft = soft_coefficients(min(needed, most), settings[2], h)
            rows[s, BIAS_RATE], rows[s, MASS_SCALE], rows[s, IMPULSE_SCALE] = soft


@numba.njit(error_model='numpy')
def _remember(rows, slot, keys, homes, by_home, memory_keys, memory_forces, memory_held,
              settings, dt):
    """This step's contacts as forces (N) in memory_* for the next step, each in its home
    row, in contact order (by_home's: contacts of one home in the order they come; as
    many as a row holds: the rest start from none)."""
    per_second = settings[0] / dt
    memory_held[:] = 0
    for q in range(keys.size):
        c = by_home[q]
        home = homes[c]
        k = memory_held[home]
        if k == CONTACTS_PER_SPHERE:
            continue
        s = slot[c]
        memory_keys[home, k] = keys[c]
        memory_forces[home, k, 0] = rows[s, NORMAL] * per_second
        memory_forces[home, k, 1] = rows[s, FX] * per_second
        memory_forces[home, k, 2] = rows[s, FY] * per_second
        memory_forces[home, k, 3] = rows[s, FZ] * per_second
        memory_held[home] = k + 1


@numba.njit(error_model='numpy')
def _body_rows(sphere, old_velocity, velocity, mass, settings, reals, used_real):
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
    substeps = settings[0]
    for k in range(members):
        i = sphere[k]
        for axis in range(3):
            velocity_rows[k, axis] = old_velocity[axis, i]
            change[k, axis] = (velocity[axis, i] - old_velocity[axis, i]) / substeps
        inverse_mass[k] = 1.0 / mass[i]
    return velocity_rows, moved, change, inverse_mass


@numba.njit(error_model='numpy')
def _substeps(rows, solve_order, velocity, moved, change, inverse_mass, settings, dt,
              support, threshold, supported):
    """The substeps (see the module's docstring, 4) on the rows of resolve_collisions;
    support (_support_order's), threshold m/s, supported: _support_sweep's."""
    substeps = int(settings[0])
    h = dt / substeps
    push_out_speed, inverse_h = settings[3], 1.0 / h
    members, total = velocity.shape[0] - 1, rows.shape[0]
    for substep in range(substeps):
        for k in range(members):
            for axis in range(3):
                velocity[k, axis] += change[k, axis]
        for s in range(total):  # the impulses carried in
            a, b = solve_order[s, 0], solve_order[s, 1]
            normal = rows[s, NORMAL]
            wa, wb = inverse_mass[a], inverse_mass[b]
            for axis in range(3):
                impulse = normal * rows[s, NX + axis] + rows[s, FX + axis]
                velocity[a, axis] += wa * impulse
                velocity[b, axis] -= wb * impulse
        for s in range(total):
            solve_contact(rows, s, solve_order[s, 0], solve_order[s, 1], velocity, moved,
                          inverse_mass, push_out_speed, True, inverse_h, True)
        _support_sweep(*support, velocity, moved, inverse_h, threshold, supported)
        for k in range(members):
            for axis in range(3):
                moved[k, axis] += h * velocity[k, axis]
        # After the last move a contact still apart is the next step's: held here, a pair
        # about to meet was slowed at a distance, inelastically.
        last = substep == substeps - 1
        for s in range(total):
            solve_contact(rows, s, solve_order[s, 0], solve_order[s, 1], velocity, moved,
                          inverse_mass, push_out_speed, False, inverse_h, not last)


@numba.njit(error_model='numpy')
def _support_order(rows, pair_ends, faces_of, slot, sphere, old_position, radius):
    """What _support_sweep reads, in the order it reads it: (ends (b, 2) int64, the upper
    and lower sphere of each pair whose normal bears weight, bottom up (by the lower
    sphere's height at the step's start); facts (b, 4): its normal from lower to upper and
    its gap at the step's start, m; floor_member (f,) int64 and floor_gap (f,) m: the
    spheres with a floor contact and its gap at the step's start)."""
    found, members = pair_ends.shape[0], sphere.size
    floor_member = np.empty(slot.size - found, dtype=np.int64)
    floor_gap = np.empty(slot.size - found)
    floors = 0
    for f in range(slot.size - found):
        if faces_of[f, 1] == 2:  # the floor: low z
            floor_member[floors] = faces_of[f, 0]
            floor_gap[floors] = rows[slot[found + f], GAP]
            floors += 1
    floor_member, floor_gap = floor_member[:floors], floor_gap[:floors]
    if floors == 0:  # nothing is held up: spheres falling through air and water
        return np.empty((0, 2), dtype=np.int64), np.empty((0, 4)), floor_member, floor_gap
    z, member_radius = np.empty(members), np.empty(members)
    for k in range(members):
        z[k], member_radius[k] = old_position[2, sphere[k]], radius[sphere[k]]
    order, _ = bottom_up_order(pair_ends, z, member_radius, np.empty(0, dtype=np.int64), 0)
    ends = np.empty((found, 2), dtype=np.int64)
    facts = np.empty((found, 4))
    bearing = 0
    for q in range(found):
        c = order[q]
        s = slot[c]
        sign = 1.0 if rows[s, NZ] > 0.0 else -1.0  # the normal's sense from lower to upper
        if sign * rows[s, NZ] < _BEARING:
            continue  # side by side: neither holds the other up
        first, second = pair_ends[c, 0], pair_ends[c, 1]
        ends[bearing, 0], ends[bearing, 1] = (first, second) if sign > 0.0 else (second, first)
        facts[bearing, 0] = sign * rows[s, NX]
        facts[bearing, 1] = sign * rows[s, NY]
        facts[bearing, 2] = sign * rows[s, NZ]
        facts[bearing, 3] = rows[s, GAP]
        bearing += 1
    return ends[:bearing], facts[:bearing], floor_member, floor_gap


@numba.njit(error_model='numpy')
def _support_sweep(ends, facts, floor_member, floor_gap, velocity, moved, inverse_h,
                   threshold, supported):
    """Shock propagation (Guendelman et al. 2003), after each substep's solve: bottom up,
    a sphere touching the floor, or touching a sphere so held up through a contact that
    bears weight, is as immovable as the floor for the sphere above it, whose approach
    beyond its gap / h stops (the momentum goes to the floor). Only an approach faster
    than threshold m/s: a landing's, not a resting pile's (swept so every substep, a pile
    of 10 000 never came to rest). ends, facts, floor_member, floor_gap: _support_order's;
    supported (members,) bool: scratch.

    Gauss-Seidel passes a blow down a chain one contact a pass, and a light sphere between
    the floor and a heavy column is driven back into the one below by the column's
    contacts swept after theirs: landing, two such spheres closed by 3 mm a step for ten
    steps, 69 % of a radius deep."""
    fastest = 0.0
    for k in range(supported.size):
        fastest = max(fastest, velocity[k, 0] ** 2 + velocity[k, 1] ** 2 + velocity[k, 2] ** 2)
    if 4.0 * fastest <= threshold * threshold:
        return  # no pair can approach faster than threshold: a pile at rest
    supported[:] = False
    for f in range(floor_member.size):
        k = floor_member[f]
        # Lifting off (rising faster than threshold): holds nothing up.
        supported[k] = floor_gap[f] + moved[k, 2] <= _HOLDING_GAP and velocity[k, 2] <= threshold
    for q in range(ends.shape[0]):
        upper, lower = ends[q, 0], ends[q, 1]
        if not supported[lower]:
            continue
        nx, ny, nz = facts[q, 0], facts[q, 1], facts[q, 2]
        gap = facts[q, 3] + ((moved[upper, 0] - moved[lower, 0]) * nx
                             + (moved[upper, 1] - moved[lower, 1]) * ny
                             + (moved[upper, 2] - moved[lower, 2]) * nz)
        supported[upper] = supported[upper] or gap <= _HOLDING_GAP
        approach = -((velocity[upper, 0] - velocity[lower, 0]) * nx
                     + (velocity[upper, 1] - velocity[lower, 1]) * ny
                     + (velocity[upper, 2] - velocity[lower, 2]) * nz) - max(gap, 0.0) * inverse_h
        if approach > threshold:
            velocity[upper, 0] += approach * nx
            velocity[upper, 1] += approach * ny
            velocity[upper, 2] += approach * nz
