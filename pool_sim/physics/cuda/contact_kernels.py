"""The soft step's substeps and restitution pass on the GPU, from the CPU's own per-contact
and per-member functions (contacts/soft_contact.py, contacts/soft_step.py): nothing of the
solver is written twice.

A colour's contacts share no sphere (contacts/colouring.py; the ground, of no inverse mass,
is written only with the value it has), so a colour is one thread a contact with no atomics,
and sweeping the colours in order gives what the CPU's serial sweep gives, to the bit. The
last colour, which takes what the others could not and may share spheres, is swept by one
thread in slot order, as on the CPU. The support sweep, serial bottom up on the CPU, goes
wave by wave (layers.sweep_waves: contacts of a wave touch no sphere another writes).

Two ways to launch the same passes (DeviceSolve's `mode`):
- 'launches': a launch per pass and colour (contacts_kernel, members_kernel, ...): a step
  of c colours and w waves of the support sweep is 4 x (3c + 5 + w) + c launches, each
  tens of µs of numba-cuda's dispatch.
- 'cooperative': one launch a step (substeps_kernel); the grid waits for itself between
  passes (cuda.cg.this_grid().sync()), so the grid is no larger than the device holds at
  once, and each thread strides over contacts and members.
"""
import numba

from ..contacts.soft_contact import carry_contact, restitute_contact, solve_contact
from ..contacts.soft_step import change_member, hold_on_floor, hold_up_contacts, may_land, \
    move_member, speed_squared
from . import load_cuda

# A global, not a local: numba's CUDA simulator swaps each thread's `cuda` into the
# kernel's globals.
cuda = load_cuda()
# What contacts_kernel does to a colour's contacts.
CARRY, SOLVE, RESTITUTE = 0, 1, 2


@numba.njit(error_model='numpy', inline='always')
def colour_share(kind, rows, solve_order, velocity, moved, inverse_mass, bounces, first, last,
                 serial, thread, threads, use_bias, hold_apart, scalars):
    """One thread's share of a colour's contacts, slots first..last - 1 (all of them for
    thread 0 if serial): CARRY (carry_contact), SOLVE (solve_contact) or RESTITUTE
    (restitute_contact, the slots bounces marks). scalars: (push_out_speed m/s, inverse_h
    1/s, threshold m/s, restitution)."""
    start, step = (first, 1) if serial else (first + thread, threads)
    if serial and thread != 0:
        start = last
    push_out_speed, inverse_h, threshold, restitution = scalars
    for s in range(start, last, step):
        a, b = solve_order[s, 0], solve_order[s, 1]
        if kind == CARRY:
            carry_contact(rows, s, a, b, velocity, inverse_mass)
        elif kind == SOLVE:
            solve_contact(rows, s, a, b, velocity, moved, inverse_mass, push_out_speed,
                          use_bias, inverse_h, hold_apart)
        elif bounces[s]:
            restitute_contact(rows, s, a, b, velocity, inverse_mass, threshold, restitution)


@numba.njit(error_model='numpy', inline='always')
def members_share(moving, velocity, change, moved, h, thread, threads):
    """One thread's share of the members: the velocity change (change_member) or, if
    moving, the move over h s (move_member)."""
    for k in range(thread, velocity.shape[0] - 1, threads):
        if moving:
            move_member(moved, velocity, h, k)
        else:
            change_member(velocity, change, k)


@numba.njit(error_model='numpy', inline='always')
def fastest_share(velocity, thread, threads):
    """The largest speed squared, (m/s)^2, of one thread's share of the members."""
    fastest = 0.0
    for k in range(thread, velocity.shape[0] - 1, threads):
        fastest = max(fastest, speed_squared(velocity, k))
    return fastest


@numba.njit(error_model='numpy', inline='always')
def support_share(part, ends, facts, floor_member, floor_gap, velocity, moved, inverse_h,
                  threshold, supported, first, last, thread, threads):
    """One thread's share of a part of the support sweep (soft_step.hold_up): 0, supported
    cleared; 1, what the floor holds (hold_on_floor); 2, a wave's contacts, first..last - 1
    of ends and facts in layers.sweep_waves' order (hold_up_contacts)."""
    if part == 0:
        for k in range(thread, supported.size, threads):
            supported[k] = False
    elif part == 1:
        hold_on_floor(floor_member, floor_gap, thread, floor_member.size, threads, velocity,
                      moved, threshold, supported)
    else:
        hold_up_contacts(ends, facts, first + thread, last, threads, velocity, moved,
                         inverse_h, threshold, supported)


