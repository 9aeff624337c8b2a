"""Sphere-sphere contact, the `collisions` effect: after each step's smooth forces and faces.

Three stages, each compiled, none with per-pair Python:

1. Broad phase (find_contacts): each sphere's bounding sphere over the step (the segment its
   centre moved along, widened by its radius and SPECULATIVE_MARGIN), so a fast sphere
   cannot pass through another within a step. Bounding spheres go into levels by size, and
   each level is a cell list (a dense grid, counting-sorted): linear in the number of
   spheres, whatever the mix of radii.
2. Narrow phase: the relative motion of the two centres over the step is taken as linear;
   a pair is in contact when the centres come within the sum of the radii, and the normal
   is the direction between them at that first moment (time of impact). Pairs whose
   bounding spheres meet but which stay apart all step are speculative contacts: they may
   close no more than their gap, however impulses elsewhere set them moving.
3. Resolution, in sweeps over the contacts (sequential impulses, Gauss-Seidel):
   - velocity: a pair approaching along its normal gets the binary-collision impulse that
     sends it apart at restitution x its speed at impact (the step's own approach after
     impact, found as for the floor by contact.impact_speed, is not bounced). A rebound no
     faster than what the step itself added to the approach (at least |g| dt) is resting
     contact, as on the floor: without this a pile hops for ever. Coulomb friction limits
     the tangential impulse to mu x that normal impulse (stick within mu_s, else slide at
     mu_k). Pool faces take part with infinite mass; a sphere a partner drives into a
     face rebounds from it without the step's gravity toward that face (the smooth step
     gave it that speed, and the face had already taken it: bouncing it too adds energy).
     Every impulse is equal and opposite (momentum kept to rounding) and never raises the
     pair's kinetic energy, whatever the order, which is why the sweeps may stop early.
     Then one sweep bottom up lets piles rest on the floor (_settle_on_floor); a sphere
     that rebounded off a partner this step neither rests nor holds another up.
   - position: the overlap left is removed along each contact's normal, mass-weighted (the
     pair's centre of mass stays), with the faces clamping, until no overlap exceeds a
     quarter of OVERLAP_TOLERANCE x the smaller radius or POSITION_SWEEPS are done; after
     the first sweep, overlaps under _POSITION_SLOP are left alone.

Point masses do not spin: friction slows relative sliding, but nothing rolls and no
torque or spin passes between spheres.
"""
import math

import numba
import numpy as np

from .contact import impact_speed

# The most sweeps a step makes over its contacts; each stage stops once nothing changes.
VELOCITY_SWEEPS = 12
POSITION_SWEEPS = 10
# Overlap a pair may keep after a step, as a fraction of the smaller radius.
OVERLAP_TOLERANCE = 0.02
# After the first position sweep, overlaps below this fraction of the smaller radius stay:
# projecting them would chase rounding and pass the last sweep's small pushes through a
# whole pile, sweep after sweep, for nothing the tolerance asks.
_POSITION_SLOP = 0.05 * OVERLAP_TOLERANCE
# The broad phase widens every sphere by this fraction of its radius: pairs at rest apart
# by less than this of their radii's sum are (speculative) contacts too.
SPECULATIVE_MARGIN = 0.02
# An approach slower than _SETTLED_SPEED (m/s) plus a fraction of |g| dt counts as none:
# float noise and solver lag, which the bottom-up sweep and the projection take care of.
# The fraction is _SETTLED_ACROSS, up to _SETTLED_ALONG x the cosine between the normal
# and gravity: sweeps spent below a tenth of a step's fall on weight-bearing contacts only
# passed a pile's weight along (at 1 % throughout, half the contacts of a landing 10 000
# fired in all 12 sweeps; at 10 % along gravity half as many), while a slow collision
# across gravity is a collision all the same, and left unswept it would pass no momentum.
# Such a pair closes by at most that speed x dt in the step, which the projection removes.
_SETTLED_SPEED = 1e-9
_SETTLED_ACROSS = 0.01
_SETTLED_ALONG = 0.1
# Centres this much (of the radii's sum) beyond touching still touch: rounding.
_TOUCHING = 1e-9
# A contact whose normal is within 72 degrees of vertical can hold the upper sphere up
# (one resting on two or three below leans at 30 to 55 degrees, in a loose pile more);
# flatter ones are side by side, and neither holds the other.
_BEARING = 0.3
# Broad-phase levels hold reaches within this factor of each other; each level's cell
# list has at most this many cells per sphere in it (a sparse scene gets coarser cells).
_LEVEL_RATIO = 4.0
_CELLS_PER_SPHERE = 4.0
_MAX_LEVEL = 40


def workspace(count):
    """(reals (float64), wholes (int64)): 1-D scratch the collision pass of `count` spheres
    takes its large arrays from, step after step, instead of allocating them anew.

    The node fixes glibc's mmap threshold at 256 kB, so allocated anew each of them was
    mapped, page-faulted in and unmapped every step (10 000 spheres landing, one A/B run
    under that threshold: 600 against 491 ns a sphere-step). Sized for up to
    contact_capacity(count) contacts; a step with more takes fresh arrays for the rest.
    Pages never touched take no memory; no spheres (or one) take none at all."""
    if count < 2:
        return np.empty(0), np.empty(0, dtype=np.int64)
    contacts = contact_capacity(count)
    reals = 42 * count + 14 * contacts
    wholes = 20 * count + 15 * contacts + 2 * (64 * (_MAX_LEVEL + 1) + 1) + 2
    return np.empty(reals), np.empty(wholes, dtype=np.int64)


