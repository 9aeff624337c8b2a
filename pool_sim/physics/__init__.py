"""The physics core: numpy arrays stepped by one compiled loop (numba), no ROS. Start at
Simulation(Scene.default())."""
from .effects import DEFAULT_EFFECTS, EFFECTS
from .integrators import DEFAULT_INTEGRATOR, INTEGRATORS
from .scene import Scene
from .simulation import mechanical_energy, Simulation
from .spheres import InvalidInput, Spheres

__all__ = ['DEFAULT_EFFECTS', 'DEFAULT_INTEGRATOR', 'EFFECTS', 'INTEGRATORS',
           'InvalidInput', 'mechanical_energy', 'Scene', 'Simulation', 'Spheres']
