"""Sphere-sphere contact, the `collisions` effect: after each step's smooth forces and faces.

Three stages, each compiled, none with per-pair Python:

1. Broad phase (find_contacts): each sphere's bounding sphere over the step (the segment its
   centre moved along, widened by its radius and SPECULATIVE_MARGIN), so a fast sphere
   cannot pass through another within a step. Bounding spheres go into levels by size, and
   each level is a cell list (a dense grid, counting-sorted): linear in the number of
   spheres, whatever the mix of radii.
2. Narrow phase: the relative motion of the two centres over the step is taken as linear;
   a pair is in contact when the centres come within the sum of the radii, and the normal
   is the direction between them at that first moment (time of impact). Pairs still apart
   by less than the margin are speculative contacts.
3. Resolution, in sweeps over the contacts (sequential impulses, Gauss-Seidel):
   - velocity: a pair approaching along its normal gets the binary-collision impulse that
     sends it apart at restitution x its speed at impact (the step's own approach after
     impact, found as for the floor by contact.impact_speed, is not bounced). A rebound no
     faster than what the step itself added to the approach (at least |g| dt) is resting
     contact, as on the floor: without this a pile hops for ever. Coulomb friction limits
     the tangential impulse to mu x that normal impulse (stick within mu_s, else slide at
     mu_k). Pool faces take part with infinite mass. Every impulse is equal and opposite
     (momentum kept to rounding) and never raises the pair's kinetic energy, whatever the
     order, which is why the sweeps may stop early. Then one sweep bottom up lets piles
     rest on the floor (_settle_on_floor).
   - position: the overlap left is removed along each contact's normal, mass-weighted (the
     pair's centre of mass stays), with the faces clamping, until no overlap exceeds a
     quarter of OVERLAP_TOLERANCE x the smaller radius or POSITION_SWEEPS are done.

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
# Pairs apart by less than this fraction of their radii's sum at a step's end are contacts
# too (speculative): the broad phase widens every sphere by it.
SPECULATIVE_MARGIN = 0.02
# An approach slower than this (m/s), plus 1 % of |g| dt, counts as none: float noise and
# solver lag the bottom-up sweep and the projection take care of.
_SETTLED_SPEED = 1e-9
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


@numba.njit(error_model='numpy')
def _grow(array, size):
    bigger = np.empty((array.shape[0], 2 * array.shape[1]), dtype=array.dtype)
    bigger[:, :size] = array[:, :size]
    return bigger


@numba.njit(error_model='numpy', inline='always')
def _cell_of(coordinate, origin, size, cells):
    """The cell (0..cells-1) a coordinate m falls in along one axis of a level's grid."""
    return min(max(int((coordinate - origin) / size), 0), cells - 1)


