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

import numpy as np


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


def resolve_contacts(pool, params, radius, old_position, old_velocity,
                     position, velocity, dt, friction):
    """Push spheres back inside the pool and bounce them; friction on the floor if asked.

    position, velocity: (3, n), changed in place.  old_*: the state at the step's start.
    radius: (n,) m.  Returns nothing.  All faces are handled in whole-array operations.
    """
    low = pool.corner_min[:, None] + radius
    high = pool.corner_max[:, None] - radius
    # On a face and moving into it is contact too: explicit Euler's position lags its
    # velocity, so a sphere resting on the floor ends each step exactly on it.
    below = (position < low) | ((position == low) & (velocity < 0.0))
    above = (position > high) | ((position == high) & (velocity > 0.0))
    hit = below | above
    if not hit.any():
        return
    inward = np.where(below, 1.0, -1.0)
    face = np.where(below, low, high)
    normal_speed = inward * velocity
    approach_start, approach_end = -inward * old_velocity, -normal_speed
    rebound = params.restitution * impact_speed(
        approach_start, approach_end, np.maximum(inward * (old_position - face), 0.0),
        np.maximum(inward * (face - position), 0.0), dt)
    # A rebound no faster than the speed the step added toward the face would be back on it
    # within a step: resting contact. Without this, explicit Euler, whose every step gains
    # energy, hops on the floor for ever.
    rebound = np.where(rebound > approach_end - approach_start, rebound, 0.0)
    bounced = np.where(normal_speed >= 0.0, normal_speed, rebound)
    position[hit] = face[hit]
    velocity[hit] = (inward * bounced)[hit]
    if friction and below[2].any():
        floor_impulse_per_mass = np.where(below[2], bounced[2] - normal_speed[2], 0.0)
        _floor_friction(params, floor_impulse_per_mass, old_position, position, velocity, dt)
        # Friction's position correction must not undo a wall's: in a corner it points back
        # at the wall the sphere just bounced off.
        np.clip(position[:2], low[:2], high[:2], out=position[:2])


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
    squared = np.minimum(approach_start * approach_start + 2.0 * acceleration * before,
                         approach_end * approach_end - 2.0 * acceleration * past)
    return np.sqrt(np.maximum(squared, 0.0))


def _floor_friction(params, impulse_per_mass, old_position, position, velocity, dt):
    """Stick while the needed tangential impulse is within mu_s x normal impulse, else slide.

    A sticking sphere keeps its horizontal place from the step's start: otherwise the tiny
    slide of each step, undone in velocity only, would add up to a creep.
    """
    touching = impulse_per_mass > 0.0
    tangential = velocity[:2, touching]
    tangential_speed = np.hypot(tangential[0], tangential[1])
    normal_impulse = impulse_per_mass[touching]
    sticks = tangential_speed <= params.static_friction * normal_impulse
    slowdown = np.minimum(
        tangential_speed,
        (params.kinetic_friction + params.rolling_friction) * normal_impulse)
    scale = np.where(sticks, 0.0, 1.0 - np.divide(
        slowdown, tangential_speed, out=np.ones_like(slowdown), where=tangential_speed > 0.0))
    new_tangential = tangential * scale
    # Position follows the velocity change as a symplectic step would; sticking undoes the slide.
    moved = position[:2, touching] + dt * (new_tangential - tangential)
    position[:2, touching] = np.where(sticks, old_position[:2, touching], moved)
    velocity[:2, touching] = new_tangential
