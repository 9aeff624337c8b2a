"""Sphere-sphere contact detection, the first half of the `collisions` effect: this step's
pairs in contact, as one Contacts record, for a solver (SOLVERS in contacts/__init__.py).

1. Broad phase: each sphere's bounding sphere over the step (the segment its centre moved
   along, widened by its radius and SPECULATIVE_MARGIN), so a fast sphere cannot pass
   through another within a step. Bounding spheres go into levels by size, and each level
   is a cell list (a dense grid, counting-sorted): linear in the number of spheres,
   whatever the mix of radii.
2. Narrow phase (narrow_phase.py): the relative motion of the two centres over the step is
   taken as linear; a pair is in contact when the centres come within the sum of the radii,
   and the normal is the direction between them at that first moment (time of impact).
   Pairs whose bounding spheres meet but which stay apart all step are speculative
   contacts: they may close no more than their gap, however impulses elsewhere set them
   moving.

Each step of it is a function of one sphere, one row or one pair, which the loops here
call and the GPU's kernels (physics/cuda/detect_kernels.py) call one thread each.
"""
from collections import namedtuple
import math

import numba
import numpy as np

from .narrow_phase import END_POSITION, END_VELOCITY, RADIUS, START_POSITION, \
    START_VELOCITY, STATE_COLUMNS, narrow_into

# The broad phase widens every sphere by this fraction of its radius: pairs at rest apart
# by less than this of their radii's sum are (speculative) contacts too.
SPECULATIVE_MARGIN = 0.02
# Broad-phase levels hold reaches within this factor of each other; each level's cell
# list has at most this many cells per sphere in it (a sparse scene gets coarser cells).
_LEVEL_RATIO = 4.0
_CELLS_PER_SPHERE = 4.0
_MAX_LEVEL = 40

Contacts = namedtuple('Contacts', ('pairs', 'normal', 'excess', 'added', 'closing', 'order',
                                   'state'))
Contacts.__doc__ = """This step's contacts, m of them among n spheres, from detect_contacts.

pairs: (2, m) int64, each contact's two rows of `state`.
normal: (3, m), unit, from the second sphere toward the first, at the time of impact (at
    the step's start for a pair already touching then; at its end for a speculative one).
excess: (m,) m/s, how much faster the pair approaches at the step's end than at impact.
added: (m,) m/s, how much the step's own forces added to its approach.
closing: (m,) m/s, the approach speed a pair still apart at the step's end may keep (its
    gap / dt; 0 for a touching one).
order: (n,) int64, the sphere in each row of `state` (rows are in cell order).
state: (n, STATE_COLUMNS) float64, the spheres in cell order; its columns from
    START_POSITION (3, m), END_POSITION (3, m), START_VELOCITY (3, m/s), END_VELOCITY
    (3, m/s) and RADIUS (1, m) on; a row is two cache lines.
"""


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
    wholes = 21 * count + 16 * contacts + 2 * (64 * (_MAX_LEVEL + 1) + 1) + 2
    return np.empty(reals), np.empty(wholes, dtype=np.int64)


@numba.njit(error_model='numpy', inline='always')
def contact_capacity(count):
    """The candidate pairs (and so contacts) the broad phase has room for at first."""
    return 4 * count + 16


@numba.njit(error_model='numpy', inline='always')
def take(buffer, used, size):
    """(size items of buffer from used on, uninitialised; where the next take starts), or a
    new array when buffer has no room left (see workspace)."""
    if used + size <= buffer.size:
        return buffer[used:used + size], used + size
    return np.empty(size, dtype=buffer.dtype), used


@numba.njit(error_model='numpy')
def counting_sort(keys, buckets, wholes, used_whole):
    """(order (m,) int64: the items 0..m-1 by their keys (m,) int64, each in 0..buckets-1,
    items of one key in the order they come; start (buckets + 1,) int64: where each key's
    items begin in order; used wholes): linear in m + buckets, the sort the collision pass
    orders its spheres and contacts by (cells, layers, memory rows)."""
    start, used_whole = take(wholes, used_whole, buckets + 1)
    start[:] = 0
    for c in range(keys.size):
        start[keys[c] + 1] += 1
    for k in range(buckets):
        start[k + 1] += start[k]
    order, used_whole = take(wholes, used_whole, keys.size)
    for c in range(keys.size):
        order[start[keys[c]]] = c
        start[keys[c]] += 1
    for k in range(buckets, 0, -1):  # each key's start has moved on to the next's: back
        start[k] = start[k - 1]
    start[0] = 0
    return order, start, used_whole


