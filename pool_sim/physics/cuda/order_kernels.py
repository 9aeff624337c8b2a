"""The orders the soft step sweeps its contacts in, made on the GPU (device_order.py): the
colouring (colouring.py) and the support sweep's order and waves (soft_step._support_order,
layers.bottom_up_order and sweep_waves), from the CPU's own per-item functions.

Both the colouring and the waves give an item a value that depends on the values of the
items before it that share a sphere with it. On the CPU one loop walks the items in order;
here every item waits, round after round, until those before it that it touches have
theirs (an item's incident list: the items at each of its spheres, sorted by sphere). What
an item reads was written in an earlier round or is being written in this one; either way
it is final once written (an aligned 8-byte store), so the result is the serial loop's in
any thread order, and only the number of rounds depends on timing.
"""
import numpy as np

from ..contacts.colouring import comes_before, pick_colour
from ..contacts.layers import layer_count, layer_of
from ..contacts.soft_contact import GAP
from ..contacts.soft_step import bears, FLOOR_FACE, write_bearing
from . import load_cuda

# A global, not a local: numba's CUDA simulator swaps each thread's `cuda` into the
# kernel's globals.
cuda = load_cuda()


def incidence_keys_kernel(ends, keys):
    """keys (2 m,) int64: entry 2 c + j is item c's end j (a row; the ground's row too)."""
    e = cuda.grid(1)
    if e < keys.size:
        keys[e] = ends[e // 2, e % 2]


def colour_round_kernel(ends, ground, incident, incident_start, colour, waiting):
    """One round of the colouring: each contact without a colour (colour -1) whose
    contacts before it (colouring.comes_before) sharing a sphere all have theirs takes
    the first colour none of them has (colouring.take_colour's rule); the others count
    themselves in waiting[0]."""
    c = cuda.grid(1)
    if c >= ends.shape[0] or colour[c] >= 0:
        return
    taken = np.uint64(0)
    for j in range(2):
        row = ends[c, j]
        if row == ground:
            continue  # the ground does not count
        for e in range(incident_start[row], incident_start[row + 1]):
            d = incident[e] // 2
            if d != c and comes_before(d, c):
                other = colour[d]
                if other < 0:
                    cuda.atomic.add(waiting, 0, 1)
                    return
                taken |= np.uint64(1) << np.uint64(other)
    colour[c] = pick_colour(taken)


def slot_kernel(by_colour, slot):
    """Each contact's slot: its place among the contacts sorted by colour (stably)."""
    i = cuda.grid(1)
    if i < by_colour.size:
        slot[by_colour[i]] = i


def floor_flags_kernel(faces_of, flags):
    """flags (f,) int64: 1 for each face contact with the floor."""
    f = cuda.grid(1)
    if f < flags.size:
        flags[f] = 1 if faces_of[f, 1] == FLOOR_FACE else 0


def floor_place_kernel(faces_of, flags, offsets, rows, slot, found, floor_member,
                       floor_gap):
    """Each floor contact's member and gap at its offset (_support_order's, in order)."""
    f = cuda.grid(1)
    if f < flags.size and flags[f]:
        floor_member[offsets[f]] = faces_of[f, 0]
        floor_gap[offsets[f]] = rows[slot[found + f], GAP]


def heights_kernel(sphere, old_position, radius, z, member_radius, extent):
    """Each member's height z m at the step's start and radius m; extent (3,): the lowest
    and highest z and the smallest radius (minima and maxima: the same in any order)."""
    k = cuda.grid(1)
    if k < sphere.size:
        z[k], member_radius[k] = old_position[2, sphere[k]], radius[sphere[k]]
        cuda.atomic.min(extent, 0, z[k])
        cuda.atomic.max(extent, 1, z[k])
        cuda.atomic.min(extent, 2, member_radius[k])


def layer_kernel(pair_ends, z, extent, layer):
    """Each pair's layer by its lower sphere's height (layers.bottom_up_order's)."""
    c = cuda.grid(1)
    if c < layer.size:
        layers = layer_count(extent[0], extent[1], extent[2], layer.size)
        layer[c] = layer_of(min(z[pair_ends[c, 0]], z[pair_ends[c, 1]]), extent[0],
                            extent[2], layers)


def bearing_flags_kernel(rows, slot, bottom_up, flags):
    """flags (m,) int64: 1 for each pair, bottom up, that bears weight (soft_step.bears)."""
    q = cuda.grid(1)
    if q < flags.size:
        flags[q] = 1 if bears(rows, slot[bottom_up[q]]) else 0


def bearing_place_kernel(rows, slot, pair_ends, bottom_up, flags, offsets, ends, facts):
    """Each bearing pair into ends and facts at its offset (soft_step.write_bearing)."""
    q = cuda.grid(1)
    if q < flags.size and flags[q]:
        c = bottom_up[q]
        write_bearing(rows, slot[c], pair_ends[c, 0], pair_ends[c, 1], ends, facts,
                      offsets[q])


def wave_round_kernel(ends, incident, incident_start, wave, waiting, deepest):
    """One round of layers.sweep_waves: each support contact q without a wave (-1) whose
    earlier contacts that write a sphere it touches, or read the one it writes, all have
    theirs goes in the wave after the latest of them (0 if none); the others count
    themselves in waiting[0]. deepest[0]: the latest wave (a maximum)."""
    q = cuda.grid(1)
    if q >= ends.shape[0] or wave[q] >= 0:
        return
    latest = -1
    for j in range(2):
        row = ends[q, j]
        for e in range(incident_start[row], incident_start[row + 1]):
            before = incident[e] // 2
            if before >= q:
                break  # a sphere's entries come in the contacts' order
            if j == 1 and incident[e] % 2 == 1:
                continue  # two contacts that only read a sphere do not wait on each other
            other = wave[before]
            if other < 0:
                cuda.atomic.add(waiting, 0, 1)
                return
            latest = max(latest, other)
    wave[q] = latest + 1
    cuda.atomic.max(deepest, 0, latest + 1)


def gather_kernel(order, ends, facts, ends_out, facts_out):
    """ends and facts rows taken in order (the support contacts wave by wave)."""
    i = cuda.grid(1)
    if i < order.size:
        for j in range(2):
            ends_out[i, j] = ends[order[i], j]
        for j in range(4):
            facts_out[i, j] = facts[order[i], j]


KERNELS = (incidence_keys_kernel, colour_round_kernel, slot_kernel, floor_flags_kernel,
           floor_place_kernel, heights_kernel, layer_kernel, bearing_flags_kernel,
           bearing_place_kernel, wave_round_kernel, gather_kernel)
