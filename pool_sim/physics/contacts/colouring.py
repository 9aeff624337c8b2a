"""Graph colouring of contacts (soft_step.py): contacts of one colour share no sphere, so
a colour's contacts may be solved in any order, or at once (SIMD lanes, GPU threads), and
sweeping colour by colour in a fixed order gives the same result as a parallel sweep.
Greedy, in the order the contacts come (Box2D v3's b2AssignColor does the same with one
bit set per body and colour)."""
import numpy as np
import numba

from .detection import take

# Colours 0..COLOURS - 2 share no sphere; the last takes what is left (swept in order).
COLOURS = 64


@numba.njit(error_model='numpy')
def colour_contacts(ends, ground, wholes, used_whole):
    """(slot (m,) int64: each contact's place in the sweep, colour by colour; colour_start
    (COLOURS + 1,)): greedy colouring, so that no two contacts of one colour (but the
    last, which takes the rest) share a sphere; the ground does not count."""
    total = ends.shape[0]
    used = np.zeros(ground + 1, dtype=np.uint64)  # each row's colours so far, one bit each
    colour = np.empty(total, dtype=np.int64)
    colour_start = np.zeros(COLOURS + 1, dtype=np.int64)
    for c in range(total):
        a, b = ends[c, 0], ends[c, 1]
        taken = used[a] | (used[b] if b != ground else np.uint64(0))
        pick = COLOURS - 1
        for k in range(COLOURS - 1):
            if (taken >> np.uint64(k)) & np.uint64(1) == 0:
                pick = k
                break
        colour[c] = pick
        bit = np.uint64(1) << np.uint64(pick)
        used[a] |= bit
        if b != ground:
            used[b] |= bit
        colour_start[pick + 1] += 1
    for k in range(COLOURS):
        colour_start[k + 1] += colour_start[k]
    slot, _ = take(wholes, used_whole, total)
    fill = colour_start[:-1].copy()
    for c in range(total):
        slot[c] = fill[colour[c]]
        fill[colour[c]] += 1
    return slot, colour_start