@numba.njit(error_model='numpy')
def find_contacts(old_position, old_velocity, position, velocity, radius, dt):
    """Pairs in contact this step: (pairs (2, m) int64, normals (3, m), excess (m,) m/s,
    added (m,) m/s, closing (m,) m/s), m the number of contacts.

    normal: unit, from the second sphere toward the first, at the time of impact (at the
    step's start for a pair already touching then; at its end for a speculative one).
    excess: how much faster the pair approaches at the step's end than at impact. added:
    how much the step's own forces added to its approach. closing: the approach speed a
    pair still apart at the step's end may keep (its gap / dt; 0 for a touching one).

    The broad phase: each sphere's bounding sphere over the step (its centre's path,
    widened by its radius and the speculative margin) goes in a level by its size, reaches
    within _LEVEL_RATIO of each other in one level. Each level is a cell list: a dense grid
    over its spheres' extent, cells at least the level's largest bounding diameter (so
    partners are in the 27 cells around), counting-sorted so that a row of three cells
    along x is one run of memory. A sphere meets its own level's spheres in 9 such rows
    and every finer level's in the rows its bounding box covers there.
    """
    count = radius.size
    centre = np.empty((3, count))
    reach = np.empty(count)
    smallest = math.inf
    for i in range(count):
        sweep = 0.0
        for axis in range(3):
            centre[axis, i] = 0.5 * (old_position[axis, i] + position[axis, i])
            sweep += (position[axis, i] - old_position[axis, i]) ** 2
        reach[i] = radius[i] * (1.0 + SPECULATIVE_MARGIN) + 0.5 * math.sqrt(sweep)
        smallest = min(smallest, reach[i])
    level = np.zeros(count, dtype=np.int64)
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
    home = np.empty(count, dtype=np.int64)
    where = np.empty((3, count), dtype=np.int64)
    start = np.zeros(first_cell[levels] + 1, dtype=np.int64)
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
    fill = start[:-1].copy()
    order = np.empty(count, dtype=np.int64)
    for i in range(count):
        order[fill[home[i]]] = i
        fill[home[i]] += 1
    # The bounding spheres in cell order: the candidate test reads memory in a row.
    sorted_bound = np.empty((count, 4))
    for k in range(count):
        i = order[k]
        sorted_bound[k, 0], sorted_bound[k, 1] = centre[0, i], centre[1, i]
        sorted_bound[k, 2], sorted_bound[k, 3] = centre[2, i], reach[i]

    pairs = np.empty((2, 4 * count + 16), dtype=np.int64)
    facts = np.empty((6, 4 * count + 16))  # normal (3), excess, added, closing
    found = 0
    for k in range(count):
        i = order[k]
        cx, cy_, cz_, reach_i = (sorted_bound[k, 0], sorted_bound[k, 1], sorted_bound[k, 2],
                                 sorted_bound[k, 3])
        for at in range(level[i] + 1):
            if members[at] == 0:
                continue
            own = at == level[i]
            if own:
                # Half the neighbourhood: the rest of this sphere's own cell (sorted after
                # it) and the next cell along x, then the three rows ahead in y and the
                # nine in z; each pair is met once, from the sphere met first.
                x, y, z = where[0, i], where[1, i], where[2, i]
                x_low, x_high = max(x - 1, 0), min(x + 1, cells[at, 0] - 1)
                y_low, y_high = y, min(y + 1, cells[at, 1] - 1)
                z_low, z_high = z, min(z + 1, cells[at, 2] - 1)
            else:  # a finer level: the cells this sphere's reach and theirs can span
                span = reach[i] + largest[at]
                x_low = _cell_of(centre[0, i] - span, low[at, 0], size[at], cells[at, 0])
                x_high = _cell_of(centre[0, i] + span, low[at, 0], size[at], cells[at, 0])
                y_low = _cell_of(centre[1, i] - span, low[at, 1], size[at], cells[at, 1])
                y_high = _cell_of(centre[1, i] + span, low[at, 1], size[at], cells[at, 1])
                z_low = _cell_of(centre[2, i] - span, low[at, 2], size[at], cells[at, 2])
                z_high = _cell_of(centre[2, i] + span, low[at, 2], size[at], cells[at, 2])
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
                        if gap2 > reach_ij * reach_ij:
                            continue
                        j = order[m]
                        touching, normal, excess, added, closing = _narrow_phase(
                            old_position, old_velocity, position, velocity, radius, i, j, dt)
                        if not touching:
                            continue
                        if found == pairs.shape[1]:
                            pairs, facts = _grow(pairs, found), _grow(facts, found)
                        pairs[0, found], pairs[1, found] = i, j
                        facts[0, found], facts[1, found], facts[2, found] = normal
                        facts[3, found], facts[4, found] = excess, added
                        facts[5, found] = closing
                        found += 1
    return (pairs[:, :found], facts[:3, :found], facts[3, :found], facts[4, :found],
            facts[5, :found])


