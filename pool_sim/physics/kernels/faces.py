"""Floor, walls and ceiling, for one sphere after its smooth step (resolve_contacts) and
for a sphere that a partner's impulse drives into one (the contact solvers in contacts/).

After the smooth step: resolved after each step, so no step size lets a sphere through.

A sphere whose step ended past a face, or on it and moving into it, is put back on it. Its
normal velocity becomes restitution x the speed at *impact*, not at the step's end: a sphere
resting on the floor gains g*dt during a step and would otherwise bounce back by e*g*dt and
jitter for ever, and one slowed on its way in (a cork pushed down through water) would
leave faster than it hit. Friction on the floor works with impulses: Coulomb's bound is mu x
the normal impulse the floor gave in this step, which for a resting sphere is exactly its
weight x dt.

The faces are a box: faces = (min_x, min_y, min_z, max_x, max_y, max_z) m, the pool's
corners; a sphere's centre stays within faces[axis] + radius and faces[axis + 3] - radius.
"""
import math

import numba

from . import compiled
from .friction import coulomb


@compiled
def inside_faces(coordinate, faces, axis, radius):
    """coordinate (m, along axis) held within the faces for a sphere of radius m."""
    return min(max(coordinate, faces[axis] + radius), faces[axis + 3] - radius)


@compiled
def _against_faces(low, high, p, v, old_p, old_v, restitution, dt):
    """One axis of one sphere against its two faces, low and high (m, the centre's limits):
    (position, velocity, impulse per mass from the low face (m/s), overflow).

    overflow: the bounce speed would not fit a double (the step guard's, then)."""
    if low < p < high:
        return p, v, 0.0, False  # almost every sphere, on every axis: two comparisons
    below = p < low or (p == low and v < 0.0)
    if not (below or p > high or (p == high and v > 0.0)):
        return p, v, 0.0, False
    inward = 1.0 if below else -1.0
    face = low if below else high
    normal_speed = inward * v
    if normal_speed >= 0.0:
        bounced = normal_speed
    elif old_v == 0.0 and old_p == face:
        bounced = 0.0  # at rest on the face: what impact_speed gives, at once
    else:
        approach_start, approach_end = -inward * old_v, -normal_speed
        bounced = restitution * impact_speed(
            approach_start, approach_end, max(inward * (old_p - face), 0.0),
            max(inward * (face - p), 0.0), dt)
        # A rebound no faster than the speed the step added toward the face would be back
        # on it within a step: resting contact. Without this, explicit Euler, whose every
        # step gains energy, hops on the floor for ever.
        if not bounced > approach_end - approach_start:
            bounced = 0.0
        if not math.isfinite(bounced):
            return p, v, 0.0, True
    return face, inward * bounced, (bounced - normal_speed) if below else 0.0, False


@compiled
def impact_speed(approach_start, approach_end, before, past, dt):
    """Speed (m/s) at which a sphere reached the face in this step.

    approach_*: normal speed toward the face at the step's start and end, m/s.  before,
    past: distance from the start position to the face and from the face to the end
    position, m, >= 0.  With the step's mean acceleration a = (approach_end -
    approach_start)/dt, two estimates: forward from the start, v^2 = approach_start^2 +
    2*a*before, and back from the end, v^2 = approach_end^2 - 2*a*past. Both are exact under
    a constant force. Where the force changes within the step (a sphere crossing the
    waterline), gravity and buoyancy (gravity down) weaken toward either face; then at
    least one estimate, and so the lower, gives no more energy than the step's start had
    or its end would have had without the face.
    """
    acceleration = (approach_end - approach_start) / dt
    squared = min(approach_start * approach_start + 2.0 * acceleration * before,
                  approach_end * approach_end - 2.0 * acceleration * past)
    return math.sqrt(max(squared, 0.0))


