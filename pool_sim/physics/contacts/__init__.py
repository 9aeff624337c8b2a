"""Sphere-sphere contact, the `collisions` effect: detection.py finds this step's contacts
(one Contacts record), a solver resolves them. A solver is one file here, registered in
SOLVERS under the name a scene chooses it by; each takes the arguments of
soft_step.resolve_collisions (SOLVES_FACES: the solvers that resolve their spheres' faces
themselves, run before the per-sphere face pass)."""
from .detection import overlaps, workspace
from .sequential_impulses import resolve_collisions
from . import soft_step
from .memory import contact_memory

SOLVERS = {'sequential_impulses': resolve_collisions,
           'soft_step': soft_step.resolve_collisions}
SOLVES_FACES = {'soft_step'}
DEFAULT_SOLVER = 'sequential_impulses'

__all__ = ['DEFAULT_SOLVER', 'contact_memory', 'overlaps', 'SOLVERS', 'SOLVES_FACES',
           'workspace']
