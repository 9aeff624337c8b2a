"""Sequential impulses (Gauss-Seidel): a contact solver of the `collisions` effect
(SOLVERS in contacts/__init__.py), on the contacts detection.py found, after each step's
smooth forces and faces. In sweeps over the contacts:

- velocity: a pair approaching along its normal gets the binary-collision impulse that
  sends it apart at restitution x its speed at impact (the step's own approach after
  impact, found as for the floor by faces.impact_speed, is not bounced). A rebound no
  faster than what the step itself added to the approach (at least |g| dt) is resting
  contact, as on the floor: without this a pile hops for ever. Coulomb friction limits
  the tangential impulse to mu x that normal impulse (stick within mu_s, else slide at
  mu_k). Pool faces take part with infinite mass; a sphere a partner drives into a face
  rebounds from it without the step's gravity toward that face (the smooth step gave it
  that speed, and the face had already taken it: bouncing it too adds energy). Every
  impulse is equal and opposite (momentum kept to rounding) and never raises the pair's
  kinetic energy, whatever the order, which is why the sweeps may stop early. Then one
  sweep bottom up lets piles rest on the floor (_settle_on_floor); a sphere that
  rebounded off a partner this step neither rests nor holds another up.
- position: the overlap left is removed along each contact's normal, mass-weighted (the
  pair's centre of mass stays), with the faces clamping, until no overlap exceeds a
  quarter of OVERLAP_TOLERANCE x the smaller radius or POSITION_SWEEPS are done; after
  the first sweep, overlaps under _POSITION_SLOP are left alone.

Point masses do not spin: friction slows relative sliding, but nothing rolls and no
torque or spin passes between spheres.
"""
import math

import numba
import numpy as np

from ..kernels.faces import face_bounce, on_a_face, shift, velocity_against_faces
from ..kernels.friction import coulomb
from ..kernels.step_guard import finite, put_back
from .layers import bottom_up_order
from .detection import detect_contacts, take, END_POSITION, END_VELOCITY, RADIUS, \
    START_POSITION

# The most sweeps a step makes over its contacts; each stage stops once nothing changes.
VELOCITY_SWEEPS = 12
POSITION_SWEEPS = 10
# Overlap a pair may keep after a step, as a fraction of the smaller radius.
OVERLAP_TOLERANCE = 0.02
# After the first position sweep, overlaps below this fraction of the smaller radius stay:
# projecting them would chase rounding and pass the last sweep's small pushes through a
# whole pile, sweep after sweep, for nothing the tolerance asks.
_POSITION_SLOP = 0.05 * OVERLAP_TOLERANCE
# An approach slower than _SETTLED_SPEED (m/s) plus a fraction of |g| dt counts as none:
# float noise and solver lag, which the bottom-up sweep and the projection take care of.
# The fraction is _SETTLED_ACROSS, up to _SETTLED_ALONG x the cosine between the normal
# and gravity: sweeps spent below a tenth of a step's fall on weight-bearing contacts only
# passed a pile's weight along (at 1 % throughout, half the contacts of a landing 10 000
# fired in all 12 sweeps; at 10 % along gravity half as many), while a slow collision
# across gravity is a collision all the same, and left unswept it would pass no momentum.
# Such a pair closes by at most that speed x dt in the step, which the projection removes.
_SETTLED_SPEED = 1e-9
_SETTLED_ACROSS = 0.01
_SETTLED_ALONG = 0.1
# A contact whose normal is within 72 degrees of vertical can hold the upper sphere up
# (one resting on two or three below leans at 30 to 55 degrees, in a loose pile more);
# flatter ones are side by side, and neither holds the other.
_BEARING = 0.3
# Columns of the per-contact rows (facts) the sweeps read: the normal (unit), the approach
# a pair still apart may keep, the approach the step added after impact, the resting speed
# (all m/s), the gap's closing speed (m/s) and the pair's reduced mass (kg).
_NX, _NY, _NZ, _ALLOWED, _EXCESS, _RESTING, _CLOSING, _REDUCED_MASS = range(8)