@numba.njit(error_model='numpy', inline='always')
def _cell_of(coordinate, origin, size, cells):
    """The cell (0..cells-1) a coordinate m falls in along one axis of a level's grid; 0
    for one that is not a number (a sphere the step guard will put back). Clamped as a
    float, before the conversion: numba's CUDA simulator, which runs it as Python, cannot
    convert NaN to an integer (compiled code gave 0 too, by overflow)."""
    # max(0.0, NaN) is 0.0 (min and max keep their first argument unless the other wins).
    return int(min(max(0.0, (coordinate - origin) / size), cells - 1.0))


@numba.njit(error_model='numpy')
def find_contacts(old_position, old_velocity, position, velocity, radius, dt):
    """detect_contacts with arrays of its own (for tests and diagnostics): (pairs (2, m) as
    sphere indices, not rows of its state; normal, excess, added, closing)."""
    none = np.empty(0), np.empty(0, dtype=np.int64)
    contacts, _, _ = detect_contacts(old_position, old_velocity, position, velocity, radius,
                                    dt, none[0], none[1])
    rows, order = contacts.pairs, contacts.order
    pairs = np.empty_like(rows)
    for c in range(rows.shape[1]):
        pairs[0, c], pairs[1, c] = order[rows[0, c]], order[rows[1, c]]
    return pairs, contacts.normal, contacts.excess, contacts.added, contacts.closing


@numba.njit(error_model='numpy')
def detect_contacts(old_position, old_velocity, position, velocity, radius, dt, reals,
                   wholes):
    """(Contacts, used reals, used wholes): the pairs in contact this step, their arrays
    taken from reals and wholes (see workspace), and how much of each they used.

    The broad phase: each sphere's bounding sphere over the step (its centre's path,
    widened by its radius and the speculative margin) goes in a level by its size, reaches
    within _LEVEL_RATIO of each other in one level. Each level is a cell list: a dense grid
    over its spheres' extent, cells at least the level's largest bounding diameter (so
    partners are in the 27 cells around), counting-sorted so that a row of three cells
    along x is one run of memory. A sphere meets its own level's spheres in 9 such rows
    and every finer level's in the rows its bounding box covers there.
    """
    count = radius.size
    centre, reach, level, levels, used_real, used_whole = _bounding_spheres(
        old_position, position, radius, reals, wholes)
    members, largest, low, size, cells, first_cell = _grids(centre, reach, level, levels)
    order, where, start, used_whole = _cell_order(centre, level, low, size, cells,
                                                  first_cell, wholes, used_whole)
    sorted_bound, sorted_cell, state, used_real, used_whole = _in_cell_order(
        old_position, old_velocity, position, velocity, radius, centre, reach, level, where,
        order, reals, used_real, wholes, used_whole)
    # Candidates first (bounding spheres that meet), in a loop of their own: the narrow
    # phase inside the cell loops ran six times slower than on its own.
    capacity = contact_capacity(count)
    candidates, used_whole = take(wholes, used_whole, 2 * capacity)
    candidates = candidates.reshape((2, capacity))
    total = _candidate_pairs(sorted_cell, members, cells, first_cell, start, sorted_bound,
                             largest, low, size, candidates)
    if total > candidates.shape[1]:
        candidates = np.empty((2, total), dtype=np.int64)
        _candidate_pairs(sorted_cell, members, cells, first_cell, start, sorted_bound,
                         largest, low, size, candidates)
    # Every candidate is a contact: touching within the step, or speculative (_narrow_phase).
    facts, used_real = take(reals, used_real, 6 * total)
    facts = facts.reshape((6, total))  # normal (3), excess, added, closing
    for c in range(total):
        narrow_into(state, candidates, c, dt, facts)
    return (Contacts(candidates[:, :total], facts[:3], facts[3], facts[4], facts[5], order,
                     state), used_real, used_whole)


