"""Contacts ordered bottom up, for the sweeps that let a pile rest on the floor (shock
propagation, Guendelman et al. 2003): sequential_impulses' last sweep and soft_step's
support sweep each visit a contact after the contacts below it."""
import math

import numba

from .detection import counting_sort, take


@numba.njit(error_model='numpy')
def bottom_up_order(ends, z, radius, wholes, used_whole):
    """(order (m,) int64: the contacts (ends (m, 2), rows of z and radius) by the height z m
    of their lower sphere, lowest first; used wholes): a counting sort on layers as thick
    as the smallest radius m, from the lowest sphere to the highest (contacts in one layer
    keep their order; at most 4 m layers)."""
    found = ends.shape[0]
    lowest, highest, smallest = math.inf, -math.inf, math.inf
    for k in range(z.size):
        lowest, highest = min(lowest, z[k]), max(highest, z[k])
        smallest = min(smallest, radius[k])
    layers = int(min((highest - lowest) / smallest, 4.0 * found)) + 1
    layer, used_whole = take(wholes, used_whole, found)
    for c in range(found):
        height = min(z[ends[c, 0]], z[ends[c, 1]])
        layer[c] = min(int((height - lowest) / smallest), layers - 1)
    order, _, used_whole = counting_sort(layer, layers, wholes, used_whole)
    return order, used_whole