@numba.njit(error_model='numpy')
def resolve_collisions(old_position, old_velocity, position, velocity, mass, radius, faces,
                       has_faces, contact, has_friction, resting_speed, gravity_step,
                       floor_supports, failed, reals, wholes, dt, flagged, identity,
                       memory_keys, memory_forces, memory_held, settings):
    """Find and resolve this step's sphere-sphere contacts in place (position, velocity:
    the step's end; old_*: its start). faces: the pool's (min_x, min_y, min_z, max_x,
    max_y, max_z) when has_faces. contact: (restitution, static_friction,
    kinetic_friction, rolling_friction). resting_speed: m/s, |g| dt. gravity_step: (3,)
    m/s, g dt (zero without gravity). floor_supports:
    gravity points down (-z) onto a floor, so piles rest on it (see _settle_on_floor).

    Returns how many spheres the step guard put back (flagged in failed): a sphere the
    impulses left non-finite goes back to the step's start, at rest. reals, wholes: the
    scratch its arrays come from (see workspace; empty ones will do). The rest: unused."""
    if radius.size < 2:
        return 0
    contacts, used_real, used_whole = detect_contacts(old_position, old_velocity, position,
                                                     velocity, radius, dt, reals, wholes)
    if contacts.pairs.shape[1] == 0:
        return 0
    restitution, static_friction, kinetic_friction = contact[0], contact[1], contact[2]
    ends, member, rows, inverse_mass, r, on_face, used_real, used_whole = _rows(
        contacts, mass, faces, has_faces, reals, used_real, wholes, used_whole)
    p, v, start, entry = rows[0], rows[1], rows[2], rows[3]
    facts, used_real = _facts(contacts, ends, v, inverse_mass, resting_speed, reals,
                              used_real)
    # Sweep at which each row's velocity (then position) last changed: a contact neither
    # of whose spheres changed since its last visit is as it was, and is skipped.
    changed_in, used_whole = take(wholes, used_whole, r.size)
    rebounded = _velocity_sweeps(ends, facts, p, start, v, r, inverse_mass, on_face,
                                 changed_in, faces, has_faces, restitution, static_friction,
                                 kinetic_friction, has_friction, resting_speed, gravity_step)
    resting = floor_supports and has_faces
    if resting:
        supported = _settle_on_floor(ends, facts, p, start, v, r, rebounded, faces,
                                     static_friction, kinetic_friction, has_friction,
                                     resting_speed, wholes, used_whole)
    else:
        supported = np.zeros(0, dtype=np.bool_)
    _position_sweeps(ends, facts, p, start, r, inverse_mass, changed_in, faces, has_faces,
                     static_friction, kinetic_friction, has_friction)
    if resting:
        _rest_correction(p, start, entry, v, supported, rebounded, static_friction,
                         has_friction, resting_speed, dt)
    put_back_count = 0
    for k in range(r.size):
        i = contacts.order[member[k]]
        for axis in range(3):
            position[axis, i] = p[k, axis]
            velocity[axis, i] = v[k, axis]
        if failed[i] or finite((p[k, 0], p[k, 1], p[k, 2], v[k, 0], v[k, 1], v[k, 2])):
            continue
        put_back(position, velocity, old_position, failed, i)
        put_back_count += 1
    return put_back_count


