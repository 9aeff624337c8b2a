"""Small scenes for the tests: one sphere, the keys the test cares about, defaults elsewhere."""
import math

from pool_sim.physics import Scene

WATER = 1000.0
G = 9.81


def sphere_volume(radius):
    return 4.0 / 3.0 * math.pi * radius**3


def one_sphere(radius=0.1, density=None, mass=None, position=(0.0, 0.0, -1.0),
               velocity=(0.0, 0.0, 0.0), pool_min=(-4.0, -4.0, -4.0),
               pool_max=(4.0, 4.0, 4.0), **global_keys):
    """A scene with one sphere 'ball'; give density (kg/m^3) or mass (kg)."""
    if mass is None:
        mass = (density if density is not None else 500.0) * sphere_volume(radius)
    params = {'sphere_names': ['ball'], 'ball.mass': mass, 'ball.radius': radius,
              'ball.position': list(position), 'ball.velocity': list(velocity),
              'pool.min': list(pool_min), 'pool.max': list(pool_max)}
    params.update({key.replace('__', '.'): value for key, value in global_keys.items()})
    return Scene(params)


def floating_draft_ratio(density_ratio):
    """Draft / radius at which the exact cap holds `density_ratio` of the volume.

    Bisection on h^2 (3 - h) / 4 = s, h = draft / r: independent of pool_sim's code.
    """
    low, high = 0.0, 2.0
    for _ in range(200):
        mid = 0.5 * (low + high)
        if mid * mid * (3.0 - mid) / 4.0 < density_ratio:
            low = mid
        else:
            high = mid
    return 0.5 * (low + high)
