"""The wave-band pass's bookkeeping (physics/stepper.py's docstring): which spheres cross
the water's surface, and their data gathered into contiguous arrays and scattered back, so
that the pass computes wave radiation for them alone, vectorised."""
import numpy as np

from . import compiled
from .effects import near_surface
from .layout import body_of

# The first pass's mark (in flagged, beside stepper's face mark) of a sphere crossing the
# surface at the step's start, where it is headed or at its end.
BAND_MARK = 2
# Past one sphere in this many crossing the surface, the first pass computes wave radiation
# for every sphere rather than leave the crossing ones to a pass of their own, which pays
# for their dry step, gathering and scattering on top (measured at 10 000 spheres, one
# thread: the waves cost ~25 ns a sphere in the first pass, ~80 ns a crossing one there).
DENSE_BAND_SHARE = 4


@compiled
def crossing_count(env, properties, position):
    """How many spheres centred at position (3, n) m cross the water's surface."""
    near = 0
    for i in range(position.shape[1]):
        near += 1 if near_surface(env, body_of(properties, i), position[2, i]) else 0
    return near


@compiled
def band_scratch(count, properties):
    """The wave-band pass's scratch for up to count spheres (gather_band): their indices,
    their properties (as properties, the spheres' arrays, holds them), their start and end
    states (3, count) each, and their face marks (count,)."""
    return (np.empty(count, dtype=np.int64),
            (np.empty(count), np.empty(count), np.empty(count), np.empty(count),
             np.empty(count), np.empty(count), np.empty(count), np.empty((3, count)),
             np.empty((3, count)), np.empty(count), np.empty(count)),
            np.empty((3, count)), np.empty((3, count)), np.empty((3, count)),
            np.empty((3, count)), np.empty(count, dtype=np.uint8))


@compiled
def gather_band(flagged, properties, old_position, old_velocity, scratch):
    """How many spheres the first pass marked crossing the surface (BAND_MARK in flagged
    (n,)); their indices, properties and start states put in scratch (band_scratch), in
    order, so that the wave-band pass runs over contiguous arrays, vectorised (over the
    spheres' own arrays it would go one sphere at a time)."""
    band, band_properties, band_position, band_velocity = scratch[:4]
    count = 0
    for i in range(flagged.shape[0]):
        if flagged[i] & BAND_MARK:
            band[count] = i
            for axis in range(3):
                band_position[axis, count] = old_position[axis, i]
                band_velocity[axis, count] = old_velocity[axis, i]
            for to, of in zip(band_properties[:7], properties[:7]):  # mass to lift_area
                to[count] = of[i]
            for to, of in zip(band_properties[9:], properties[9:]):  # lift_slope, stall
                to[count] = of[i]
            for axis in range(3):  # lift_normal, external_force
                band_properties[7][axis, count] = properties[7][axis, i]
                band_properties[8][axis, count] = properties[8][axis, i]
            count += 1
    return count


@compiled
def scatter_band(scratch, count, new_position, new_velocity, flagged):
    """The wave-band pass's end states and face marks (in scratch, band_scratch) back to
    the spheres they belong to."""
    band, end_position, end_velocity, marks = scratch[0], scratch[4], scratch[5], scratch[6]
    for k in range(count):
        i = band[k]
        for axis in range(3):
            new_position[axis, i] = end_position[axis, k]
            new_velocity[axis, i] = end_velocity[axis, k]
        flagged[i] = marks[k]