@numba.njit(error_model='numpy')
def _rows(contacts, mass, faces, has_faces, reals, used_real, wholes, used_whole):
    """The sweeps run on copies in rows: each sphere in contact (in cell order) has its x,
    y, z in one cache line, and each contact its facts in one row, so a sweep reads memory
    near what it just read. Returns (ends (m, 2) int64, each contact's two rows; member
    (members,) int64, each row's row of contacts.state; rows (4, members, 4): position m,
    velocity m/s, position at the step's start m, position before the sweeps m, the fourth
    column padding a row to 32 bytes; inverse_mass 1/kg; radius m; on_face bool (members,)
    each; used reals; used wholes)."""
    pairs, state, found = contacts.pairs, contacts.state, contacts.pairs.shape[1]
    count = state.shape[0]
    row_of, used_whole = take(wholes, used_whole, count)  # state's row -> ours, or -1
    row_of[:] = -1
    for c in range(found):
        row_of[pairs[0, c]], row_of[pairs[1, c]] = 0, 0
    member, used_whole = take(wholes, used_whole, count)  # our row -> state's
    members = 0
    for k in range(count):
        if row_of[k] == 0:
            row_of[k] = members
            member[members] = k
            members += 1
    ends, used_whole = take(wholes, used_whole, 2 * found)
    ends = ends.reshape((found, 2))  # contact -> its two rows
    for c in range(found):
        ends[c, 0], ends[c, 1] = row_of[pairs[0, c]], row_of[pairs[1, c]]
    rows, used_real = take(reals, used_real, 16 * members)
    rows = rows.reshape((4, members, 4))  # the fourth column pads a row to 32 bytes
    rows[:, :, 3] = 0.0
    p = rows[0]  # position, m
    v = rows[1]  # velocity, m/s
    start = rows[2]  # position at the step's start, m
    entry = rows[3]  # position before the sweeps, m
    inverse_mass, used_real = take(reals, used_real, members)  # 1/kg
    r, used_real = take(reals, used_real, members)  # radius, m
    on_face = np.zeros(members, dtype=np.bool_)
    for k in range(members):
        row = member[k]
        for axis in range(3):  # as detect_contacts' state holds them
            p[k, axis] = state[row, END_POSITION + axis]
            v[k, axis] = state[row, END_VELOCITY + axis]
            start[k, axis] = state[row, START_POSITION + axis]
            entry[k, axis] = state[row, END_POSITION + axis]
        inverse_mass[k] = 1.0 / mass[contacts.order[row]]
        r[k] = state[row, RADIUS]
        if has_faces:
            on_face[k] = on_a_face(faces, r[k], p, start, k)
    return ends, member[:members], rows, inverse_mass, r, on_face, used_real, used_whole


@numba.njit(error_model='numpy')
def _facts(contacts, ends, v, inverse_mass, resting_speed, reals, used_real):
    """(facts (m, 8), used reals): each contact's row of the columns _NX.._REDUCED_MASS."""
    normals, closing, found = contacts.normal, contacts.closing, ends.shape[0]
    facts, used_real = take(reals, used_real, 8 * found)
    facts = facts.reshape((found, 8))
    for c in range(found):
        a, b = ends[c, 0], ends[c, 1]
        facts[c, _NX], facts[c, _NY], facts[c, _NZ] = normals[0, c], normals[1, c], normals[2, c]
        # What a pair still apart may keep of its approach: its gap / dt, or the approach
        # it came with if faster. It has not hit yet (the next step finds the impact, and
        # bounces it); this only stops impulses elsewhere in this step driving it through
        # its gap.
        facts[c, _ALLOWED] = 0.0 if not closing[c] > 0.0 else max(closing[c], -(
            (v[a, 0] - v[b, 0]) * normals[0, c] + (v[a, 1] - v[b, 1]) * normals[1, c]
            + (v[a, 2] - v[b, 2]) * normals[2, c]))
        facts[c, _EXCESS] = contacts.excess[c]
        facts[c, _RESTING] = max(contacts.added[c], resting_speed)
        facts[c, _CLOSING] = closing[c]
        facts[c, _REDUCED_MASS] = 1.0 / (inverse_mass[a] + inverse_mass[b])  # kg
    return facts, used_real