@numba.njit(error_model='numpy')
def _narrow_phase(old_position, old_velocity, position, velocity, radius, i, j, dt):
    """(in contact, normal (3-tuple), excess m/s, added m/s, closing m/s) of spheres i, j;
    see find_contacts."""
    reach = radius[i] + radius[j]
    d0 = (old_position[0, i] - old_position[0, j], old_position[1, i] - old_position[1, j],
          old_position[2, i] - old_position[2, j])
    d1 = (position[0, i] - position[0, j], position[1, i] - position[1, j],
          position[2, i] - position[2, j])
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
        # Apart all step: a contact all the same if the gap left at its end is within the
        # margin, closing no faster than would shut it in the next step (speculative
        # contact). Without it a pair that an impulse elsewhere sets moving toward each
        # other in this step would go unseen until it overlaps.
        end_gap = math.sqrt(d1[0] * d1[0] + d1[1] * d1[1] + d1[2] * d1[2]) - reach
        if end_gap > SPECULATIVE_MARGIN * reach:
            return False, (0.0, 0.0, 1.0), 0.0, 0.0, 0.0
        if end_gap <= _TOUCHING * reach:
            impact = 1.0  # touching at the end (a row of spheres at rest): a contact
        d = d1
    length = math.sqrt(d[0] * d[0] + d[1] * d[1] + d[2] * d[2])
    if length > 0.0:
        normal = (d[0] / length, d[1] / length, d[2] / length)
    else:
        normal = (0.0, 0.0, 1.0)  # centres at one point: any direction is as good
    if impact > 1.0:
        return True, normal, 0.0, 0.0, (length - reach) / dt
    approach_start = -((old_velocity[0, i] - old_velocity[0, j]) * normal[0]
                       + (old_velocity[1, i] - old_velocity[1, j]) * normal[1]
                       + (old_velocity[2, i] - old_velocity[2, j]) * normal[2])
    approach_end = -((velocity[0, i] - velocity[0, j]) * normal[0]
                     + (velocity[1, i] - velocity[1, j]) * normal[1]
                     + (velocity[2, i] - velocity[2, j]) * normal[2])
    before = max(d0[0] * normal[0] + d0[1] * normal[1] + d0[2] * normal[2] - reach, 0.0)
    past = max(reach - (d1[0] * normal[0] + d1[1] * normal[1] + d1[2] * normal[2]), 0.0)
    at_impact = impact_speed(approach_start, approach_end, before, past, dt)
    return True, normal, max(approach_end - at_impact, 0.0), approach_end - approach_start, 0.0


@numba.njit(error_model='numpy', inline='always')
def _face_bounce(approach, restitution, resting_speed):
    """Speed away from a face (or partner) after an approach (m/s) resolved with
    restitution: none when no faster than resting_speed (resting contact)."""
    bounced = restitution * approach
    return bounced if bounced > resting_speed else 0.0


@numba.njit(error_model='numpy', inline='always')
def _against_face_pair(low, high, p, v, slack, restitution, resting_speed):
    """One axis: the velocity (m/s) of a sphere at p (m, its centre's limits low, high)
    after it meets the face it is on and moving into, if any."""
    if v < 0.0 and p <= low + slack:
        return _face_bounce(-v, restitution, resting_speed)
    if v > 0.0 and p >= high - slack:
        return -_face_bounce(v, restitution, resting_speed)
    return v


@numba.njit(error_model='numpy', inline='always')
def _velocity_against_faces(faces, radius, position, velocity, i, restitution,
                            resting_speed):
    """A sphere on a face and moving into it after an impulse bounces off it (or stops)."""
    r = radius[i]
    slack = 1e-9 * r
    velocity[0, i] = _against_face_pair(faces[0] + r, faces[3] - r, position[0, i],
                                        velocity[0, i], slack, restitution, resting_speed)
    velocity[1, i] = _against_face_pair(faces[1] + r, faces[4] - r, position[1, i],
                                        velocity[1, i], slack, restitution, resting_speed)
    velocity[2, i] = _against_face_pair(faces[2] + r, faces[5] - r, position[2, i],
                                        velocity[2, i], slack, restitution, resting_speed)


@numba.njit(error_model='numpy', inline='always')
def _shift(position, radius, i, sx, sy, sz, faces, has_faces):
    """Move sphere i by (sx, sy, sz) m to undo an overlap, but not through a face."""
    moved = position[0, i] + sx
    if has_faces:
        moved = min(max(moved, faces[0] + radius[i]), faces[3] - radius[i])
    position[0, i] = moved
    moved = position[1, i] + sy
    if has_faces:
        moved = min(max(moved, faces[1] + radius[i]), faces[4] - radius[i])
    position[1, i] = moved
    moved = position[2, i] + sz
    if has_faces:
        moved = min(max(moved, faces[2] + radius[i]), faces[5] - radius[i])
    position[2, i] = moved