@numba.njit(error_model='numpy', inline='always')
def contact_capacity(count):
    """The candidate pairs (and so contacts) the broad phase has room for at first."""
    return 4 * count + 16


@numba.njit(error_model='numpy', inline='always')
def _take(buffer, used, size):
    """(size items of buffer from used on, uninitialised; where the next take starts), or a
    new array when buffer has no room left (see workspace)."""
    if used + size <= buffer.size:
        return buffer[used:used + size], used + size
    return np.empty(size, dtype=buffer.dtype), used


@numba.njit(error_model='numpy', inline='always')
def _cell_of(coordinate, origin, size, cells):
    """The cell (0..cells-1) a coordinate m falls in along one axis of a level's grid."""
    return min(max(int((coordinate - origin) / size), 0), cells - 1)


@numba.njit(error_model='numpy')
def find_contacts(old_position, old_velocity, position, velocity, radius, dt):
    """_find_contacts with arrays of its own (for tests and diagnostics): its first five
    results, the pairs as sphere indices (not rows of its state)."""
    none = np.empty(0), np.empty(0, dtype=np.int64)
    rows, normals, excess, added, closing, order, _, _, _ = _find_contacts(
        old_position, old_velocity, position, velocity, radius, dt, none[0], none[1])
    pairs = np.empty_like(rows)
    for c in range(rows.shape[1]):
        pairs[0, c], pairs[1, c] = order[rows[0, c]], order[rows[1, c]]
    return pairs, normals, excess, added, closing


@numba.njit(error_model='numpy')
def _find_contacts(old_position, old_velocity, position, velocity, radius, dt, reals,
                   wholes):
    """Pairs in contact this step: (pairs (2, m) int64, normals (3, m), excess (m,) m/s,
    added (m,) m/s, closing (m,) m/s, order (n,) int64, state (n, 16), used reals, used
    wholes), m the number of contacts. A pair is two rows of state, which holds the
    spheres in cell order (sphere order[k] in row k; its columns are below).

    normal: unit, from the second sphere toward the first, at the time of impact (at the
    step's start for a pair already touching then; at its end for a speculative one).
    excess: how much faster the pair approaches at the step's end than at impact. added:
    how much the step's own forces added to its approach. closing: the approach speed a
    pair still apart at the step's end may keep (its gap / dt; 0 for a touching one).
    The arrays come from reals and wholes (see workspace); the last two results are how
    much of each they used.

    The broad phase: each sphere's bounding sphere over the step (its centre's path,
    widened by its radius and the speculative margin) goes in a level by its size, reaches
    within _LEVEL_RATIO of each other in one level. Each level is a cell list: a dense grid
    over its spheres' extent, cells at least the level's largest bounding diameter (so
    partners are in the 27 cells around), counting-sorted so that a row of three cells
    along x is one run of memory. A sphere meets its own level's spheres in 9 such rows
    and every finer level's in the rows its bounding box covers there.
    """
    count = radius.size
    centre, used_real = _take(reals, 0, 3 * count)
    centre = centre.reshape((3, count))
    reach, used_real = _take(reals, used_real, count)
    smallest = math.inf
    for i in range(count):
        sweep = 0.0
        for axis in range(3):
            centre[axis, i] = 0.5 * (old_position[axis, i] + position[axis, i])
            sweep += (position[axis, i] - old_position[axis, i]) ** 2
        reach[i] = radius[i] * (1.0 + SPECULATIVE_MARGIN) + 0.5 * math.sqrt(sweep)
        smallest = min(smallest, reach[i])
    level, used_whole = _take(wholes, 0, count)
    level[:] = 0
    top = 0
    for i in range(count):
        bound = smallest * _LEVEL_RATIO
        while reach[i] > bound and level[i] < _MAX_LEVEL:
            bound *= _LEVEL_RATIO
            level[i] += 1
        top = max(top, level[i])
    levels = top + 1
    members = np.zeros(levels, dtype=np.int64)
    largest = np.zeros(levels)
    low = np.full((levels, 3), math.inf)
    high = np.full((levels, 3), -math.inf)
    for i in range(count):
        at = level[i]
        members[at] += 1
        largest[at] = max(largest[at], reach[i])
        for axis in range(3):
            low[at, axis] = min(low[at, axis], centre[axis, i])
            high[at, axis] = max(high[at, axis], centre[axis, i])
    size = np.zeros(levels)
    cells = np.ones((levels, 3), dtype=np.int64)
    first_cell = np.zeros(levels + 1, dtype=np.int64)
    for at in range(levels):
        if members[at] > 0:
            size[at] = 2.0 * largest[at]
            budget = _CELLS_PER_SPHERE * members[at] + 64.0
            while True:
                total = 1.0
                for axis in range(3):
                    total *= math.floor((high[at, axis] - low[at, axis]) / size[at]) + 1.0
                if total <= budget:
                    break
                size[at] *= 1.25  # coarser cells: still at least the bounding diameter
            for axis in range(3):
                cells[at, axis] = int((high[at, axis] - low[at, axis]) / size[at]) + 1
        first_cell[at + 1] = first_cell[at] + cells[at, 0] * cells[at, 1] * cells[at, 2]
    home, used_whole = _take(wholes, used_whole, count)
    where, used_whole = _take(wholes, used_whole, 3 * count)
    where = where.reshape((3, count))
    start, used_whole = _take(wholes, used_whole, first_cell[levels] + 1)
    start[:] = 0
    for i in range(count):
        at = level[i]
        for axis in range(3):
            where[axis, i] = _cell_of(centre[axis, i], low[at, axis], size[at],
                                      cells[at, axis])
        home[i] = first_cell[at] + where[0, i] + cells[at, 0] * (
            where[1, i] + cells[at, 1] * where[2, i])
        start[home[i] + 1] += 1
    for c in range(first_cell[levels]):
        start[c + 1] += start[c]
    fill, used_whole = _take(wholes, used_whole, first_cell[levels])
    fill[:] = start[:-1]
    order, used_whole = _take(wholes, used_whole, count)
    for i in range(count):
        order[fill[home[i]]] = i
        fill[home[i]] += 1
    # The bounding spheres, and the state the narrow phase reads, in cell order: the
    # candidate test reads memory in a row, and a pair's two rows are near each other.
    sorted_bound, used_real = _take(reals, used_real, 4 * count)
    sorted_bound = sorted_bound.reshape((count, 4))
    sorted_cell, used_whole = _take(wholes, used_whole, 4 * count)
    sorted_cell = sorted_cell.reshape((count, 4))  # its cell x, y, z and its level
    # Columns: position at the step's start (0-2) and end (3-5), m; velocity at its start
    # (6-8) and end (9-11), m/s; radius (12), m; a row is two cache lines.
    sorted_state, used_real = _take(reals, used_real, 16 * count)
    sorted_state = sorted_state.reshape((count, 16))
    for k in range(count):
        i = order[k]
        sorted_bound[k, 0], sorted_bound[k, 1] = centre[0, i], centre[1, i]
        sorted_bound[k, 2], sorted_bound[k, 3] = centre[2, i], reach[i]
        sorted_cell[k, 0], sorted_cell[k, 1] = where[0, i], where[1, i]
        sorted_cell[k, 2], sorted_cell[k, 3] = where[2, i], level[i]
        for axis in range(3):
            sorted_state[k, axis] = old_position[axis, i]
            sorted_state[k, 3 + axis] = position[axis, i]
            sorted_state[k, 6 + axis] = old_velocity[axis, i]
            sorted_state[k, 9 + axis] = velocity[axis, i]
        sorted_state[k, 12] = radius[i]

    # Candidates first (bounding spheres that meet), in a loop of their own: the narrow
    # phase inside the cell loops ran six times slower than on its own.
    capacity = contact_capacity(count)
    candidates, used_whole = _take(wholes, used_whole, 2 * capacity)
    candidates = candidates.reshape((2, capacity))
    total = _candidate_pairs(sorted_cell, members, cells, first_cell, start, sorted_bound,
                             largest, low, size, candidates)
    if total > candidates.shape[1]:
        candidates = np.empty((2, total), dtype=np.int64)
        _candidate_pairs(sorted_cell, members, cells, first_cell, start, sorted_bound,
                         largest, low, size, candidates)
    # Every candidate is a contact: touching within the step, or speculative (_narrow_phase).
    facts, used_real = _take(reals, used_real, 6 * total)
    facts = facts.reshape((6, total))  # normal (3), excess, added, closing
    for c in range(total):
        normal, excess, added, closing = _narrow_phase(sorted_state, candidates[0, c],
                                                       candidates[1, c], dt)
        facts[0, c], facts[1, c], facts[2, c] = normal
        facts[3, c], facts[4, c], facts[5, c] = excess, added, closing
    return (candidates[:, :total], facts[:3], facts[3], facts[4], facts[5], order,
            sorted_state, used_real, used_whole)