@numba.njit(error_model='numpy')
def _velocity_sweeps(ends, facts, p, start, v, r, inverse_mass, on_face, changed_in, faces,
                     has_faces, restitution, static_friction, kinetic_friction, has_friction,
                     resting_speed, gravity_step):
    """Impulses, contact after contact, until none changes or VELOCITY_SWEEPS are done (see
    the module's docstring), on the rows of resolve_collisions. Returns rebounded (rows,)
    bool: the spheres that bounced off a partner this step."""
    found, members = ends.shape[0], r.size
    changed_in[:] = 0
    rebounded = np.zeros(members, dtype=np.bool_)  # bounced off a partner this step
    settled_across = _SETTLED_SPEED + _SETTLED_ACROSS * resting_speed
    # Down, as a unit vector x _SETTLED_ALONG x |g| dt (gravity_step is zero without gravity).
    down = (_SETTLED_ALONG * gravity_step[0], _SETTLED_ALONG * gravity_step[1],
            _SETTLED_ALONG * gravity_step[2])
    for sweep in range(1, VELOCITY_SWEEPS + 1):
        changed = False
        for c in range(found):
            a, b = ends[c, 0], ends[c, 1]
            if changed_in[a] < sweep - 1 and changed_in[b] < sweep - 1:
                continue
            nx, ny, nz = facts[c, _NX], facts[c, _NY], facts[c, _NZ]
            rx = v[a, 0] - v[b, 0]
            ry = v[a, 1] - v[b, 1]
            rz = v[a, 2] - v[b, 2]
            approach = -(rx * nx + ry * ny + rz * nz) - facts[c, _ALLOWED]
            settled = max(settled_across, _SETTLED_SPEED + abs(
                nx * down[0] + ny * down[1] + nz * down[2]))
            if not approach > settled:
                continue
            changed = True
            changed_in[a], changed_in[b] = sweep, sweep
            # The rebound keeps restitution x the speed at impact; what the step added
            # after impact, and rebounds within resting speed, are not bounced. A pair
            # still apart has not hit: it is only kept from closing its gap too fast.
            bounced = 0.0 if facts[c, _CLOSING] > 0.0 else face_bounce(
                max(approach - facts[c, _EXCESS], 0.0), restitution, facts[c, _RESTING])
            if bounced > 0.0:
                rebounded[a], rebounded[b] = True, True
            wi, wj = inverse_mass[a], inverse_mass[b]
            impulse = (approach + bounced) * facts[c, _REDUCED_MASS]  # N s along the normal
            fx, fy, fz = impulse * nx, impulse * ny, impulse * nz  # on the first sphere
            if has_friction:
                # The sliding the normal impulse leaves is the sliding before it (that
                # impulse is along the normal): found from the same velocities, and both
                # impulses applied at once.
                along = rx * nx + ry * ny + rz * nz
                tx, ty, tz = rx - along * nx, ry - along * ny, rz - along * nz
                sliding = math.sqrt(tx * tx + ty * ty + tz * tz)
                if sliding > 0.0:
                    stick = sliding * facts[c, _REDUCED_MASS]  # the impulse that stops it
                    grip = coulomb(stick, impulse, static_friction, kinetic_friction)[1] / sliding
                    fx, fy, fz = fx - grip * tx, fy - grip * ty, fz - grip * tz
            v[a, 0] += wi * fx
            v[b, 0] -= wj * fx
            v[a, 1] += wi * fy
            v[b, 1] -= wj * fy
            v[a, 2] += wi * fz
            v[b, 2] -= wj * fz
            if has_faces:
                if on_face[a]:
                    velocity_against_faces(faces, r[a], p, start, v, a, restitution,
                                            resting_speed, gravity_step)
                if on_face[b]:
                    velocity_against_faces(faces, r[b], p, start, v, b, restitution,
                                            resting_speed, gravity_step)
        if not changed:
            break
    return rebounded


