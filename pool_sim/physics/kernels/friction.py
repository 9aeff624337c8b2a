"""Coulomb's law, once, for every contact that has friction: a sphere on the floor
(faces.resolve_contacts) and a pair of spheres (contacts/), in impulses or in positions."""
from . import compiled


@compiled
def coulomb(sliding, normal, static_friction, kinetic_friction):
    """(sticks, removed): how much of `sliding` friction takes away, given what the normal
    direction gave (`normal`, in the same unit: an impulse per mass against a speed, an
    overlap against a slide). All of it while it is within static_friction x normal (it
    sticks), else kinetic_friction x normal (it slides; the caller bounds that by what there
    is to stop where it needs to)."""
    sticks = sliding <= static_friction * normal
    return sticks, sliding if sticks else kinetic_friction * normal