@numba.njit(error_model='numpy')
def _candidate_pairs(sorted_cell, members, cells, first_cell, start, sorted_bound, largest,
                     low, size, out):
    """The pairs (k, m) of cell-order rows whose bounding spheres meet, each once, written
    into out (2, capacity) while they fit; returns how many there are (see _find_contacts
    for the grid)."""
    count = sorted_cell.shape[0]
    capacity = out.shape[1]
    total = 0
    for k in range(count):
        cx, cy_, cz_, reach_i = (sorted_bound[k, 0], sorted_bound[k, 1], sorted_bound[k, 2],
                                 sorted_bound[k, 3])
        its_level = sorted_cell[k, 3]
        for at in range(its_level + 1):
            if members[at] == 0:
                continue
            own = at == its_level
            if own:
                # Half the neighbourhood: the rest of this sphere's own cell (sorted after
                # it) and the next cell along x, then the three rows ahead in y and the
                # nine in z; each pair is met once, from the sphere met first.
                x, y, z = sorted_cell[k, 0], sorted_cell[k, 1], sorted_cell[k, 2]
                x_low, x_high = max(x - 1, 0), min(x + 1, cells[at, 0] - 1)
                y_low, y_high = y, min(y + 1, cells[at, 1] - 1)
                z_low, z_high = z, min(z + 1, cells[at, 2] - 1)
            else:  # a finer level: the cells this sphere's reach and theirs can span
                span = reach_i + largest[at]
                x_low = _cell_of(cx - span, low[at, 0], size[at], cells[at, 0])
                x_high = _cell_of(cx + span, low[at, 0], size[at], cells[at, 0])
                y_low = _cell_of(cy_ - span, low[at, 1], size[at], cells[at, 1])
                y_high = _cell_of(cy_ + span, low[at, 1], size[at], cells[at, 1])
                z_low = _cell_of(cz_ - span, low[at, 2], size[at], cells[at, 2])
                z_high = _cell_of(cz_ + span, low[at, 2], size[at], cells[at, 2])
            for cz in range(z_low, z_high + 1):
                # Own level, the row of z ahead: all nine cells; its own z: y and y + 1.
                ys = max(y_low - 1, 0) if own and cz > z_low else y_low
                for cy in range(ys, y_high + 1):
                    row = first_cell[at] + cells[at, 0] * (cy + cells[at, 1] * cz)
                    first, last = start[row + x_low], start[row + x_high + 1]
                    if own and cz == z_low and cy == y_low:
                        first = k + 1  # its own cell after it, and the next along x
                    for m in range(first, last):
                        reach_ij = reach_i + sorted_bound[m, 3]
                        gap2 = ((cx - sorted_bound[m, 0]) ** 2 + (cy_ - sorted_bound[m, 1]) ** 2
                                + (cz_ - sorted_bound[m, 2]) ** 2)
                        # Written whether they meet or not, and kept if they do: no
                        # branch to mispredict (most do not).
                        if total < capacity:
                            out[0, total], out[1, total] = k, m
                        total += gap2 <= reach_ij * reach_ij
    return total