@numba.njit(error_model='numpy')
def _position_sweeps(ends, facts, p, start, r, inverse_mass, changed_in, faces, has_faces,
                     static_friction, kinetic_friction, has_friction):
    """The overlap left removed along each contact's normal, mass-weighted, with Coulomb
    friction on the step's sliding, until none exceeds a quarter of OVERLAP_TOLERANCE x
    the smaller radius or POSITION_SWEEPS are done (see the module's docstring)."""
    found = ends.shape[0]
    changed_in[:] = 0
    for sweep in range(1, POSITION_SWEEPS + 1):
        worst = 0.0
        for c in range(found):
            a, b = ends[c, 0], ends[c, 1]
            if changed_in[a] < sweep - 1 and changed_in[b] < sweep - 1:
                continue
            nx, ny, nz = facts[c, _NX], facts[c, _NY], facts[c, _NZ]
            separation = ((p[a, 0] - p[b, 0]) * nx + (p[a, 1] - p[b, 1]) * ny
                          + (p[a, 2] - p[b, 2]) * nz)
            overlap = r[a] + r[b] - separation
            smaller = min(r[a], r[b])
            if not overlap > (0.0 if sweep == 1 else _POSITION_SLOP * smaller):
                continue
            changed_in[a], changed_in[b] = sweep, sweep
            worst = max(worst, overlap / smaller)
            share_a = inverse_mass[a] * facts[c, _REDUCED_MASS]
            share_b = inverse_mass[b] * facts[c, _REDUCED_MASS]
            # Along the normal: the overlap, shared by inverse mass (the pair's centre of
            # mass stays).
            px, py, pz = overlap * nx, overlap * ny, overlap * nz
            if has_friction and sweep == 1:
                # Across it: Coulomb on the step's relative sliding (Macklin et al. 2014),
                # undone while within mu_s x the overlap, else by mu_k x it. In velocity
                # alone each step's small slide would stay, and a pile creep flat.
                sx = (p[a, 0] - start[a, 0]) - (p[b, 0] - start[b, 0])
                sy = (p[a, 1] - start[a, 1]) - (p[b, 1] - start[b, 1])
                sz = (p[a, 2] - start[a, 2]) - (p[b, 2] - start[b, 2])
                along = sx * nx + sy * ny + sz * nz
                tx, ty, tz = sx - along * nx, sy - along * ny, sz - along * nz
                slid = math.sqrt(tx * tx + ty * ty + tz * tz)
                if slid > 0.0:
                    undone = coulomb(slid, overlap, static_friction, kinetic_friction)[1] / slid
                    px, py, pz = px - undone * tx, py - undone * ty, pz - undone * tz
            shift(p, r[a], a, share_a * px, share_a * py, share_a * pz, faces, has_faces)
            shift(p, r[b], b, -share_b * px, -share_b * py, -share_b * pz, faces, has_faces)
        if worst <= 0.25 * OVERLAP_TOLERANCE:
            break


@numba.njit(error_model='numpy')
def _rest_correction(p, start, entry, v, supported, rebounded, static_friction, has_friction,
                     resting_speed, dt):
    """A resting sphere (supported, not rebounded; rows of resolve_collisions) moves up and
    down as its position did, if that is slower: what is left of its velocity after the
    sweeps is the solver's lag, which the projection has undone in position (as
    position-based dynamics derives velocity), and the floor below takes that momentum.
    Across, the floor takes momentum only by friction: there the velocity takes on what
    the projection itself moved the sphere / dt, if that slows it, and only with friction,
    by at most a step of Coulomb friction under its weight (mu_s |g| dt). The whole step's
    move / dt, as it was, took momentum no floor gives up (two spheres meeting slowly on a
    frictionless floor kept half of theirs), and under any integrator but semi-implicit
    Euler it is the velocity at mid-step: spheres touching one another on the floor,
    pushed, were held back as by friction twice."""
    most_across = static_friction * resting_speed if has_friction else 0.0
    for k in range(p.shape[0]):
        if not supported[k] or rebounded[k]:
            continue  # a bounce is not lag
        moved = p[k, 2] - start[k, 2]
        if abs(moved) < dt * abs(v[k, 2]):
            v[k, 2] = moved / dt
        sx, sy = (p[k, 0] - entry[k, 0]) / dt, (p[k, 1] - entry[k, 1]) / dt
        tx, ty = v[k, 0] + sx, v[k, 1] + sy
        if (tx * tx + ty * ty < v[k, 0] * v[k, 0] + v[k, 1] * v[k, 1]
                and sx * sx + sy * sy <= most_across * most_across):
            v[k, 0], v[k, 1] = tx, ty