@numba.njit(error_model='numpy')
def _bounding_spheres(old_position, position, radius, reals, wholes):
    """(centre (3, n) m, reach (n,) m, level (n,) int64, levels, used reals, used wholes):
    each sphere's bounding sphere over the step and its level (see detect_contacts)."""
    count = radius.size
    centre, used_real = take(reals, 0, 3 * count)
    centre = centre.reshape((3, count))
    reach, used_real = take(reals, used_real, count)
    smallest = math.inf
    for i in range(count):
        bounding_sphere(old_position, position, radius, i, centre, reach)
        smallest = min(smallest, reach[i])
    level, used_whole = take(wholes, 0, count)
    top = 0
    for i in range(count):
        level[i] = level_of(reach[i], smallest)
        top = max(top, level[i])
    levels = top + 1
    return centre, reach, level, levels, used_real, used_whole


@numba.njit(error_model='numpy', inline='always')
def bounding_sphere(old_position, position, radius, i, centre, reach):
    """Sphere i's bounding sphere over the step into centre[:, i] (m) and reach[i] (m)."""
    sweep = 0.0
    for axis in range(3):
        centre[axis, i] = 0.5 * (old_position[axis, i] + position[axis, i])
        sweep += (position[axis, i] - old_position[axis, i]) ** 2
    reach[i] = radius[i] * (1.0 + SPECULATIVE_MARGIN) + 0.5 * math.sqrt(sweep)


@numba.njit(error_model='numpy', inline='always')
def level_of(reach, smallest):
    """The level of a bounding sphere of this reach (m), the smallest's smallest (m)."""
    level = 0
    bound = smallest * _LEVEL_RATIO
    while reach > bound and level < _MAX_LEVEL:
        bound *= _LEVEL_RATIO
        level += 1
    return level


@numba.njit(error_model='numpy')
def _grids(centre, reach, level, levels):
    """Each level's cell list: (members (levels,) int64, largest reach (levels,) m, low
    corner (levels, 3) m, cell size (levels,) m, cells (levels, 3) int64 along each axis,
    first_cell (levels + 1,) int64, where each level's cells begin in one numbering)."""
    count = reach.size
    members = np.zeros(levels, dtype=np.int64)
    largest = np.zeros(levels)
    low = np.full((levels, 3), math.inf)
    high = np.full((levels, 3), -math.inf)
    for i in range(count):  # each level's extent (a GPU takes these as atomics)
        at = level[i]
        members[at] += 1
        largest[at] = max(largest[at], reach[i])
        for axis in range(3):
            low[at, axis] = min(low[at, axis], centre[axis, i])
            high[at, axis] = max(high[at, axis], centre[axis, i])
    size = np.zeros(levels)
    cells = np.ones((levels, 3), dtype=np.int64)
    first_cell = np.zeros(levels + 1, dtype=np.int64)
    size_grids(members, largest, low, high, size, cells, first_cell)
    return members, largest, low, size, cells, first_cell


@numba.njit(error_model='numpy', inline='always')
def size_grids(members, largest, low, high, size, cells, first_cell):
    """Each level's cells, from its members, largest reach (m) and its centres' box (low,
    high (levels, 3) m), into size (levels,) zeros, cells (levels, 3) ones and first_cell
    (levels + 1,) zeros (see _grids)."""
    for at in range(members.size):
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


@numba.njit(error_model='numpy')
def _cell_order(centre, level, low, size, cells, first_cell, wholes, used_whole):
    """Counting sort of the spheres by cell: (order (n,) int64, the sphere in each place;
    where (3, n) int64, each sphere's cell along each axis; start (cells + 1,) int64, where
    each cell's spheres begin in order; used wholes)."""
    count = level.size
    levels = first_cell.size - 1
    home, used_whole = take(wholes, used_whole, count)
    where, used_whole = take(wholes, used_whole, 3 * count)
    where = where.reshape((3, count))
    for i in range(count):
        home[i] = home_of(centre, i, level[i], low, size, cells, first_cell, where)
    order, start, used_whole = counting_sort(home, first_cell[levels], wholes, used_whole)
    return order, where, start, used_whole