@numba.njit(error_model='numpy', inline='always')
def _narrow_phase(state, i, j, dt):
    """(normal (3-tuple), excess m/s, added m/s, closing m/s) of the spheres of rows i, j
    of state (_find_contacts' sorted_state), whose bounding spheres met; see _find_contacts."""
    reach = state[i, 12] + state[j, 12]
    d0 = (state[i, 0] - state[j, 0], state[i, 1] - state[j, 1], state[i, 2] - state[j, 2])
    d1 = (state[i, 3] - state[j, 3], state[i, 4] - state[j, 4], state[i, 5] - state[j, 5])
    e = (d1[0] - d0[0], d1[1] - d0[1], d1[2] - d0[2])
    start_gap = d0[0] * d0[0] + d0[1] * d0[1] + d0[2] * d0[2] - reach * reach
    impact = 0.0  # touching (or overlapping) from the step's start
    if start_gap > 0.0:
        a = e[0] * e[0] + e[1] * e[1] + e[2] * e[2]
        b = d0[0] * e[0] + d0[1] * e[1] + d0[2] * e[2]
        discriminant = b * b - a * start_gap
        if b < 0.0 and discriminant >= 0.0:
            impact = start_gap / (-b + math.sqrt(discriminant))  # the smaller root, stably
        else:
            impact = math.inf  # not closing, or passing wide
    if impact <= 1.0:
        d = (d0[0] + impact * e[0], d0[1] + impact * e[1], d0[2] + impact * e[2])
    else:
        # Apart all step: a contact all the same (speculative), closing no faster than
        # would shut its gap in the step. Impulses elsewhere in this step can set it
        # moving toward each other: unseen, a light sphere struck from above was driven
        # 2 cm into the one below in one step (a column of spheres landing in water). The
        # broad phase's bounding spheres, which met, bound which pairs these are.
        end_gap = math.sqrt(d1[0] * d1[0] + d1[1] * d1[1] + d1[2] * d1[2]) - reach
        if end_gap <= _TOUCHING * reach:
            impact = 1.0  # touching at the end (a row of spheres at rest): a contact
        d = d1
    length = math.sqrt(d[0] * d[0] + d[1] * d[1] + d[2] * d[2])
    if length > 0.0:
        normal = (d[0] / length, d[1] / length, d[2] / length)
    else:
        normal = (0.0, 0.0, 1.0)  # centres at one point: any direction is as good
    if impact > 1.0:
        return normal, 0.0, 0.0, (length - reach) / dt
    approach_start = -((state[i, 6] - state[j, 6]) * normal[0]
                       + (state[i, 7] - state[j, 7]) * normal[1]
                       + (state[i, 8] - state[j, 8]) * normal[2])
    approach_end = -((state[i, 9] - state[j, 9]) * normal[0]
                     + (state[i, 10] - state[j, 10]) * normal[1]
                     + (state[i, 11] - state[j, 11]) * normal[2])
    before = max(d0[0] * normal[0] + d0[1] * normal[1] + d0[2] * normal[2] - reach, 0.0)
    past = max(reach - (d1[0] * normal[0] + d1[1] * normal[1] + d1[2] * normal[2]), 0.0)
    at_impact = impact_speed(approach_start, approach_end, before, past, dt)
    return normal, max(approach_end - at_impact, 0.0), approach_end - approach_start, 0.0


@numba.njit(error_model='numpy', inline='always')
def _face_bounce(approach, restitution, resting_speed):
    """Speed away from a face (or partner) after an approach (m/s) resolved with
    restitution: none when no faster than resting_speed (resting contact)."""
    bounced = restitution * approach
    return bounced if bounced > resting_speed else 0.0


