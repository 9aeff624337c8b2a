"""Contact detection's narrow phase (detection.py): for a pair whose bounding spheres met,
the time of impact of its two centres, moving linearly over the step, and the contact's
facts at that moment; and the columns of the spheres' state (Contacts.state) it reads."""
import math

import numba

from ..kernels.faces import impact_speed

# Columns of Contacts.state: a row is two cache lines.
START_POSITION, END_POSITION, START_VELOCITY, END_VELOCITY, RADIUS = 0, 3, 6, 9, 12
STATE_COLUMNS = 16
# Centres this much (of the radii's sum) beyond touching still touch: rounding.
_TOUCHING = 1e-9


@numba.njit(error_model='numpy', inline='always')
def narrow_into(state, candidates, c, dt, facts):
    """The narrow phase of candidate pair c (rows of state) into facts[:, c]: normal (3),
    excess, added, closing (Contacts)."""
    normal, excess, added, closing = _narrow_phase(state, candidates[0, c], candidates[1, c],
                                                   dt)
    facts[0, c], facts[1, c], facts[2, c] = normal
    facts[3, c], facts[4, c], facts[5, c] = excess, added, closing


@numba.njit(error_model='numpy', inline='always')
def _difference(state, i, j, column):
    """Row i less row j of state (Contacts.state) in the three columns from column on."""
    return (state[i, column] - state[j, column], state[i, column + 1] - state[j, column + 1],
            state[i, column + 2] - state[j, column + 2])


@numba.njit(error_model='numpy', inline='always')
def _narrow_phase(state, i, j, dt):
    """(normal (3-tuple), excess m/s, added m/s, closing m/s) of the spheres of rows i, j
    of state (Contacts.state), whose bounding spheres met; see Contacts."""
    reach = state[i, RADIUS] + state[j, RADIUS]
    d0 = _difference(state, i, j, START_POSITION)
    d1 = _difference(state, i, j, END_POSITION)
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
    w0 = _difference(state, i, j, START_VELOCITY)
    w1 = _difference(state, i, j, END_VELOCITY)
    approach_start = -(w0[0] * normal[0] + w0[1] * normal[1] + w0[2] * normal[2])
    approach_end = -(w1[0] * normal[0] + w1[1] * normal[1] + w1[2] * normal[2])
    before = max(d0[0] * normal[0] + d0[1] * normal[1] + d0[2] * normal[2] - reach, 0.0)
    past = max(reach - (d1[0] * normal[0] + d1[1] * normal[1] + d1[2] * normal[2]), 0.0)
    at_impact = impact_speed(approach_start, approach_end, before, past, dt)
    return normal, max(approach_end - at_impact, 0.0), approach_end - approach_start, 0.0
