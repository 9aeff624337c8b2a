"""The soft step's per-contact functions: soft_step.py sweeps them over its contacts,
colour by colour, and the GPU's kernels (physics/cuda/contact_kernels.py) call them one
thread a contact. Each reads and writes one contact's row of facts and the velocities of
its two spheres, nothing else."""
import math

import numba

# A contact apart by at most this fraction of its gap at the step's start (and of its
# approach over a substep) touches: a speculative contact closes its gap to rounding.
_TOUCHING = 1e-9
# Columns of a contact's row: normal (unit, from the second toward the first), the gap
# along it at the step's start (m), the effective mass (kg), the approach at the step's
# start (m/s, negative closing), the accumulated normal impulse (N s), friction impulse
# (3, N s), the most normal impulse any pass gave while touching, mu_s, mu_k, and its
# spring's bias rate (1/s), mass scale and impulse scale (soft_coefficients).
(NX, NY, NZ, GAP, MASS, APPROACH, NORMAL, FX, FY, FZ, MOST, MU_S, MU_K, BIAS_RATE, MASS_SCALE,
 IMPULSE_SCALE) = range(16)
COLUMNS = 16  # two cache lines a contact


@numba.njit(error_model='numpy', inline='always')
def soft_coefficients(stiffness_hz, damping_ratio, h):
    """(bias rate 1/s, mass scale, impulse scale) of an implicit spring-damper of
    stiffness_hz and damping_ratio over a substep of h s (Box2D's b2MakeSoft)."""
    omega = 2.0 * math.pi * stiffness_hz
    a1 = 2.0 * damping_ratio + h * omega
    a2 = h * omega * a1
    a3 = 1.0 / (1.0 + a2)
    return omega / a1, a2 * a3, a3


@numba.njit(error_model='numpy', inline='always')
def solve_contact(rows, s, a, b, velocity, moved, inverse_mass, push_out_speed, use_bias,
                  inverse_h, hold_apart):
    """One contact (rows[s]: its COLUMNS; a, b: its spheres' rows in velocity (rows, 4) m/s
    and moved (rows, 4) m since the step's start; inverse_mass (rows,) 1/kg) solved in
    place: the normal impulse, soft when use_bias and overlapping (its own spring's
    coefficients), speculative when apart (if hold_apart; else an apart contact is left as
    it is), then Coulomb friction on the accumulated impulse. The per-contact function of
    the solver (and of a GPU's)."""
    nx, ny, nz = rows[s, NX], rows[s, NY], rows[s, NZ]
    rx = velocity[a, 0] - velocity[b, 0]
    ry = velocity[a, 1] - velocity[b, 1]
    rz = velocity[a, 2] - velocity[b, 2]
    speed = rx * nx + ry * ny + rz * nz  # > 0 separating
    gap = rows[s, GAP] + ((moved[a, 0] - moved[b, 0]) * nx + (moved[a, 1] - moved[b, 1]) * ny
                       + (moved[a, 2] - moved[b, 2]) * nz)
    # Selects, not branches: whether a contact is apart, or slides, is a coin toss from one
    # contact to the next, and mispredicted branches made the sweeps 1.5x dearer.
    apart = gap > 0.0
    soft = use_bias and not apart
    # Apart: may close its gap in this substep, no more; soft: the spring's push-out.
    bias = gap * inverse_h if apart else (
        max(rows[s, BIAS_RATE] * gap, -push_out_speed) if soft else 0.0)
    mass_scale = rows[s, MASS_SCALE] if soft else 1.0
    impulse_scale = rows[s, IMPULSE_SCALE] if soft else 0.0
    accumulated = rows[s, NORMAL]
    impulse = -rows[s, MASS] * mass_scale * (speed + bias) - impulse_scale * accumulated
    # Touching: within rounding of the gap closed (a speculative contact shuts it exactly).
    touching = gap * inverse_h <= _TOUCHING * (abs(rows[s, GAP]) * inverse_h
                                              + abs(rows[s, APPROACH]))
    free = not touching and not hold_apart
    total = accumulated if free else max(accumulated + impulse, 0.0)
    impulse = total - accumulated
    rows[s, NORMAL] = total
    # Only a push while touching counts toward a bounce (restitute_contact): a bounce off
    # a face never reached threw a sphere up at the 9 m/s it came down with.
    rows[s, MOST] = max(rows[s, MOST], impulse if touching else 0.0)
    wa, wb = inverse_mass[a], inverse_mass[b]
    rx += (wa + wb) * impulse * nx
    ry += (wa + wb) * impulse * ny
    rz += (wa + wb) * impulse * nz
    # Friction: the impulse that would stop the sliding, on the accumulated one; beyond
    # mu_s x the normal impulse it slides (kinetic, along the same line); none at mu_s 0.
    along = rx * nx + ry * ny + rz * nz
    held_x, held_y, held_z = rows[s, FX], rows[s, FY], rows[s, FZ]
    gx = held_x - rows[s, MASS] * (rx - along * nx)
    gy = held_y - rows[s, MASS] * (ry - along * ny)
    gz = held_z - rows[s, MASS] * (rz - along * nz)
    grip = math.sqrt(gx * gx + gy * gy + gz * gz)
    mu_s = rows[s, MU_S]
    scale = (rows[s, MU_K] * total / grip if grip > mu_s * total else 1.0) if mu_s > 0.0 else 0.0
    gx = held_x if free else gx * scale  # a contact left as it is keeps its friction
    gy = held_y if free else gy * scale
    gz = held_z if free else gz * scale
    rows[s, FX], rows[s, FY], rows[s, FZ] = gx, gy, gz
    fx = impulse * nx + (gx - held_x)
    fy = impulse * ny + (gy - held_y)
    fz = impulse * nz + (gz - held_z)
    velocity[a, 0] += wa * fx
    velocity[a, 1] += wa * fy
    velocity[a, 2] += wa * fz
    velocity[b, 0] -= wb * fx
    velocity[b, 1] -= wb * fy
    velocity[b, 2] -= wb * fz