@numba.njit(error_model='numpy')
def resolve_collisions(old_position, old_velocity, position, velocity, mass, radius, faces,
                       has_faces, contact, has_friction, resting_speed, floor_supports,
                       failed, dt):
    """Find and resolve this step's sphere-sphere contacts in place (position, velocity:
    the step's end; old_*: its start). faces: the pool's (min_x, min_y, min_z, max_x,
    max_y, max_z) when has_faces. contact: (restitution, static_friction,
    kinetic_friction, rolling_friction). resting_speed: m/s, |g| dt. floor_supports:
    gravity points down (-z) onto a floor, so piles rest on it (see _settle_on_floor).

    Returns how many spheres the step guard put back (flagged in failed): a sphere the
    impulses left non-finite goes back to the step's start, at rest."""
    if radius.size < 2:
        return 0
    pairs, normals, excess, added, closing = find_contacts(old_position, old_velocity,
                                                           position, velocity, radius, dt)
    found = pairs.shape[1]
    if found == 0:
        return 0
    restitution, static_friction, kinetic_friction = contact[0], contact[1], contact[2]
    # What a pair still apart may keep of its approach: its gap / dt, or the approach it
    # came with if faster. It has not hit yet (the next step finds the impact, and bounces
    # it); this only stops impulses elsewhere in this step driving it through its gap.
    allowed = np.zeros(found)
    for c in range(found):
        if closing[c] > 0.0:
            i, j = pairs[0, c], pairs[1, c]
            allowed[c] = max(closing[c], -(
                (velocity[0, i] - velocity[0, j]) * normals[0, c]
                + (velocity[1, i] - velocity[1, j]) * normals[1, c]
                + (velocity[2, i] - velocity[2, j]) * normals[2, c]))
    # Sweep at which each sphere's velocity (then position) last changed: a contact neither
    # of whose spheres changed since its last visit is as it was, and is skipped.
    changed_in = np.full(radius.size, 0, dtype=np.int64)
    rebounded = np.zeros(radius.size, dtype=np.bool_)  # bounced off a partner this step
    settled = _SETTLED_SPEED + 0.01 * resting_speed
    for sweep in range(1, VELOCITY_SWEEPS + 1):
        changed = False
        for c in range(found):
            i, j = pairs[0, c], pairs[1, c]
            if changed_in[i] < sweep - 1 and changed_in[j] < sweep - 1:
                continue
            nx, ny, nz = normals[0, c], normals[1, c], normals[2, c]
            rx = velocity[0, i] - velocity[0, j]
            ry = velocity[1, i] - velocity[1, j]
            rz = velocity[2, i] - velocity[2, j]
            approach = -(rx * nx + ry * ny + rz * nz) - allowed[c]
            if not approach > settled:
                continue
            changed = True
            changed_in[i], changed_in[j] = sweep, sweep
            # The rebound keeps restitution x the speed at impact; what the step added
            # after impact, and rebounds within resting speed, are not bounced. A pair
            # still apart has not hit: it is only kept from closing its gap too fast.
            bounced = 0.0 if closing[c] > 0.0 else _face_bounce(
                max(approach - excess[c], 0.0), restitution, max(added[c], resting_speed))
            if bounced > 0.0:
                rebounded[i], rebounded[j] = True, True
            wi, wj = 1.0 / mass[i], 1.0 / mass[j]
            impulse = (approach + bounced) / (wi + wj)  # N s along the normal
            velocity[0, i] += wi * impulse * nx
            velocity[0, j] -= wj * impulse * nx
            velocity[1, i] += wi * impulse * ny
            velocity[1, j] -= wj * impulse * ny
            velocity[2, i] += wi * impulse * nz
            velocity[2, j] -= wj * impulse * nz
            if has_friction:
                rx = velocity[0, i] - velocity[0, j]
                ry = velocity[1, i] - velocity[1, j]
                rz = velocity[2, i] - velocity[2, j]
                along = rx * nx + ry * ny + rz * nz
                tx, ty, tz = rx - along * nx, ry - along * ny, rz - along * nz
                sliding = math.sqrt(tx * tx + ty * ty + tz * tz)
                if sliding > 0.0:
                    stick = sliding / (wi + wj)  # the impulse that stops the sliding
                    grip = (stick if stick <= static_friction * impulse
                            else kinetic_friction * impulse) / sliding
                    velocity[0, i] -= wi * grip * tx
                    velocity[0, j] += wj * grip * tx
                    velocity[1, i] -= wi * grip * ty
                    velocity[1, j] += wj * grip * ty
                    velocity[2, i] -= wi * grip * tz
                    velocity[2, j] += wj * grip * tz
            if has_faces:
                _velocity_against_faces(faces, radius, position, velocity, i, restitution,
                                        resting_speed)
                _velocity_against_faces(faces, radius, position, velocity, j, restitution,
                                        resting_speed)
        if not changed:
            break
    resting = floor_supports and has_faces
    if resting:
        supported = _settle_on_floor(pairs, normals, closing, position, velocity, radius,
                                     faces, static_friction, kinetic_friction, has_friction,
                                     resting_speed)
    else:
        supported = np.zeros(0, dtype=np.bool_)
    changed_in[:] = 0
    for sweep in range(1, POSITION_SWEEPS + 1):
        worst = 0.0
        for c in range(found):
            i, j = pairs[0, c], pairs[1, c]
            if changed_in[i] < sweep - 1 and changed_in[j] < sweep - 1:
                continue
            nx, ny, nz = normals[0, c], normals[1, c], normals[2, c]
            separation = ((position[0, i] - position[0, j]) * nx
                          + (position[1, i] - position[1, j]) * ny
                          + (position[2, i] - position[2, j]) * nz)
            overlap = radius[i] + radius[j] - separation
            if not overlap > 0.0:
                continue
            changed_in[i], changed_in[j] = sweep, sweep
            worst = max(worst, overlap / min(radius[i], radius[j]))
            wi, wj = 1.0 / mass[i], 1.0 / mass[j]
            share_i, share_j = wi / (wi + wj), wj / (wi + wj)
            # Along the normal: the overlap, shared by inverse mass (the pair's centre of
            # mass stays).
            px, py, pz = overlap * nx, overlap * ny, overlap * nz
            if has_friction and sweep == 1:
                # Across it: Coulomb on the step's relative sliding (Macklin et al. 2014),
                # undone while within mu_s x the overlap, else by mu_k x it. In velocity
                # alone each step's small slide would stay, and a pile creep flat.
                sx = (position[0, i] - old_position[0, i]) - (position[0, j] - old_position[0, j])
                sy = (position[1, i] - old_position[1, i]) - (position[1, j] - old_position[1, j])
                sz = (position[2, i] - old_position[2, i]) - (position[2, j] - old_position[2, j])
                along = sx * nx + sy * ny + sz * nz
                tx, ty, tz = sx - along * nx, sy - along * ny, sz - along * nz
                slid = math.sqrt(tx * tx + ty * ty + tz * tz)
                if slid > 0.0:
                    undone = (1.0 if slid <= static_friction * overlap
                              else kinetic_friction * overlap / slid)
                    px, py, pz = px - undone * tx, py - undone * ty, pz - undone * tz
            _shift(position, radius, i, share_i * px, share_i * py, share_i * pz, faces,
                   has_faces)
            _shift(position, radius, j, -share_j * px, -share_j * py, -share_j * pz, faces,
                   has_faces)
        if worst <= 0.25 * OVERLAP_TOLERANCE:
            break
    if resting:
        # A resting sphere moves as its position did, if that is slower: what is left of
        # its velocity after the sweeps is the solver's lag, which the projection has
        # undone in position (as position-based dynamics derives velocity).
        for i in range(radius.size):
            if not supported[i] or rebounded[i]:
                continue  # a bounce is not lag
            moved = (position[0, i] - old_position[0, i], position[1, i] - old_position[1, i],
                     position[2, i] - old_position[2, i])
            if ((moved[0] * moved[0] + moved[1] * moved[1] + moved[2] * moved[2])
                    < dt * dt * (velocity[0, i] ** 2 + velocity[1, i] ** 2
                                 + velocity[2, i] ** 2)):
                for axis in range(3):
                    velocity[axis, i] = moved[axis] / dt
    put_back = 0
    for c in range(found):
        for i in (pairs[0, c], pairs[1, c]):
            if failed[i] or (position[0, i] * 0.0 + position[1, i] * 0.0 + position[2, i] * 0.0
                             + velocity[0, i] * 0.0 + velocity[1, i] * 0.0
                             + velocity[2, i] * 0.0) == 0.0:
                continue
            for axis in range(3):
                position[axis, i] = old_position[axis, i]
                velocity[axis, i] = 0.0
            failed[i] = 1
            put_back += 1
    return put_back