@numba.njit(error_model='numpy', inline='always')
def home_of(centre, i, at, low, size, cells, first_cell, where):
    """Sphere i's cell in its level at's grid, along each axis into where[:, i]; returns
    its number over every level's cells."""
    for axis in range(3):
        where[axis, i] = _cell_of(centre[axis, i], low[at, axis], size[at], cells[at, axis])
    return first_cell[at] + where[0, i] + cells[at, 0] * (
        where[1, i] + cells[at, 1] * where[2, i])


@numba.njit(error_model='numpy')
def _in_cell_order(old_position, old_velocity, position, velocity, radius, centre, reach,
                   level, where, order, reals, used_real, wholes, used_whole):
    """The bounding spheres (n, 4: centre m, reach m), cells (n, 4: x, y, z, level) and
    state (Contacts.state) in cell order: the candidate test reads memory in a row, and a
    pair's two rows are near each other. Returns them, then used reals and used wholes."""
    count = radius.size
    sorted_bound, used_real = take(reals, used_real, 4 * count)
    sorted_bound = sorted_bound.reshape((count, 4))
    sorted_cell, used_whole = take(wholes, used_whole, 4 * count)
    sorted_cell = sorted_cell.reshape((count, 4))  # its cell x, y, z and its level
    state, used_real = take(reals, used_real, STATE_COLUMNS * count)
    state = state.reshape((count, STATE_COLUMNS))
    for k in range(count):
        place_in_cell_order(k, order[k], old_position, old_velocity, position, velocity,
                            radius, centre, reach, level, where, sorted_bound, sorted_cell,
                            state)
    return sorted_bound, sorted_cell, state, used_real, used_whole


@numba.njit(error_model='numpy', inline='always')
def place_in_cell_order(k, i, old_position, old_velocity, position, velocity, radius, centre,
                        reach, level, where, sorted_bound, sorted_cell, state):
    """Sphere i into row k of sorted_bound, sorted_cell and state (see _in_cell_order)."""
    sorted_bound[k, 0], sorted_bound[k, 1] = centre[0, i], centre[1, i]
    sorted_bound[k, 2], sorted_bound[k, 3] = centre[2, i], reach[i]
    sorted_cell[k, 0], sorted_cell[k, 1] = where[0, i], where[1, i]
    sorted_cell[k, 2], sorted_cell[k, 3] = where[2, i], level[i]
    for axis in range(3):
        state[k, START_POSITION + axis] = old_position[axis, i]
        state[k, END_POSITION + axis] = position[axis, i]
        state[k, START_VELOCITY + axis] = old_velocity[axis, i]
        state[k, END_VELOCITY + axis] = velocity[axis, i]
    state[k, RADIUS] = radius[i]


@numba.njit(error_model='numpy')
def _candidate_pairs(sorted_cell, members, cells, first_cell, start, sorted_bound, largest,
                     low, size, out):
    """The pairs (k, m) of cell-order rows whose bounding spheres meet, each once, written
    into out (2, capacity) while they fit; returns how many there are (see detect_contacts
    for the grid). Cell by cell: the spheres of a cell share its neighbours (10 000 spheres
    at rest: 574 against 753 µs sphere by sphere, the same pairs in the same order)."""
    count = sorted_cell.shape[0]
    total = 0
    runs = np.empty((5, 2), dtype=np.int64)  # a cell's neighbours ahead: rows of cells
    k = 0
    while k < count:
        x, y, z, at = sorted_cell[k, 0], sorted_cell[k, 1], sorted_cell[k, 2], sorted_cell[k, 3]
        used = cell_runs(x, y, z, at, cells, first_cell, start, runs)
        cell = first_cell[at] + x + cells[at, 0] * (y + cells[at, 1] * z)
        end = start[cell + 1]  # this cell's spheres are rows k..end-1
        for i in range(k, end):
            total = row_candidates(i, at, runs, used, sorted_bound, members, cells,
                                   first_cell, start, largest, low, size, out, total)
        k = end
    return total