@numba.njit(error_model='numpy', inline='always')
def carry_contact(rows, s, a, b, velocity, inverse_mass):
    """One contact's accumulated impulses (normal and friction, N s) applied to its two
    spheres (see solve_contact for the arguments): a substep's warm start."""
    normal = rows[s, NORMAL]
    wa, wb = inverse_mass[a], inverse_mass[b]
    for axis in range(3):
        impulse = normal * rows[s, NX + axis] + rows[s, FX + axis]
        velocity[a, axis] += wa * impulse
        velocity[b, axis] -= wb * impulse


@numba.njit(error_model='numpy', inline='always')
def may_bounce(rows, s, threshold):
    """Whether contact s approached at the step's start faster than threshold m/s (or by
    no number): restitute_contact's first test, which soft_rows.fill_rows marks ahead."""
    return not rows[s, APPROACH] > -threshold


@numba.njit(error_model='numpy', inline='always')
def restitute_contact(rows, s, a, b, velocity, inverse_mass, threshold, restitution):
    """The restitution pass for one contact (see solve_contact for the arguments): one that
    pushed while touching and approached faster than threshold m/s leaves at restitution x
    that."""
    if not may_bounce(rows, s, threshold) or rows[s, MOST] == 0.0:
        return
    approach = rows[s, APPROACH]
    nx, ny, nz = rows[s, NX], rows[s, NY], rows[s, NZ]
    speed = ((velocity[a, 0] - velocity[b, 0]) * nx + (velocity[a, 1] - velocity[b, 1]) * ny
             + (velocity[a, 2] - velocity[b, 2]) * nz)
    accumulated = rows[s, NORMAL]
    total = max(accumulated - rows[s, MASS] * (speed + restitution * approach), 0.0)
    impulse = total - accumulated
    rows[s, NORMAL] = total
    wa, wb = inverse_mass[a], inverse_mass[b]
    velocity[a, 0] += wa * impulse * nx
    velocity[a, 1] += wa * impulse * ny
    velocity[a, 2] += wa * impulse * nz
    velocity[b, 0] -= wb * impulse * nx
    velocity[b, 1] -= wb * impulse * ny
    velocity[b, 2] -= wb * impulse * nz
