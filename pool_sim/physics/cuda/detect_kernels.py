"""Contact detection's kernels on the GPU, from the CPU's own per-sphere and per-pair
functions (contacts/detection.py): the same broad phase (bounding spheres over the step,
levels by size, a cell list a level) and narrow phase, nothing written twice.

Where the CPU runs a serial loop, the GPU runs one thread a sphere, a row or a pair:
- the extents of the levels' grids are minima, maxima and counts, as atomics: the same in
  any order (no sums of floats);
- the sort by cell is a library's stable sort (device_detect.py), as the CPU's counting
  sort is stable, so the spheres come in the same order;
- the candidate pairs are counted row by row, the counts summed into offsets (a library's
  running sum), and written row by row at their offsets: the CPU's pairs, in its order
  (a row that finds other than it counted is counted, and detection refuses to go on).
"""
import numba

from ..contacts.detection import bounding_sphere, cell_runs, home_of, level_of, narrow_into, \
    place_in_cell_order, row_candidates, size_grids
from . import load_cuda

# A global, not a local: numba's CUDA simulator swaps each thread's `cuda` into the
# kernel's globals.
cuda = load_cuda()
RUNS = 5  # a cell's runs of neighbours (detection.cell_runs)


def bounds_kernel(old_position, position, radius, centre, reach, smallest):
    """Each sphere's bounding sphere over the step; smallest[0] = min of their reaches."""
    i = cuda.grid(1)
    if i < radius.size:
        bounding_sphere(old_position, position, radius, i, centre, reach)
        cuda.atomic.min(smallest, 0, reach[i])


def levels_kernel(reach, smallest, level, top):
    """Each sphere's level by size; top[0] = the highest."""
    i = cuda.grid(1)
    if i < reach.size:
        level[i] = level_of(reach[i], smallest[0])
        cuda.atomic.max(top, 0, level[i])


def extents_kernel(centre, reach, level, members, largest, low, high):
    """Each level's spheres counted, its largest reach and the corners of its centres'
    box: detection._grids' first loop, its minima, maxima and counts as atomics."""
    i = cuda.grid(1)
    if i < reach.size:
        at = level[i]
        cuda.atomic.add(members, at, 1)
        cuda.atomic.max(largest, at, reach[i])
        for axis in range(3):
            cuda.atomic.min(low, (at, axis), centre[axis, i])
            cuda.atomic.max(high, (at, axis), centre[axis, i])


def grids_kernel(members, largest, low, high, size, cells, first_cell):
    """detection.size_grids, one thread (a level at most 41)."""
    if cuda.grid(1) == 0:
        size_grids(members, largest, low, high, size, cells, first_cell)


def homes_kernel(centre, level, low, size, cells, first_cell, where, home):
    """Each sphere's cell (where) and its number over every level's cells (home)."""
    i = cuda.grid(1)
    if i < level.size:
        home[i] = home_of(centre, i, level[i], low, size, cells, first_cell, where)


def place_kernel(old_position, old_velocity, position, velocity, radius, centre, reach,
                 level, where, order, sorted_bound, sorted_cell, state):
    """The spheres in cell order (detection.place_in_cell_order), one thread a row."""
    k = cuda.grid(1)
    if k < order.size:
        place_in_cell_order(k, order[k], old_position, old_velocity, position, velocity,
                            radius, centre, reach, level, where, sorted_bound, sorted_cell,
                            state)


@numba.njit(error_model='numpy', inline='always')
def row_share(k, sorted_cell, members, cells, first_cell, start, sorted_bound, largest, low,
              size, runs, out):
    """Row k's candidate pairs (detection.row_candidates) written into out (2, c), as many
    as fit; returns how many there are."""
    used = cell_runs(sorted_cell[k, 0], sorted_cell[k, 1], sorted_cell[k, 2],
                     sorted_cell[k, 3], cells, first_cell, start, runs)
    return row_candidates(k, sorted_cell[k, 3], runs, used, sorted_bound, members, cells,
                          first_cell, start, largest, low, size, out, 0)


def count_kernel(sorted_cell, members, cells, first_cell, start, sorted_bound, largest, low,
                 size, counts, nothing):
    """How many candidate pairs each row has (nothing: (2, 0), written into by none)."""
    k = cuda.grid(1)
    if k < counts.size:
        runs = cuda.local.array((RUNS, 2), numba.int64)
        counts[k] = row_share(k, sorted_cell, members, cells, first_cell, start, sorted_bound,
                              largest, low, size, runs, nothing)


def write_kernel(sorted_cell, members, cells, first_cell, start, sorted_bound, largest, low,
                 size, counts, offsets, candidates, differ):
    """Each row's candidate pairs at its offset in candidates (2, total); differ[0] counts
    the rows that found other than count_kernel counted (the two passes' comparisons are
    compiled apart: a contraction of one would leave pairs unwritten)."""
    k = cuda.grid(1)
    if k < counts.size:
        runs = cuda.local.array((RUNS, 2), numba.int64)
        found = row_share(k, sorted_cell, members, cells, first_cell, start, sorted_bound,
                          largest, low, size, runs,
                          candidates[:, offsets[k]:offsets[k] + counts[k]])
        if found != counts[k]:
            cuda.atomic.add(differ, 0, 1)


def narrow_kernel(state, candidates, dt, facts):
    """The narrow phase (detection.narrow_into), one thread a candidate pair."""
    c = cuda.grid(1)
    if c < candidates.shape[1]:
        narrow_into(state, candidates, c, dt, facts)


KERNELS = (bounds_kernel, levels_kernel, extents_kernel, grids_kernel, homes_kernel,
           place_kernel, count_kernel, write_kernel, narrow_kernel)
