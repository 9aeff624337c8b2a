"""Floor, walls and ceiling: resolved after each step, so no step size lets a sphere through.

A sphere whose step ended past a face, or on it and moving into it, is put back on it. Its
normal velocity becomes restitution x the speed at *impact*, not at the step's end: a sphere
resting on the floor gains g*dt during a step and would otherwise bounce back by e*g*dt and
jitter for ever, and one slowed on its way in (a cork pushed down through water) would
leave faster than it hit. Friction on the floor works with impulses: Coulomb's bound is mu x
the normal impulse the floor gave in this step, which for a resting sphere is exactly its
weight x dt.
"""
from dataclasses import dataclass
import math

from .media import compiled


@dataclass(frozen=True)
class ContactParameters:
    """restitution: 0..1.  static_friction >= kinetic_friction >= 0.  rolling_friction >= 0.

    A point mass has no spin, so rolling resistance is modelled as a further retarding force
    rolling_friction x N on a sphere that moves along the floor.
    """

    restitution: float = 0.5
    static_friction: float = 0.6
    kinetic_friction: float = 0.4
    rolling_friction: float = 0.01


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
        if tangential_speed <= static_friction * floor_impulse:
            x, y, vx, vy = ox, oy, 0.0, 0.0
        else:
            slowdown = min(tangential_speed,
                           (kinetic_friction + rolling_friction) * floor_impulse)
            scale = 1.0 - slowdown / tangential_speed if tangential_speed > 0.0 else 1.0
            # Position follows the velocity change as a symplectic step would.
            x += dt * (vx * scale - vx)
            y += dt * (vy * scale - vy)
            vx, vy = vx * scale, vy * scale
        # Friction's position correction must not undo a wall's: in a corner it points
        # back at the wall the sphere just bounced off.
        x = min(max(x, pool[0] + radius), pool[3] - radius)
        y = min(max(y, pool[1] + radius), pool[4] - radius)
    return (x, y, z, vx, vy, vz), False