@numba.njit(error_model='numpy', inline='always')
def _against_face_pair(low, high, p, q, v, slack, restitution, resting_speed, gravity_step):
    """One axis: the velocity (m/s) of a sphere at p at the step's end and q at its start
    (m, its centre's limits low, high) after it meets the face it is on, at either, and
    moving into, if any. gravity_step: what gravity adds to the velocity along the axis in
    a step, m/s. (A sphere that buoyancy lifts off the floor within the step, then struck
    from above, is still on the floor: without that its partner's fall went unchecked.)

    An impulse from a partner drove it into the face some time within the step, so it
    left the face with at most that time's gravity still to come: the rebound gives up
    the step's gravity into the face (without it a sphere on the floor, struck from
    above, bounced back with the fall its partner made after impact, and the pair gained
    energy)."""
    if v < 0.0 and min(p, q) <= low + slack:
        return max(_face_bounce(-v, restitution, resting_speed) + min(gravity_step, 0.0),
                   0.0)
    if v > 0.0 and max(p, q) >= high - slack:
        return -max(_face_bounce(v, restitution, resting_speed) - max(gravity_step, 0.0),
                    0.0)
    return v


@numba.njit(error_model='numpy', inline='always')
def _on_a_face(faces, r, position, start, k):
    """Whether the sphere of row k (radius r m) is on a face at the step's end (position)
    or start, where _velocity_against_faces may change its velocity."""
    slack = 1e-9 * r
    for axis in range(3):
        if (min(position[k, axis], start[k, axis]) <= faces[axis] + r + slack
                or max(position[k, axis], start[k, axis]) >= faces[axis + 3] - r - slack):
            return True
    return False


@numba.njit(error_model='numpy', inline='always')
def _velocity_against_faces(faces, r, position, start, velocity, k, restitution,
                            resting_speed, gravity_step):
    """The sphere of row k (radius r m), on a face (at the step's end, position, or its
    start) and moving into it after an impulse, bounces off it (or stops); gravity_step:
    gravity x dt, m/s (see _against_face_pair)."""
    slack = 1e-9 * r
    for axis in range(3):
        velocity[k, axis] = _against_face_pair(faces[axis] + r, faces[axis + 3] - r,
                                               position[k, axis], start[k, axis],
                                               velocity[k, axis], slack, restitution,
                                               resting_speed, gravity_step[axis])


@numba.njit(error_model='numpy', inline='always')
def _shift(position, r, k, sx, sy, sz, faces, has_faces):
    """Move the sphere of row k (radius r m) by (sx, sy, sz) m to undo an overlap, but not
    through a face."""
    for axis, step in ((0, sx), (1, sy), (2, sz)):
        moved = position[k, axis] + step
        if has_faces:
            moved = min(max(moved, faces[axis] + r), faces[axis + 3] - r)
        position[k, axis] = moved


# Columns of the per-contact rows resolve_collisions sweeps over.
_NX, _NY, _NZ, _ALLOWED, _EXCESS, _RESTING, _CLOSING, _REDUCED_MASS = range(8)