@compiled
def resolve_contacts(pool, contact, friction, radius, old_state, state, dt):
    """Floor, walls and ceiling for one sphere, and friction on the floor when `friction`.

    pool: (min_x, min_y, min_z, max_x, max_y, max_z) m.  contact: ContactParameters' fields
    in order.  old_state, state: (x, y, z, vx, vy, vz) at the step's start and end.
    Returns (the state after contact, overflow): overflow when a bounce speed would not
    fit a double, for the step guard.
    """
    restitution, static_friction, kinetic_friction, rolling_friction = contact
    x, y, z, vx, vy, vz = state
    ox, oy, oz, ovx, ovy, ovz = old_state
    x, vx, _, overflow_x = _against_faces(pool[0] + radius, pool[3] - radius, x, vx, ox, ovx,
                                          restitution, dt)
    y, vy, _, overflow_y = _against_faces(pool[1] + radius, pool[4] - radius, y, vy, oy, ovy,
                                          restitution, dt)
    z, vz, floor_impulse, overflow_z = _against_faces(pool[2] + radius, pool[5] - radius, z,
                                                      vz, oz, ovz, restitution, dt)
    if overflow_x or overflow_y or overflow_z:
        return state, True
    if friction and floor_impulse > 0.0:
        # Coulomb at the impulse level: stick while the tangential speed is within
        # mu_s x the normal impulse per mass, else slide. A sticking sphere keeps its
        # horizontal place from the step's start: otherwise the tiny slide of each step,
        # undone in velocity only, would add up to a creep.
        tangential_speed = math.hypot(vx, vy)
        sticks, slowdown = coulomb(tangential_speed, floor_impulse, static_friction,
                                   kinetic_friction + rolling_friction)
        if sticks:
            x, y, vx, vy = ox, oy, 0.0, 0.0
        else:
            slowdown = min(tangential_speed, slowdown)
            scale = 1.0 - slowdown / tangential_speed if tangential_speed > 0.0 else 1.0
            # Position follows the velocity change as a symplectic step would.
            x += dt * (vx * scale - vx)
            y += dt * (vy * scale - vy)
            vx, vy = vx * scale, vy * scale
        # Friction's position correction must not undo a wall's: in a corner it points
        # back at the wall the sphere just bounced off.
        x = inside_faces(x, pool, 0, radius)
        y = inside_faces(y, pool, 1, radius)
    return (x, y, z, vx, vy, vz), False


# After an impulse from a partner (the contact solvers), on the rows of a solver's arrays.
@numba.njit(error_model='numpy', inline='always')
def face_bounce(approach, restitution, resting_speed):
    """Speed away from a face (or partner) after an approach (m/s) resolved with
    restitution: none when no faster than resting_speed (resting contact)."""
    bounced = restitution * approach
    return bounced if bounced > resting_speed else 0.0


@numba.njit(error_model='numpy', inline='always')
def _against_face_pair(low, high, p, q, v, slack, restitution, resting_speed, gravity_step):
    """One axis: the velocity (m/s) of a sphere at p at the step's end and q at its start
    (m, its centre's limits low, high) after it meets the face it is on, at either, and
    moving into, if any. gravity_step: what gravity adds to the velocity along the axis in
    a step, m/s. (A sphere that buoyancy lifts off the floor within the step, then struck
    from above, is still on the floor: without that its partner's fall went unchecked.)

    An impulse from a partner drove it into the face some time within the step, so it
    left the face with at most that time's gravity still to come: the rebound gives up
    the step's gravity into the face (without it a sphere on the floor, struck from
    above, bounced back with the fall its partner made after impact, and the pair gained
    energy)."""
    if v < 0.0 and min(p, q) <= low + slack:
        return max(face_bounce(-v, restitution, resting_speed) + min(gravity_step, 0.0),
                   0.0)
    if v > 0.0 and max(p, q) >= high - slack:
        return -max(face_bounce(v, restitution, resting_speed) - max(gravity_step, 0.0),
                    0.0)
    return v


@numba.njit(error_model='numpy', inline='always')
def on_a_face(faces, r, position, start, k):
    """Whether the sphere of row k (radius r m) is on a face at the step's end (position)
    or start, where velocity_against_faces may change its velocity."""
    slack = 1e-9 * r
    for axis in range(3):
        if (min(position[k, axis], start[k, axis]) <= faces[axis] + r + slack
                or max(position[k, axis], start[k, axis]) >= faces[axis + 3] - r - slack):
            return True
    return False


@numba.njit(error_model='numpy', inline='always')
def velocity_against_faces(faces, r, position, start, velocity, k, restitution,
                            resting_speed, gravity_step):
    """The sphere of row k (radius r m), on a face (at the step's end, position, or its
    start) and moving into it after an impulse, bounces off it (or stops); gravity_step:
    gravity x dt, m/s (see _against_face_pair)."""
    slack = 1e-9 * r
    for axis in range(3):
        velocity[k, axis] = _against_face_pair(faces[axis] + r, faces[axis + 3] - r,
                                               position[k, axis], start[k, axis],
                                               velocity[k, axis], slack, restitution,
                                               resting_speed, gravity_step[axis])


@numba.njit(error_model='numpy', inline='always')
def shift(position, r, k, sx, sy, sz, faces, has_faces):
    """Move the sphere of row k (radius r m) by (sx, sy, sz) m to undo an overlap, but not
    through a face."""
    for axis, step in ((0, sx), (1, sy), (2, sz)):
        moved = position[k, axis] + step
        if has_faces:
            moved = inside_faces(moved, faces, axis, r)
        position[k, axis] = moved
