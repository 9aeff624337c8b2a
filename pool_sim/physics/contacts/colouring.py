"""Graph colouring of contacts (soft_step.py): contacts of one colour share no sphere, so
a colour's contacts may be solved in any order, or at once (SIMD lanes, GPU threads), and
sweeping colour by colour in a fixed order gives the same result as a parallel sweep.
Greedy (Box2D v3's b2AssignColor does the same with one bit set per body and colour): a
contact takes the first colour none of the contacts before it that share a sphere has.

The CPU colours in the order the contacts come (colour_contacts). That order's chains of
contacts, each sharing a sphere with the one before, are long (869 contacts in a 10 000
sphere layer on the floor, 1 736 in 100 000), and a contact's colour waits for its chain:
a GPU colours in rounds, each contact once every contact before it that it touches has
its colour, so it colours in the order of colour_priority (a hash of the contact's index,
Jones and Plassmann 1993), whose chains are short. colour_by_priority is that colouring
on the CPU."""
import numpy as np
import numba

from .detection import take

# Colours 0..COLOURS - 2 share no sphere; the last takes what is left (swept in order).
COLOURS = 64
# The scene's soft_step.colouring: as found, by colour_priority, or found on the CPU and
# by priority on a GPU (which colours no other way).
COLOURINGS = ('auto', 'found', 'priority')


def by_priority(colouring, backend):
    """Whether a scene's soft step colours by colour_priority (soft_step.colouring, the
    backend)."""
    return colouring == 'priority' or (colouring == 'auto' and backend == 'cuda')


@numba.njit(error_model='numpy')
def pick_colour(taken):
    """The first colour whose bit in taken (uint64, one bit each) is clear, or the last
    colour, which takes what is left."""
    for k in range(COLOURS - 1):
        if (taken >> np.uint64(k)) & np.uint64(1) == 0:
            return k
    return COLOURS - 1


@numba.njit(error_model='numpy')
def colour_priority(c):
    """Where contact c (int, under 2**31) comes in the GPU's colouring order: a hash of c
    in 0..2**32 - 1 (ties go to the lower index), in int64 arithmetic that cannot
    overflow (the products stay under 2**59)."""
    x = c & 0xFFFFFFFF
    x = (((x >> 16) ^ x) * 0x45D9F3B) & 0xFFFFFFFF
    x = (((x >> 16) ^ x) * 0x45D9F3B) & 0xFFFFFFFF
    return (x >> 16) ^ x


@numba.njit(error_model='numpy')
def comes_before(d, c):
    """Whether contact d takes its colour before contact c in colour_priority's order."""
    first, second = colour_priority(d), colour_priority(c)
    return first < second or (first == second and d < c)


@numba.njit(error_model='numpy')
def take_colour(ends, ground, used, colour, c):
    """Contact c (ends[c]) takes the first colour neither of its spheres' contacts so far
    has (used (rows + 1,) uint64: each row's colours, one bit each, updated)."""
    a, b = ends[c, 0], ends[c, 1]
    pick = pick_colour(used[a] | (used[b] if b != ground else np.uint64(0)))
    colour[c] = pick
    bit = np.uint64(1) << np.uint64(pick)
    used[a] |= bit
    if b != ground:
        used[b] |= bit


@numba.njit(error_model='numpy')
def colour_contacts(ends, ground, wholes, used_whole):
    """(slot (m,) int64: each contact's place in the sweep, colour by colour; colour_start
    (COLOURS + 1,)): greedy colouring in the order the contacts (ends (m, 2)) come, so that
    no two contacts of one colour (but the last, which takes the rest) share a sphere; the
    ground (row `ground`) does not count."""
    total = ends.shape[0]
    used = np.zeros(ground + 1, dtype=np.uint64)  # each row's colours so far, one bit each
    colour = np.empty(total, dtype=np.int64)
    for c in range(total):
        take_colour(ends, ground, used, colour, c)
    slot, _ = take(wholes, used_whole, total)
    return slot, slots_by_colour(colour, slot)


@numba.njit(error_model='numpy')
def colour_by_priority(ends, ground):
    """colour_contacts' (slot, colour_start), but greedy in colour_priority's order, as
    the GPU colours (cuda/device_order.py): the same colouring, to the bit."""
    total = ends.shape[0]
    priority = np.empty(total, dtype=np.int64)
    for c in range(total):
        priority[c] = colour_priority(c)
    used = np.zeros(ground + 1, dtype=np.uint64)
    colour = np.empty(total, dtype=np.int64)
    for c in np.argsort(priority, kind='mergesort'):  # stable: ties in index order
        take_colour(ends, ground, used, colour, c)
    slot = np.empty(total, dtype=np.int64)
    return slot, slots_by_colour(colour, slot)


@numba.njit(error_model='numpy')
def slots_by_colour(colour, slot):
    """colour_start (COLOURS + 1,) int64, and each contact's slot written into slot (m,):
    colour by colour, a colour's contacts in the order they come."""
    colour_start = np.zeros(COLOURS + 1, dtype=np.int64)
    for c in range(colour.size):
        colour_start[colour[c] + 1] += 1
    for k in range(COLOURS):
        colour_start[k + 1] += colour_start[k]
    fill = colour_start[:-1].copy()
    for c in range(colour.size):
        slot[c] = fill[colour[c]]
        fill[colour[c]] += 1
    return colour_start