@numba.njit(error_model='numpy')
def _settle_on_floor(pairs, normals, closing, position, velocity, radius, faces,
                     static_friction, kinetic_friction, has_friction, resting_speed):
    """One last sweep, bottom up, that lets a pile rest (shock propagation, Guendelman et
    al. 2003): a sphere on the floor, or on one that rests, is as immovable as the floor
    for the sphere above it, whose approach (and, within Coulomb, its sliding) stops.

    Sequential impulses alone pass a pile's weight down a layer per sweep, so a pile of k
    layers would keep velocities of order g dt unless swept ~k^2 times. The momentum so
    taken goes to the floor, as in a resting pile it does.

    Returns supported (n,) bool: the spheres found resting."""
    found = pairs.shape[1]
    count = radius.size
    # Contacts ordered by the lower sphere's height: a counting sort on layers of the
    # smallest radius.
    lowest, highest, smallest = math.inf, -math.inf, math.inf
    for c in range(found):
        for i in (pairs[0, c], pairs[1, c]):
            lowest = min(lowest, position[2, i])
            highest = max(highest, position[2, i])
            smallest = min(smallest, radius[i])
    layers = int(min((highest - lowest) / smallest, 4.0 * found)) + 1
    start = np.zeros(layers + 1, dtype=np.int64)
    layer = np.empty(found, dtype=np.int64)
    for c in range(found):
        height = min(position[2, pairs[0, c]], position[2, pairs[1, c]])
        layer[c] = min(int((height - lowest) / smallest), layers - 1)
        start[layer[c] + 1] += 1
    for k in range(layers):
        start[k + 1] += start[k]
    order = np.empty(found, dtype=np.int64)
    for c in range(found):
        order[start[layer[c]]] = c
        start[layer[c]] += 1
    supported = np.zeros(count, dtype=np.bool_)
    for c in range(found):
        for i in (pairs[0, c], pairs[1, c]):
            supported[i] = position[2, i] <= faces[2] + radius[i] * (1.0 + 1e-9)
    # Who rests on what: sorted bottom up, a few passes reach every layer (a pass misses
    # only a sphere held up through one of its own layer met later).
    carries = np.zeros(found, dtype=np.int64)  # 1: the first sphere rests on the second
    for _ in range(8):
        spread = False
        for k in range(found):
            c = order[k]
            if closing[c] > resting_speed or carries[c] != 0:
                continue  # apart by more than a step's fall: holds nothing up; or known
            if normals[2, c] > _BEARING and supported[pairs[1, c]]:
                carries[c], upper = 1, pairs[0, c]
            elif normals[2, c] < -_BEARING and supported[pairs[0, c]]:
                carries[c], upper = 2, pairs[1, c]
            else:
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
            upper, lower, sign = pairs[0, c], pairs[1, c], 1.0
        else:
            upper, lower, sign = pairs[1, c], pairs[0, c], -1.0
        nx, ny, nz = sign * normals[0, c], sign * normals[1, c], sign * normals[2, c]
        rx = velocity[0, upper] - velocity[0, lower]
        ry = velocity[1, upper] - velocity[1, lower]
        rz = velocity[2, upper] - velocity[2, lower]
        approach = -(rx * nx + ry * ny + rz * nz) - closing[c]
        if not approach > 0.0:
            continue
        velocity[0, upper] += approach * nx
        velocity[1, upper] += approach * ny
        velocity[2, upper] += approach * nz
        if has_friction:
            rx, ry, rz = rx + approach * nx, ry + approach * ny, rz + approach * nz
            tx, ty, tz = rx, ry, rz  # normal part now zero
            sliding = math.sqrt(tx * tx + ty * ty + tz * tz)
            if sliding > 0.0:
                grip = (1.0 if sliding <= static_friction * approach
                        else kinetic_friction * approach / sliding)
                velocity[0, upper] -= grip * tx
                velocity[1, upper] -= grip * ty
                velocity[2, upper] -= grip * tz
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
