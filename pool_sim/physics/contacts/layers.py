"""Contacts ordered bottom up, for the sweeps that let a pile rest on the floor (shock
propagation, Guendelman et al. 2003): sequential_impulses' last sweep and soft_step's
support sweep each visit a contact after the contacts below it."""
import math

import numba
import numpy as np

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
    layers = layer_count(lowest, highest, smallest, found)
    layer, used_whole = take(wholes, used_whole, found)
    for c in range(found):
        layer[c] = layer_of(min(z[ends[c, 0]], z[ends[c, 1]]), lowest, smallest, layers)
    order, _, used_whole = counting_sort(layer, layers, wholes, used_whole)
    return order, used_whole


@numba.njit(error_model='numpy')
def layer_count(lowest, highest, smallest, found):
    """How many layers bottom_up_order sorts found contacts into: as thick as the smallest
    radius m from the lowest sphere's height m to the highest's, at most 4 found."""
    return int(min((highest - lowest) / smallest, 4.0 * found)) + 1


@numba.njit(error_model='numpy')
def layer_of(height, lowest, smallest, layers):
    """The layer of a contact whose lower sphere is at height m (layer_count's)."""
    return min(int((height - lowest) / smallest), layers - 1)


@numba.njit(error_model='numpy')
def sweep_waves(ends, members):
    """(order (b,) int64, bounds (w + 1,) int64): a serial sweep's contacts (ends (b, 2):
    the sphere each writes, then the one it only reads, rows below members) regrouped into
    waves that may each be swept at once (the support sweep on a GPU): a contact goes in a
    later wave than every contact before it that writes a sphere it touches or reads the
    one it writes. So no two contacts of a wave touch a sphere one of them writes, and
    wave after wave is the serial sweep's result to the bit. Within a wave, the contacts
    keep their order; wave k is order[bounds[k]:bounds[k + 1]]."""
    found = ends.shape[0]
    written = np.full(members, -1, dtype=np.int64)  # the last wave that wrote each sphere
    read = np.full(members, -1, dtype=np.int64)  # the last wave that read it
    wave = np.empty(found, dtype=np.int64)
    waves = 0
    for q in range(found):
        writes, reads = ends[q, 0], ends[q, 1]
        w = max(written[writes], written[reads], read[writes]) + 1
        wave[q] = w
        written[writes] = w
        read[reads] = max(read[reads], w)
        waves = max(waves, w + 1)
    order, bounds, _ = counting_sort(wave, waves, np.empty(0, dtype=np.int64), 0)
    return order, bounds
