"""The fixed-step integrators a scene may choose, by name (each one compiled function of
kernels/integrators.py), and what each costs."""
from .kernels.integrators import explicit_euler, linearly_implicit_euler, rk4, \
    semi_implicit_euler, velocity_verlet

INTEGRATORS = {
    'explicit_euler': explicit_euler,
    'semi_implicit_euler': semi_implicit_euler,
    'velocity_verlet': velocity_verlet,
    'rk4': rk4,
    'linearly_implicit_euler': linearly_implicit_euler,
}
DEFAULT_INTEGRATOR = 'linearly_implicit_euler'
# How many times each evaluates the forces in a step.
FORCE_EVALUATIONS = {'explicit_euler': 1, 'semi_implicit_euler': 1, 'velocity_verlet': 2,
                     'rk4': 4, 'linearly_implicit_euler': 1}