def contacts_kernel(kind, rows, solve_order, velocity, moved, inverse_mass, bounces, first,
                    last, serial, use_bias, hold_apart, scalars):
    """colour_share over a launch's threads (one launch a pass and colour)."""
    colour_share(kind, rows, solve_order, velocity, moved, inverse_mass, bounces, first, last,
                 serial, cuda.grid(1), cuda.gridsize(1), use_bias, hold_apart, scalars)


def members_kernel(moving, velocity, change, moved, h):
    """members_share over a launch's threads."""
    members_share(moving, velocity, change, moved, h, cuda.grid(1), cuda.gridsize(1))


def fastest_kernel(velocity, fastest, substep):
    """fastest[substep] = the members' largest speed squared (a maximum: the same in any
    order, so an atomic one is reproducible)."""
    cuda.atomic.max(fastest, substep, fastest_share(velocity, cuda.grid(1), cuda.gridsize(1)))


def support_kernel(part, ends, facts, floor_member, floor_gap, velocity, moved, inverse_h,
                   threshold, supported, fastest, substep, first, last):
    """support_share over a launch's threads, if may_land (fastest[substep])."""
    if may_land(fastest[substep], threshold):
        support_share(part, ends, facts, floor_member, floor_gap, velocity, moved, inverse_h,
                      threshold, supported, first, last, cuda.grid(1), cuda.gridsize(1))


def substeps_kernel(rows, solve_order, velocity, moved, change, inverse_mass, bounces,
                    colour_bounds, serial_colour, ends, facts, wave_bounds, floor_member,
                    floor_gap, supported, fastest, substeps, h, scalars):
    """A step's substeps and its restitution pass in one cooperative launch, in
    soft_step._substeps' order: the grid syncs between passes (and colours).
    colour_bounds (colours + 1,) int64: the slots where each non-empty colour begins;
    serial_colour: the index of the one swept by one thread (-1: none); ends, facts: the
    support sweep's, wave by wave, wave_bounds where each wave begins (layers.sweep_waves);
    fastest (substeps,) zeros; scalars as colour_share takes them."""
    grid = cuda.cg.this_grid()
    thread, threads = cuda.grid(1), cuda.gridsize(1)
    colours = colour_bounds.size - 1
    inverse_h, threshold = scalars[1], scalars[2]
    # Each substep sweeps the colours three times (the carried impulses, the solve, the
    # relax); after the last, once more (the restitution pass). Before the first sweep, the
    # velocity change; before the relax, the support sweep and the move.
    for substep in range(substeps + 1):
        final = substep == substeps
        for sweep in range(1 if final else 3):
            if not final and sweep == 0:
                members_share(False, velocity, change, moved, h, thread, threads)
                grid.sync()
            if not final and sweep == 2:
                cuda.atomic.max(fastest, substep, fastest_share(velocity, thread, threads))
                grid.sync()
                if may_land(fastest[substep], threshold):  # the same for every thread
                    for part in range(wave_bounds.size + 1):  # clear, the floor, each wave
                        wave = max(part - 2, 0)
                        first, last = ((wave_bounds[wave], wave_bounds[wave + 1]) if part >= 2
                                       else (0, 0))
                        support_share(min(part, 2), ends, facts, floor_member, floor_gap,
                                      velocity, moved, inverse_h, threshold, supported, first,
                                      last, thread, threads)
                        grid.sync()
                members_share(True, velocity, change, moved, h, thread, threads)
                grid.sync()
            kind = RESTITUTE if final else (CARRY if sweep == 0 else SOLVE)
            # The relax (sweep 2) has no bias; after the last move it leaves apart contacts.
            use_bias, hold_apart = sweep < 2, sweep < 2 or substep < substeps - 1
            for c in range(colours):
                colour_share(kind, rows, solve_order, velocity, moved, inverse_mass, bounces,
                             colour_bounds[c], colour_bounds[c + 1], c == serial_colour,
                             thread, threads, use_bias, hold_apart, scalars)
                grid.sync()


KERNELS = (contacts_kernel, members_kernel, fastest_kernel, support_kernel, substeps_kernel)
