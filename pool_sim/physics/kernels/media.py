"""How much of a sphere is under the water (physics/media.py's world: water below
surface_z, air above), per sphere: the exact spherical cap or, for comparison only, the
linear approximation."""
import math

from . import compiled


@compiled
def submerged_fraction(cap, z, radius, inverse_radius, surface_z):
    """Fraction of a sphere's volume below the surface (inverse_radius = 1/radius, 1/m: a
    product where a division would cost several).

    cap (True): the exact spherical cap: the cap of height h holds pi*h^2*(3r - h)/3 of the
    sphere's 4*pi*r^3/3. False: the seed's approximation, depth / diameter (for comparison).
    """
    depth = surface_z - (z - radius)
    depth = 0.0 if depth < 0.0 else depth
    depth = 2.0 * radius if depth > 2.0 * radius else depth
    h = depth * inverse_radius
    if cap:
        return 0.25 * h * h * (3.0 - h)
    return 0.5 * h


@compiled
def submerged_fraction_slope(cap, z_from, z_to, radius, inverse_radius, surface_z):
    """-(change of submerged_fraction) / (change of z) from z_from to z_to, 1/m: the secant
    slope, and at z_from == z_to the slope itself.

    In h = depth / r the cap's fraction is the cubic h^2 (3 - h) / 4, whose divided
    difference (3 (h1 + h2) - (h1^2 + h1 h2 + h2^2)) / 4 needs no division by h2 - h1, so
    there is no cancellation however close the heights; the linear model's is 1/2. Beyond
    the waterline band the fraction does not change, which the share of the way from z_from
    to z_to inside the band accounts for.
    """
    h1 = min(max((surface_z - z_from) * inverse_radius + 1.0, 0.0), 2.0)
    h2 = min(max((surface_z - z_to) * inverse_radius + 1.0, 0.0), 2.0)
    travel = z_to - z_from
    share = (h1 - h2) * radius / (travel if travel != 0.0 else 1.0)
    share = share if travel != 0.0 else 1.0
    if cap:
        return 0.25 * (3.0 * (h1 + h2) - (h1 * h1 + h1 * h2 + h2 * h2)) * inverse_radius * share
    in_band = h1 != h2 or (h1 > 0.0 and h1 < 2.0)
    return 0.5 * inverse_radius * share if in_band else 0.0


@compiled
def waterline_volume_slope(cap, z, radius, volume, surface_z):
    """-dV_sub/dz at z, m^2: the area of the sphere's section at the surface (exact cap), or
    V/(2r) while the linear model's sphere crosses the surface; 0 when it does not."""
    offset = z - surface_z
    if cap:
        reach = radius * radius - offset * offset
        return math.pi * (reach if reach > 0.0 else 0.0)
    return 0.5 * volume / radius if abs(offset) < radius else 0.0