@numba.njit(error_model='numpy')
def _settle_on_floor(ends, facts, p, start, v, r, rebounded, faces, static_friction,
                     kinetic_friction, has_friction, resting_speed, wholes, used_whole):
    """One last sweep, bottom up, that lets a pile rest (shock propagation, Guendelman et
    al. 2003): a sphere on the floor, or on one that rests, is as immovable as the floor
    for the sphere above it, whose approach (and, within Coulomb, its sliding) stops.

    Sequential impulses alone pass a pile's weight down a layer per sweep, so a pile of k
    layers would keep velocities of order g dt unless swept ~k^2 times. The momentum so
    taken goes to the floor, as in a resting pile it does. ends, facts, p, start, v, r,
    rebounded: the rows of resolve_collisions; wholes from used_whole on: scratch (see
    workspace). A sphere on the floor at the step's start or end rests on it. A sphere that
    bounced off a partner in this step neither rests nor holds anything up: it is moving,
    and treating it as immovable would hand its speed, at the floor's expense, to whatever
    lies on it (a light sphere on the floor, struck by a heavy one, sent the heavy one up
    at its own rebound speed). Nor does one on the floor rising faster than a step's fall
    (resting_speed) hold anything up: it is lifting off (a buoyant sphere rising off the
    floor at 0.44 m/s under one that slid across it pushed that one on along their slanted
    normal and was then stopped as resting: the pair gained energy). Above the floor the
    rest correction below leaves a resting sphere rising by what the projection lifted it
    (up to ~0.1 m/s): taking such spheres as lifting off too left a pile's upper layers
    unsettled, its late steps twice as dear.

    Returns supported (rows,) bool: the spheres found resting."""
    found = ends.shape[0]
    members = r.size
    # Contacts ordered by the lower sphere's height: a counting sort on layers of the
    # smallest radius.
    order, used_whole = bottom_up_order(ends, p[:, 2], r, wholes, used_whole)
    supported = np.empty(members, dtype=np.bool_)
    lifting = np.empty(members, dtype=np.bool_)
    for k in range(members):
        supported[k] = (min(p[k, 2], start[k, 2]) <= faces[2] + r[k] * (1.0 + 1e-9)
                        and not rebounded[k])
        # On the floor and rising faster than a step's fall: lifting off, holds nothing up
        # (it is still a resting sphere for the rest correction).
        lifting[k] = supported[k] and v[k, 2] > resting_speed
    # Who rests on what: sorted bottom up, a few passes reach every layer (a pass misses
    # only a sphere held up through one of its own layer met later).
    carries, used_whole = take(wholes, used_whole, found)
    carries[:] = 0  # 1: the first sphere rests on the second
    for _ in range(8):
        spread = False
        for k in range(found):
            c = order[k]
            if facts[c, _CLOSING] > resting_speed or carries[c] != 0:
                continue  # apart by more than a step's fall: holds nothing up; or known
            first, second = ends[c, 0], ends[c, 1]
            if facts[c, _NZ] > _BEARING and supported[second] and not lifting[second]:
                carries[c], upper = 1, first
            elif facts[c, _NZ] < -_BEARING and supported[first] and not lifting[first]:
                carries[c], upper = 2, second
            else:
                continue
            if rebounded[upper]:
                carries[c] = 0
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
            upper, lower, sign = ends[c, 0], ends[c, 1], 1.0
        else:
            upper, lower, sign = ends[c, 1], ends[c, 0], -1.0
        nx, ny, nz = sign * facts[c, _NX], sign * facts[c, _NY], sign * facts[c, _NZ]
        rx = v[upper, 0] - v[lower, 0]
        ry = v[upper, 1] - v[lower, 1]
        rz = v[upper, 2] - v[lower, 2]
        approach = -(rx * nx + ry * ny + rz * nz) - facts[c, _CLOSING]
        if not approach > 0.0:
            continue
        v[upper, 0] += approach * nx
        v[upper, 1] += approach * ny
        v[upper, 2] += approach * nz
        if has_friction:
            rx, ry, rz = rx + approach * nx, ry + approach * ny, rz + approach * nz
            tx, ty, tz = rx, ry, rz  # normal part now zero
            sliding = math.sqrt(tx * tx + ty * ty + tz * tz)
            if sliding > 0.0:
                grip = coulomb(sliding, approach, static_friction, kinetic_friction)[1] / sliding
                v[upper, 0] -= grip * tx
                v[upper, 1] -= grip * ty
                v[upper, 2] -= grip * tz
    return supported