@numba.njit(error_model='numpy')
def resolve_collisions(old_position, old_velocity, position, velocity, mass, radius, faces,
                       has_faces, contact, has_friction, resting_speed, gravity_step,
                       floor_supports, failed, reals, wholes, dt):
    """Find and resolve this step's sphere-sphere contacts in place (position, velocity:
    the step's end; old_*: its start). faces: the pool's (min_x, min_y, min_z, max_x,
    max_y, max_z) when has_faces. contact: (restitution, static_friction,
    kinetic_friction, rolling_friction). resting_speed: m/s, |g| dt. gravity_step: (3,)
    m/s, g dt (zero without gravity). floor_supports:
    gravity points down (-z) onto a floor, so piles rest on it (see _settle_on_floor).

    Returns how many spheres the step guard put back (flagged in failed): a sphere the
    impulses left non-finite goes back to the step's start, at rest. reals, wholes: the
    scratch its arrays come from (see workspace; empty ones will do)."""
    if radius.size < 2:
        return 0
    (pairs, normals, excess, added, closing, order, state, used_real,
     used_whole) = _find_contacts(old_position, old_velocity, position, velocity, radius,
                                  dt, reals, wholes)
    found = pairs.shape[1]
    if found == 0:
        return 0
    count = radius.size
    restitution, static_friction, kinetic_friction = contact[0], contact[1], contact[2]
    # The sweeps run on copies in rows: each sphere in contact (in cell order) has its x,
    # y, z in one cache line, and each contact its facts in one row, so a sweep reads
    # memory near what it just read.
    row_of, used_whole = _take(wholes, used_whole, count)  # state's row -> ours, or -1
    row_of[:] = -1
    for c in range(found):
        row_of[pairs[0, c]], row_of[pairs[1, c]] = 0, 0
    member, used_whole = _take(wholes, used_whole, count)  # our row -> state's
    members = 0
    for k in range(count):
        if row_of[k] == 0:
            row_of[k] = members
            member[members] = k
            members += 1
    ends, used_whole = _take(wholes, used_whole, 2 * found)
    ends = ends.reshape((found, 2))  # contact -> its two rows
    for c in range(found):
        ends[c, 0], ends[c, 1] = row_of[pairs[0, c]], row_of[pairs[1, c]]
    rows, used_real = _take(reals, used_real, 16 * members)
    rows = rows.reshape((4, members, 4))  # the fourth column pads a row to 32 bytes
    rows[:, :, 3] = 0.0
    p = rows[0]  # position, m
    v = rows[1]  # velocity, m/s
    start = rows[2]  # position at the step's start, m
    entry = rows[3]  # position before the sweeps, m
    inverse_mass, used_real = _take(reals, used_real, members)  # 1/kg
    r, used_real = _take(reals, used_real, members)  # radius, m
    on_face = np.zeros(members, dtype=np.bool_)
    for k in range(members):
        row = member[k]
        for axis in range(3):  # as _find_contacts' state holds them
            p[k, axis] = state[row, 3 + axis]
            v[k, axis] = state[row, 9 + axis]
            start[k, axis] = state[row, axis]
            entry[k, axis] = state[row, 3 + axis]
        inverse_mass[k] = 1.0 / mass[order[row]]
        r[k] = state[row, 12]
        if has_faces:
            on_face[k] = _on_a_face(faces, r[k], p, start, k)
    facts, used_real = _take(reals, used_real, 8 * found)
    facts = facts.reshape((found, 8))
    for c in range(found):
        a, b = ends[c, 0], ends[c, 1]
        facts[c, _NX], facts[c, _NY], facts[c, _NZ] = normals[0, c], normals[1, c], normals[2, c]
        # What a pair still apart may keep of its approach: its gap / dt, or the approach
        # it came with if faster. It has not hit yet (the next step finds the impact, and
        # bounces it); this only stops impulses elsewhere in this step driving it through
        # its gap.
        facts[c, _ALLOWED] = 0.0 if not closing[c] > 0.0 else max(closing[c], -(
            (v[a, 0] - v[b, 0]) * normals[0, c] + (v[a, 1] - v[b, 1]) * normals[1, c]
            + (v[a, 2] - v[b, 2]) * normals[2, c]))
        facts[c, _EXCESS] = excess[c]
        facts[c, _RESTING] = max(added[c], resting_speed)
        facts[c, _CLOSING] = closing[c]
        facts[c, _REDUCED_MASS] = 1.0 / (inverse_mass[a] + inverse_mass[b])  # kg
    # Sweep at which each row's velocity (then position) last changed: a contact neither
    # of whose spheres changed since its last visit is as it was, and is skipped.
    changed_in, used_whole = _take(wholes, used_whole, members)
    changed_in[:] = 0
    rebounded = np.zeros(members, dtype=np.bool_)  # bounced off a partner this step
    settled_across = _SETTLED_SPEED + _SETTLED_ACROSS * resting_speed
    # Down, as a unit vector x _SETTLED_ALONG x |g| dt (gravity_step is zero without gravity).
    down = (_SETTLED_ALONG * gravity_step[0], _SETTLED_ALONG * gravity_step[1],
            _SETTLED_ALONG * gravity_step[2])
    for sweep in range(1, VELOCITY_SWEEPS + 1):
        changed = False
        for c in range(found):
            a, b = ends[c, 0], ends[c, 1]
            if changed_in[a] < sweep - 1 and changed_in[b] < sweep - 1:
                continue
            nx, ny, nz = facts[c, _NX], facts[c, _NY], facts[c, _NZ]
            rx = v[a, 0] - v[b, 0]
            ry = v[a, 1] - v[b, 1]
            rz = v[a, 2] - v[b, 2]
            approach = -(rx * nx + ry * ny + rz * nz) - facts[c, _ALLOWED]
            settled = max(settled_across, _SETTLED_SPEED + abs(
                nx * down[0] + ny * down[1] + nz * down[2]))
            if not approach > settled:
                continue
            changed = True
            changed_in[a], changed_in[b] = sweep, sweep
            # The rebound keeps restitution x the speed at impact; what the step added
            # after impact, and rebounds within resting speed, are not bounced. A pair
            # still apart has not hit: it is only kept from closing its gap too fast.
            bounced = 0.0 if facts[c, _CLOSING] > 0.0 else _face_bounce(
                max(approach - facts[c, _EXCESS], 0.0), restitution, facts[c, _RESTING])
            if bounced > 0.0:
                rebounded[a], rebounded[b] = True, True
            wi, wj = inverse_mass[a], inverse_mass[b]
            impulse = (approach + bounced) * facts[c, _REDUCED_MASS]  # N s along the normal
            fx, fy, fz = impulse * nx, impulse * ny, impulse * nz  # on the first sphere
            if has_friction:
                # The sliding the normal impulse leaves is the sliding before it (that
                # impulse is along the normal): found from the same velocities, and both
                # impulses applied at once.
                along = rx * nx + ry * ny + rz * nz
                tx, ty, tz = rx - along * nx, ry - along * ny, rz - along * nz
                sliding = math.sqrt(tx * tx + ty * ty + tz * tz)
                if sliding > 0.0:
                    stick = sliding * facts[c, _REDUCED_MASS]  # the impulse that stops it
                    grip = (stick if stick <= static_friction * impulse
                            else kinetic_friction * impulse) / sliding
                    fx, fy, fz = fx - grip * tx, fy - grip * ty, fz - grip * tz
            v[a, 0] += wi * fx
            v[b, 0] -= wj * fx
            v[a, 1] += wi * fy
            v[b, 1] -= wj * fy
            v[a, 2] += wi * fz
            v[b, 2] -= wj * fz
            if has_faces:
                if on_face[a]:
                    _velocity_against_faces(faces, r[a], p, start, v, a, restitution,
                                            resting_speed, gravity_step)
                if on_face[b]:
                    _velocity_against_faces(faces, r[b], p, start, v, b, restitution,
                                            resting_speed, gravity_step)
        if not changed:
            break
    resting = floor_supports and has_faces
    if resting:
        supported = _settle_on_floor(ends, facts, p, start, v, r, rebounded, faces,
                                     static_friction, kinetic_friction, has_friction,
                                     resting_speed, wholes, used_whole)
    else:
        supported = np.zeros(0, dtype=np.bool_)
    changed_in[:] = 0
    for sweep in range(1, POSITION_SWEEPS + 1):
        worst = 0.0
        for c in range(found):
            a, b = ends[c, 0], ends[c, 1]
            if changed_in[a] < sweep - 1 and changed_in[b] < sweep - 1:
                continue
            nx, ny, nz = facts[c, _NX], facts[c, _NY], facts[c, _NZ]
            separation = ((p[a, 0] - p[b, 0]) * nx + (p[a, 1] - p[b, 1]) * ny
                          + (p[a, 2] - p[b, 2]) * nz)
            overlap = r[a] + r[b] - separation
            smaller = min(r[a], r[b])
            if not overlap > (0.0 if sweep == 1 else _POSITION_SLOP * smaller):
                continue
            changed_in[a], changed_in[b] = sweep, sweep
            worst = max(worst, overlap / smaller)
            share_a = inverse_mass[a] * facts[c, _REDUCED_MASS]
            share_b = inverse_mass[b] * facts[c, _REDUCED_MASS]
            # Along the normal: the overlap, shared by inverse mass (the pair's centre of
            # mass stays).
            px, py, pz = overlap * nx, overlap * ny, overlap * nz
            if has_friction and sweep == 1:
                # Across it: Coulomb on the step's relative sliding (Macklin et al. 2014),
                # undone while within mu_s x the overlap, else by mu_k x it. In velocity
                # alone each step's small slide would stay, and a pile creep flat.
                sx = (p[a, 0] - start[a, 0]) - (p[b, 0] - start[b, 0])
                sy = (p[a, 1] - start[a, 1]) - (p[b, 1] - start[b, 1])
                sz = (p[a, 2] - start[a, 2]) - (p[b, 2] - start[b, 2])
                along = sx * nx + sy * ny + sz * nz
                tx, ty, tz = sx - along * nx, sy - along * ny, sz - along * nz
                slid = math.sqrt(tx * tx + ty * ty + tz * tz)
                if slid > 0.0:
                    undone = (1.0 if slid <= static_friction * overlap
                              else kinetic_friction * overlap / slid)
                    px, py, pz = px - undone * tx, py - undone * ty, pz - undone * tz
            _shift(p, r[a], a, share_a * px, share_a * py, share_a * pz, faces, has_faces)
            _shift(p, r[b], b, -share_b * px, -share_b * py, -share_b * pz, faces, has_faces)
        if worst <= 0.25 * OVERLAP_TOLERANCE:
            break
    if resting:
        # A resting sphere moves up and down as its position did, if that is slower: what
        # is left of its velocity after the sweeps is the solver's lag, which the
        # projection has undone in position (as position-based dynamics derives velocity),
        # and the floor below takes that momentum. Across, the floor takes momentum only
        # by friction: there the velocity takes on what the projection itself moved the
        # sphere / dt, if that slows it, and only with friction, by at most a step of
        # Coulomb friction under its weight (mu_s |g| dt). The whole step's move / dt, as
        # it was, took momentum no floor gives up (two spheres meeting slowly on a
        # frictionless floor kept half of theirs), and under any integrator but
        # semi-implicit Euler it is the velocity at mid-step: spheres touching one another
        # on the floor, pushed, were held back as by friction twice.
        most_across = static_friction * resting_speed if has_friction else 0.0
        for k in range(members):
            if not supported[k] or rebounded[k]:
                continue  # a bounce is not lag
            moved = p[k, 2] - start[k, 2]
            if abs(moved) < dt * abs(v[k, 2]):
                v[k, 2] = moved / dt
            sx, sy = (p[k, 0] - entry[k, 0]) / dt, (p[k, 1] - entry[k, 1]) / dt
            tx, ty = v[k, 0] + sx, v[k, 1] + sy
            if (tx * tx + ty * ty < v[k, 0] * v[k, 0] + v[k, 1] * v[k, 1]
                    and sx * sx + sy * sy <= most_across * most_across):
                v[k, 0], v[k, 1] = tx, ty
    put_back = 0
    for k in range(members):
        i = order[member[k]]
        for axis in range(3):
            position[axis, i] = p[k, axis]
            velocity[axis, i] = v[k, axis]
        if failed[i] or (p[k, 0] * 0.0 + p[k, 1] * 0.0 + p[k, 2] * 0.0 + v[k, 0] * 0.0
                         + v[k, 1] * 0.0 + v[k, 2] * 0.0) == 0.0:
            continue
        for axis in range(3):
            position[axis, i] = old_position[axis, i]
            velocity[axis, i] = 0.0
        failed[i] = 1
        put_back += 1
    return put_back


