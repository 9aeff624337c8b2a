"""Sphere-sphere contact, the `collisions` effect: detection.py finds this step's contacts
(one Contacts record), a solver resolves them. A solver is one file here, registered in
SOLVERS under the name a scene chooses it by; each takes the arguments of
sequential_impulses.resolve_collisions."""
from .detection import overlaps, workspace
from .sequential_impulses import resolve_collisions

SOLVERS = {'sequential_impulses': resolve_collisions}
DEFAULT_SOLVER = 'sequential_impulses'

__all__ = ['DEFAULT_SOLVER', 'overlaps', 'SOLVERS', 'workspace']
