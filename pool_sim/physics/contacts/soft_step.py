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

The rows it solves on are made in soft_rows.py, one contact a row (soft_contact.py's
columns), and solved by soft_contact.py's per-contact functions.

Impulses are equal and opposite (momentum is kept to rounding). Point masses do not spin:
friction slows relative sliding, nothing rolls.
"""
from collections import namedtuple

import numba
import numpy as np

from ..kernels.step_guard import finite, put_back
from .colouring import colour_by_priority, colour_contacts
from .layers import bottom_up_order
from .face_crossing import bound_face_crossings
from .soft_contact import COLUMNS, GAP, NX, NY, NZ, carry_contact, restitute_contact, \
    solve_contact
from .soft_rows import body_rows, contact_keys, face_contacts, fill_rows, members_of, \
    remember, warm_start
from .detection import counting_sort, detect_contacts, take

# Scene keys' defaults (schema.py gives their ranges): chosen in results/collisions.
SUBSTEPS = 4
STIFFNESS_HZ = 120.0
DAMPING_RATIO = 10.0
PUSH_OUT_SPEED = 0.5  # m/s
# A restitution pass bounces an approach faster than this x |g| dt only (slower ones rest).
RESTING_FACTOR = 2.0
# A contact whose normal is at least this steep (its z part) bears weight: one sphere
# holds the other up (sequential_impulses' _BEARING).
_BEARING = 0.3
# Touching, for _support_sweep: apart by no more than this, m.
_HOLDING_GAP = 1e-9
# The floor among a contact's faces (0-2: the low x, y and z faces; 3-5: the high ones).
FLOOR_FACE = 2

Prepared = namedtuple('Prepared', ('rows', 'solve_order', 'velocity', 'moved', 'change',
                                   'inverse_mass', 'support', 'bounces', 'sphere', 'slot',
                                   'keys', 'homes', 'by_home', 'colour_start', 'faces_of',
                                   'state_row'))
Prepared.__doc__ = """What a step's substeps solve on (contact_rows), c contacts among m
member spheres: rows (c, COLUMNS), each slot's contact (soft_contact.py's columns), colour by
colour; solve_order (c, 2) int64, each slot's two member rows (the ground, row m, for a
face); velocity, moved, change (m + 1, 4): the members' velocity m/s from the step's start,
how far each has moved since it (m), the smooth step's velocity change per substep (m/s);
inverse_mass (m + 1,) 1/kg; support: _support_order's; bounces (c,) bool: the slots the
restitution pass looks at (soft_rows.fill_rows); sphere (m,) int64, each member's sphere;
slot, keys, homes (c,) int64 and by_home: for remember (soft_rows.py); colour_start
(colouring.COLOURS + 1,) int64: where each colour's slots begin (the last colour's
contacts may share a sphere: swept in order); faces_of (f, 2) int64: each face contact's
member and face (soft_rows.face_contacts); state_row (m,) int64: each member's row of
detection's state."""


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
    settings: (substeps, stiffness_hz, damping_ratio, push_out_speed m/s, 1 to colour by
    priority (colouring.py) or 0).

    Returns how many spheres the step guard put back (flagged in failed)."""
    count = radius.size
    if count < 2:
        memory_held[:] = 0
        return 0
    contacts, used_real, used_whole = detect_contacts(old_position, old_velocity, position,
                                                     velocity, radius, dt, reals, wholes)
    if contacts.pairs.shape[1] == 0:
        memory_held[:] = 0
        return 0
    threshold = RESTING_FACTOR * resting_speed
    ready = contact_rows(contacts, used_real, used_whole, old_position, old_velocity,
                         position, velocity, mass, radius, faces, has_faces, contact,
                         has_friction, identity, memory_keys, memory_forces, memory_held,
                         settings, threshold, dt, reals, wholes,
                         settings.size > 4 and settings[4] != 0.0)
    return settle(ready, old_position, position, velocity, failed, flagged, contact[0],
                  memory_keys, memory_forces, memory_held, settings, threshold, dt)


@numba.njit(error_model='numpy')
def settle(ready, old_position, position, velocity, failed, flagged, restitution,
           memory_keys, memory_forces, memory_held, settings, threshold, dt):
    """The rest of resolve_collisions once contact_rows made ready (a Prepared): the
    substeps, the restitution pass, the contacts remembered, each member written back
    (write_members). Returns how many spheres the step guard put back."""
    supported = np.zeros(ready.sphere.size, dtype=np.bool_)  # _support_sweep's scratch
    _substeps(ready.rows, ready.solve_order, ready.velocity, ready.moved, ready.change,
              ready.inverse_mass, settings, dt, ready.support, threshold, supported)
    restitution_pass(ready.rows, ready.solve_order, ready.velocity, ready.inverse_mass,
                     threshold, restitution, ready.bounces)
    remember(ready.rows, ready.slot, ready.keys, ready.homes, ready.by_home, memory_keys,
             memory_forces, memory_held, settings, dt)
    return write_members(ready.sphere, ready.moved, ready.velocity, old_position, position,
                         velocity, failed, flagged, 0, ready.sphere.size, 1)


@numba.njit(error_model='numpy')
def write_members(sphere, moved, velocity_rows, old_position, position, velocity, failed,
                  flagged, start, stop, step):
    """Members start, start + step, ... below stop: each one's solved path into its
    sphere's position and velocity (its faces are done: its flag cleared), then the step
    guard. Returns how many spheres it put back. (A range, not one member: a call a member
    costs the CPU's loop its speed; a GPU thread passes its own.)"""
    put_back_count = 0
    for k in range(start, stop, step):
        i = sphere[k]
        for axis in range(3):
            position[axis, i] = old_position[axis, i] + moved[k, axis]
            velocity[axis, i] = velocity_rows[k, axis]
        flagged[i] = 0
        if failed[i] or finite((position[0, i], position[1, i], position[2, i],
                                velocity[0, i], velocity[1, i], velocity[2, i])):
            continue
        put_back(position, velocity, old_position, failed, i)
        put_back_count += 1
    return put_back_count


@numba.njit(error_model='numpy')
def contact_rows(contacts, used_real, used_whole, old_position, old_velocity, position,
                 velocity, mass, radius, faces, has_faces, contact, has_friction, identity,
                 memory_keys, memory_forces, memory_held, settings, threshold, dt, reals,
                 wholes, by_priority):
    """What the substeps solve on (a Prepared), made from detection's contacts (at least
    one pair) and the workspace past what detection used (used_real, used_whole); threshold:
    the restitution pass's, m/s; by_priority: colour as the GPU does
    (colouring.colour_by_priority), not in the order the contacts come; the other arguments
    as resolve_collisions takes them. Reads last step's memory, writes none."""
    count, pairs = radius.size, contacts.pairs
    sphere, row_of, state_row, used_whole = members_of(pairs, contacts.order, count, wholes,
                                                       used_whole)
    members, state = sphere.size, contacts.state
    faces_of, total = face_contacts(state_row, state, faces, has_faces, pairs.shape[1])
    ends, keys, homes, used_whole = contact_keys(pairs, faces_of, row_of, sphere, identity,
                                                 total, wholes, used_whole)
    # The warm start and remember walk the contacts by their home row, so that the memory's
    # rows come in order (in the order contacts are found, the rows came in a cache miss at
    # a time: 451 against 134 µs with them in cache, 10 000 spheres at rest).
    by_home, _, used_whole = counting_sort(homes, count, wholes, used_whole)
    rows, used_real = take(reals, used_real, COLUMNS * total)
    rows = rows.reshape((total, COLUMNS))
    if by_priority:
        slot, colour_start = colour_by_priority(ends, members)
    else:
        slot, colour_start = colour_contacts(ends, members, wholes, used_whole)
    velocity_rows, moved, change, inverse_mass = body_rows(sphere, state_row, state, mass,
                                                           settings, reals, used_real)
    bounces = np.empty(total, dtype=np.bool_)
    fill_rows(rows, slot, ends, contacts, faces_of, state_row, inverse_mass, mass, sphere,
              faces, contact, has_friction, settings, dt, threshold, bounces)
    warm_start(rows, slot, keys, homes, by_home, memory_keys, memory_forces, memory_held,
               ends, sphere, radius, settings, dt)
    bound_face_crossings(change, faces_of, sphere, old_position, old_velocity, position,
                         velocity, radius, faces, settings[0], dt)
    solve_order = np.empty_like(ends)  # each slot's two rows
    for c in range(total):
        solve_order[slot[c], 0], solve_order[slot[c], 1] = ends[c, 0], ends[c, 1]
    support = _support_order(rows, ends[:pairs.shape[1]], faces_of, slot, sphere,
                             old_position, radius)
    return Prepared(rows, solve_order, velocity_rows, moved, change, inverse_mass, support,
                    bounces, sphere, slot, keys, homes, by_home, colour_start, faces_of,
                    state_row)


@numba.njit(error_model='numpy')
def _substeps(rows, solve_order, velocity, moved, change, inverse_mass, settings, dt,
              support, threshold, supported):
    """The substeps (see the module's docstring, 4) on a Prepared's arrays; support
    (_support_order's), threshold m/s, supported: _support_sweep's."""
    substeps = int(settings[0])
    h = dt / substeps
    push_out_speed, inverse_h = settings[3], 1.0 / h
    for substep in range(substeps):
        change_pass(velocity, change)
        carried_pass(rows, solve_order, velocity, inverse_mass)
        solve_pass(rows, solve_order, velocity, moved, inverse_mass, push_out_speed, True,
                   inverse_h, True)
        _support_sweep(*support, velocity, moved, inverse_h, threshold, supported)
        move_pass(moved, velocity, h)
        # After the last move a contact still apart is the next step's: held here, a pair
        # about to meet was slowed at a distance, inelastically.
        solve_pass(rows, solve_order, velocity, moved, inverse_mass, push_out_speed, False,
                   inverse_h, substep < substeps - 1)


# The passes of a step, each over its members or contacts (solve_order: each row's two
# member rows, the ground last): functions of their own so that benchmarks/solve_passes.py
# times the code the solver runs; inlined, as the loops they were.
@numba.njit(error_model='numpy', inline='always')
def change_pass(velocity, change):
    """The smooth step's velocity change, a substep's share (change), into velocity."""
    for k in range(velocity.shape[0] - 1):
        change_member(velocity, change, k)


@numba.njit(error_model='numpy', inline='always')
def change_member(velocity, change, k):
    """change_pass for member k (a GPU thread's share)."""
    for axis in range(3):
        velocity[k, axis] += change[k, axis]


@numba.njit(error_model='numpy', inline='always')
def carried_pass(rows, solve_order, velocity, inverse_mass):
    """soft_contact.carry_contact over every contact: their accumulated impulses."""
    for s in range(rows.shape[0]):
        carry_contact(rows, s, solve_order[s, 0], solve_order[s, 1], velocity, inverse_mass)


@numba.njit(error_model='numpy', inline='always')
def solve_pass(rows, solve_order, velocity, moved, inverse_mass, push_out_speed, use_bias,
               inverse_h, hold_apart):
    """soft_contact.solve_contact over every contact, colour by colour (its arguments)."""
    for s in range(rows.shape[0]):
        solve_contact(rows, s, solve_order[s, 0], solve_order[s, 1], velocity, moved,
                      inverse_mass, push_out_speed, use_bias, inverse_h, hold_apart)


@numba.njit(error_model='numpy', inline='always')
def move_pass(moved, velocity, h):
    """Every member moved by its velocity over h s."""
    for k in range(velocity.shape[0] - 1):
        move_member(moved, velocity, h, k)


@numba.njit(error_model='numpy', inline='always')
def move_member(moved, velocity, h, k):
    """move_pass for member k (a GPU thread's share)."""
    for axis in range(3):
        moved[k, axis] += h * velocity[k, axis]


@numba.njit(error_model='numpy', inline='always')
def restitution_pass(rows, solve_order, velocity, inverse_mass, threshold, restitution,
                     bounces):
    """soft_contact.restitute_contact over the contacts that may bounce (bounces, by slot:
    a resting pile's rows, none of which bounce, are not read), once a step."""
    for s in range(rows.shape[0]):
        if bounces[s]:
            restitute_contact(rows, s, solve_order[s, 0], solve_order[s, 1], velocity,
                              inverse_mass, threshold, restitution)


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
        if faces_of[f, 1] == FLOOR_FACE:
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
        if bears(rows, slot[c]):
            write_bearing(rows, slot[c], pair_ends[c, 0], pair_ends[c, 1], ends, facts,
                          bearing)
            bearing += 1
    return ends[:bearing], facts[:bearing], floor_member, floor_gap


@numba.njit(error_model='numpy')
def bears(rows, s):
    """Whether the pair in slot s bears weight (its normal is steep enough); side by
    side, neither sphere holds the other up."""
    sign = 1.0 if rows[s, NZ] > 0.0 else -1.0  # the normal's sense from lower to upper
    return not sign * rows[s, NZ] < _BEARING


@numba.njit(error_model='numpy')
def write_bearing(rows, s, first, second, ends, facts, at):
    """The bearing pair in slot s (member rows first, second) into _support_order's ends
    and facts at row `at`: upper sphere first, the normal from lower to upper, the gap."""
    sign = 1.0 if rows[s, NZ] > 0.0 else -1.0
    ends[at, 0], ends[at, 1] = (first, second) if sign > 0.0 else (second, first)
    facts[at, 0] = sign * rows[s, NX]
    facts[at, 1] = sign * rows[s, NY]
    facts[at, 2] = sign * rows[s, NZ]
    facts[at, 3] = rows[s, GAP]


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
        fastest = max(fastest, speed_squared(velocity, k))
    if may_land(fastest, threshold):
        hold_up(ends, facts, floor_member, floor_gap, velocity, moved, inverse_h, threshold,
                supported)


@numba.njit(error_model='numpy', inline='always')
def speed_squared(velocity, k):
    """Member k's speed squared, (m/s)^2: the support sweep's first test takes the most."""
    return velocity[k, 0] ** 2 + velocity[k, 1] ** 2 + velocity[k, 2] ** 2


@numba.njit(error_model='numpy', inline='always')
def may_land(fastest, threshold):
    """Whether a pair may approach faster than threshold m/s, its members' largest speed
    squared fastest (m/s)^2: if not, a pile at rest, which the sweep leaves alone."""
    return 4.0 * fastest > threshold * threshold


@numba.njit(error_model='numpy', inline='always')
def hold_up(ends, facts, floor_member, floor_gap, velocity, moved, inverse_h, threshold,
            supported):
    """_support_sweep's sweep bottom up, once may_land (its arguments): what the floor holds
    (hold_on_floor), then each contact (hold_up_contacts), in order."""
    supported[:] = False
    hold_on_floor(floor_member, floor_gap, 0, floor_member.size, 1, velocity, moved,
                  threshold, supported)
    hold_up_contacts(ends, facts, 0, ends.shape[0], 1, velocity, moved, inverse_h, threshold,
                     supported)


# The sweep's two loops take a range, so that a GPU thread sweeps its share with them:
# their bodies as functions of one contact, inlined into the loops, made the step 4-13 %
# slower in node_rate's scene (compare_commits, the same numbers).
@numba.njit(error_model='numpy', inline='always')
def hold_on_floor(floor_member, floor_gap, start, stop, step, velocity, moved, threshold,
                  supported):
    """Whether the floor holds up the spheres of floor contacts start, start + step, ...
    (below stop), into supported."""
    for f in range(start, stop, step):
        k = floor_member[f]
        # Lifting off (rising faster than threshold): holds nothing up.
        supported[k] = floor_gap[f] + moved[k, 2] <= _HOLDING_GAP and velocity[k, 2] <= threshold


@numba.njit(error_model='numpy', inline='always')
def hold_up_contacts(ends, facts, start, stop, step, velocity, moved, inverse_h, threshold,
                     supported):
    """Contacts start, start + step, ... (below stop) of the sweep, in order: a held-up
    lower sphere holds up the upper one touching it, whose approach beyond the gap / h
    stops. Each reads both spheres and writes the upper's velocity and supported
    (layers.sweep_waves: which contacts may go at once)."""
    for q in range(start, stop, step):
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