@numba.njit(error_model='numpy')
def _settle_on_floor(ends, facts, p, start, v, r, rebounded, faces, static_friction,
                     kinetic_friction, has_friction, resting_speed, wholes, used_whole):
    """One last sweep, bottom up, that lets a pile rest (shock propagation, Guendelman et
    al. 2003): a sphere on the floor, or on one that rests, is as immovable as the floor
    for the sphere above it, whose approach (and, within Coulomb, its sliding) stops.

    Sequential impulses alone pass a pile's weight down a layer per sweep, so a pile of k
    layers would keep velocities of order g dt unless swept ~k^2 times. The momentum so
    taken goes to the floor, as in a resting pile it does. ends, facts, p, start, v, r,
    rebounded: the rows of resolve_collisions; wholes from used_whole on: scratch (see
    workspace). A sphere on the floor at the step's start or end rests on it. A sphere that
    bounced off a partner in this step neither rests nor holds anything up: it is moving,
    and treating it as immovable would hand its speed, at the floor's expense, to whatever
    lies on it (a light sphere on the floor, struck by a heavy one, sent the heavy one up
    at its own rebound speed). Nor does one on the floor rising faster than a step's fall
    (resting_speed) hold anything up: it is lifting off (a buoyant sphere rising off the
    floor at 0.44 m/s under one that slid across it pushed that one on along their slanted
    normal and was then stopped as resting: the pair gained energy). Above the floor the
    rest correction below leaves a resting sphere rising by what the projection lifted it
    (up to ~0.1 m/s): taking such spheres as lifting off too left a pile's upper layers
    unsettled, its late steps twice as dear.

    Returns supported (rows,) bool: the spheres found resting."""
    found = ends.shape[0]
    members = r.size
    # Contacts ordered by the lower sphere's height: a counting sort on layers of the
    # smallest radius.
    lowest, highest, smallest = math.inf, -math.inf, math.inf
    for k in range(members):
        lowest = min(lowest, p[k, 2])
        highest = max(highest, p[k, 2])
        smallest = min(smallest, r[k])
    layers = int(min((highest - lowest) / smallest, 4.0 * found)) + 1
    layer_start, used_whole = _take(wholes, used_whole, layers + 1)
    layer_start[:] = 0
    layer, used_whole = _take(wholes, used_whole, found)
    for c in range(found):
        height = min(p[ends[c, 0], 2], p[ends[c, 1], 2])
        layer[c] = min(int((height - lowest) / smallest), layers - 1)
        layer_start[layer[c] + 1] += 1
    for k in range(layers):
        layer_start[k + 1] += layer_start[k]
    order, used_whole = _take(wholes, used_whole, found)
    for c in range(found):
        order[layer_start[layer[c]]] = c
        layer_start[layer[c]] += 1
    supported = np.empty(members, dtype=np.bool_)
    lifting = np.empty(members, dtype=np.bool_)
    for k in range(members):
        supported[k] = (min(p[k, 2], start[k, 2]) <= faces[2] + r[k] * (1.0 + 1e-9)
                        and not rebounded[k])
        # On the floor and rising faster than a step's fall: lifting off, holds nothing up
        # (it is still a resting sphere for the rest correction).
        lifting[k] = supported[k] and v[k, 2] > resting_speed
    # Who rests on what: sorted bottom up, a few passes reach every layer (a pass misses
    # only a sphere held up through one of its own layer met later).
    carries, used_whole = _take(wholes, used_whole, found)
    carries[:] = 0  # 1: the first sphere rests on the second
    for _ in range(8):
        spread = False
        for k in range(found):
            c = order[k]
            if facts[c, _CLOSING] > resting_speed or carries[c] != 0:
                continue  # apart by more than a step's fall: holds nothing up; or known
            first, second = ends[c, 0], ends[c, 1]
            if facts[c, _NZ] > _BEARING and supported[second] and not lifting[second]:
                carries[c], upper = 1, first
            elif facts[c, _NZ] < -_BEARING and supported[first] and not lifting[first]:
                carries[c], upper = 2, second
            else:
                continue
            if rebounded[upper]:
                carries[c] = 0
                continue
            spread = spread or not supported[upper]
            supported[upper] = True
        if not spread:
            break
    for k in range(found):
        c = order[k]
        if carries[c] == 0:
            continue
        if carries[c] == 1:
            upper, lower, sign = ends[c, 0], ends[c, 1], 1.0
        else:
            upper, lower, sign = ends[c, 1], ends[c, 0], -1.0
        nx, ny, nz = sign * facts[c, _NX], sign * facts[c, _NY], sign * facts[c, _NZ]
        rx = v[upper, 0] - v[lower, 0]
        ry = v[upper, 1] - v[lower, 1]
        rz = v[upper, 2] - v[lower, 2]
        approach = -(rx * nx + ry * ny + rz * nz) - facts[c, _CLOSING]
        if not approach > 0.0:
            continue
        v[upper, 0] += approach * nx
        v[upper, 1] += approach * ny
        v[upper, 2] += approach * nz
        if has_friction:
            rx, ry, rz = rx + approach * nx, ry + approach * ny, rz + approach * nz
            tx, ty, tz = rx, ry, rz  # normal part now zero
            sliding = math.sqrt(tx * tx + ty * ty + tz * tz)
            if sliding > 0.0:
                grip = (1.0 if sliding <= static_friction * approach
                        else kinetic_friction * approach / sliding)
                v[upper, 0] -= grip * tx
                v[upper, 1] -= grip * ty
                v[upper, 2] -= grip * tz
    return supported


def overlaps(position, radius):
    """(pairs (2, m) int64, depth (m,) m) of every pair of spheres that overlap, found by
    the broad phase: for diagnostics and benchmarks. position: (3, n) m, radius (n,) m."""
    position = np.ascontiguousarray(position, dtype=float)
    radius = np.ascontiguousarray(radius, dtype=float)
    if radius.size < 2:
        return np.zeros((2, 0), dtype=np.int64), np.zeros(0)
    still = np.zeros_like(position)
    pairs = find_contacts(position, still, position, still, radius, 1.0)[0]
    depth = radius[pairs[0]] + radius[pairs[1]] - np.linalg.norm(
        position[:, pairs[0]] - position[:, pairs[1]], axis=0)
    return pairs[:, depth > 0.0], depth[depth > 0.0]
