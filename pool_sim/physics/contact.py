"""The contact parameters a scene sets: what the faces (kernels/faces.py) and the contact
solvers (contacts/) take, as one tuple of their fields in order."""
from dataclasses import dataclass


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