@numba.njit(error_model='numpy', inline='always')
def cell_runs(x, y, z, at, cells, first_cell, start, runs):
    """The runs of rows a sphere of cell (x, y, z) of level at meets in its own level,
    into runs (5, 2): half the neighbourhood, so each pair is met once, from the row met
    first: the rest of the own cell and the next along x (one run of memory: only its end,
    runs[0, 1], is set), the row of three cells ahead in y, and the three rows ahead in z.
    Returns how many runs."""
    nx, ny, nz = cells[at, 0], cells[at, 1], cells[at, 2]
    cell = first_cell[at] + x + nx * (y + ny * z)
    x_low, x_high = max(x - 1, 0), min(x + 1, nx - 1)
    runs[0, 1] = start[cell + 1 + (x_high > x)]
    used = 1
    if y + 1 < ny:
        row = first_cell[at] + nx * (y + 1 + ny * z)
        runs[used, 0], runs[used, 1] = start[row + x_low], start[row + x_high + 1]
        used += 1
    for cy in range(max(y - 1, 0), min(y + 1, ny - 1) + 1 if z + 1 < nz else 0):
        row = first_cell[at] + nx * (cy + ny * (z + 1))
        runs[used, 0], runs[used, 1] = start[row + x_low], start[row + x_high + 1]
        used += 1
    return used


@numba.njit(error_model='numpy', inline='always')
def row_candidates(i, at, runs, used, sorted_bound, members, cells, first_cell, start,
                   largest, low, size, out, total):
    """Row i's candidate pairs (its level at, its cell's runs, cell_runs'), written into
    out from total on while they fit: the finer levels' spheres in the cells both reaches
    can span, then its own level's in the runs. Returns the new total."""
    for finer in range(at):
        if members[finer] > 0:
            total = _meet_finer(sorted_bound, i, finer, cells, first_cell, start, largest,
                                low, size, out, total)
    total = _meet(sorted_bound, i, i + 1, runs[0, 1], out, total)
    for r in range(1, used):
        total = _meet(sorted_bound, i, runs[r, 0], runs[r, 1], out, total)
    return total


@numba.njit(error_model='numpy', inline='always')
def _meet_finer(sorted_bound, i, finer, cells, first_cell, start, largest, low, size, out,
                total):
    """_meet for row i and the spheres of a finer level in the cells its reach spans."""
    span = sorted_bound[i, 3] + largest[finer]
    x_low = _cell_of(sorted_bound[i, 0] - span, low[finer, 0], size[finer], cells[finer, 0])
    x_high = _cell_of(sorted_bound[i, 0] + span, low[finer, 0], size[finer], cells[finer, 0])
    y_low = _cell_of(sorted_bound[i, 1] - span, low[finer, 1], size[finer], cells[finer, 1])
    y_high = _cell_of(sorted_bound[i, 1] + span, low[finer, 1], size[finer], cells[finer, 1])
    z_low = _cell_of(sorted_bound[i, 2] - span, low[finer, 2], size[finer], cells[finer, 2])
    z_high = _cell_of(sorted_bound[i, 2] + span, low[finer, 2], size[finer], cells[finer, 2])
    for cz in range(z_low, z_high + 1):
        for cy in range(y_low, y_high + 1):
            row = first_cell[finer] + cells[finer, 0] * (cy + cells[finer, 1] * cz)
            total = _meet(sorted_bound, i, start[row + x_low], start[row + x_high + 1], out,
                          total)
    return total


@numba.njit(error_model='numpy', inline='always')
def _meet(sorted_bound, i, first, last, out, total):
    """Rows first..last-1 whose bounding spheres meet row i's, written into out from total on
    while they fit; returns the new total."""
    cx, cy, cz, reach = (sorted_bound[i, 0], sorted_bound[i, 1], sorted_bound[i, 2],
                         sorted_bound[i, 3])
    for m in range(first, last):
        reach_im = reach + sorted_bound[m, 3]
        gap2 = ((cx - sorted_bound[m, 0]) ** 2 + (cy - sorted_bound[m, 1]) ** 2
                + (cz - sorted_bound[m, 2]) ** 2)
        # Written whether they meet or not, and kept if they do: no branch to mispredict
        # (most do not).
        if total < out.shape[1]:
            out[0, total], out[1, total] = i, m
        total += gap2 <= reach_im * reach_im
    return total


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
