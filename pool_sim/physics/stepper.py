"""The step: a scene's integrator, effects and contacts composed into one compiled loop.

For each configuration (integrator, the effects listed, the submerged-volume model, and
whether the loop runs in parallel) numba compiles one function that takes many steps per
call. Inside, every effect, integrator and contact function is inlined and the scene's
choices are compile-time constants, so what the scene does not list is not in the loop at
all. Each step is two passes over the spheres (three with collisions):

1. the smooth step, sphere by sphere: from parallel_from_spheres() spheres up a numba
   parallel loop (prange), which pays for itself even on one thread: numba proves a parallel
   loop's arrays do not alias and tells LLVM so, which then computes four spheres at once
   (packed square roots and divisions) where a plain loop stays scalar. It marks each
   sphere on or past a face or not finite in a byte stored for every sphere, and counts
   them in an integer reduction (a conditional store would stop the vectorising).
   With wave_radiation and the default integrator, the parallel build leaves the waves
   out of this pass where few spheres cross the surface (fewer than one in
   DENSE_BAND_SHARE): their table look-ups, vectorised, cost every sphere, though only
   those crossing the surface feel them. It marks the crossing spheres too, and a pass over
   them alone takes their step again with the waves. Away from the surface the two steps
   are the same to the bit, so the result does not depend on which way a step went;
2. contacts and the step guard for the spheres the first pass marked (on or past a face,
   or not finite), a plain loop with branches: a sphere the step left non-finite (or whose
   bounce would not fit a double) goes back to where that step began, at rest, and is
   flagged. A step reads one pair of state arrays and writes the other, so the step's
   start is still there for them without a copy of every sphere;
3. with `collisions` listed, sphere-sphere contact over all spheres (contacts/), which
   needs both the step's start and its end. A solver that resolves its spheres' faces
   itself (contacts.SOLVES_FACES: soft_step) runs before the second pass, from the smooth
   step's own end, and clears its spheres' marks.

Compiled functions are cached on disk (numba's cache, beside this file or in the user's
cache directory when that is not writable), each configuration under a name that carries it
and a digest of the physics sources, so an edit to any of them compiles afresh.
"""
import dataclasses
import hashlib
import math
import pathlib
import threading
import types

import numba
import numpy as np

from .contacts import DEFAULT_SOLVER, SOLVERS, SOLVES_FACES
from .contacts.colouring import by_priority
from .effects import effect_flags
from .schema import SOLVER_SETTINGS
from .integrators import INTEGRATORS
from .kernels import compiled
from .kernels.effects import heave_radiation, inertia, near_surface, WAVE_TABLE, \
    water_fraction, water_taken_on
from .kernels.faces import resolve_contacts
from .kernels.integrators import explicit_euler, linearly_implicit_euler, rk4, \
    semi_implicit_euler, velocity_verlet
from .kernels.layout import Body, body_of, Env, env_of, properties_of
from .kernels.step_guard import finite, put_back as put_back_sphere
from .kernels.wave_band import BAND_MARK, DENSE_BAND_SHARE, band_scratch, crossing_count, \
    gather_band, scatter_band

INTEGRATOR_CODES = {name: code for code, name in enumerate(INTEGRATORS)}
# The codes run_steps dispatches on, by name (its globals: constants when it compiles).
INTEGRATORS_BY_CODE = list(INTEGRATORS)
_EXPLICIT_EULER, _SEMI_IMPLICIT_EULER = (INTEGRATOR_CODES['explicit_euler'],
                                         INTEGRATOR_CODES['semi_implicit_euler'])
_VELOCITY_VERLET, _RK4 = INTEGRATOR_CODES['velocity_verlet'], INTEGRATOR_CODES['rk4']
_LINEARLY_IMPLICIT_EULER = INTEGRATOR_CODES['linearly_implicit_euler']
# The first pass's marks in flagged: on or past a face or not finite (the second pass's),
# crossing the water's surface (the wave-band pass's).
_FACE_MARK = 1  # BAND_MARK: kernels/wave_band.py

# Every file the compiled loop is made of, found by pattern so that no new one is missed:
# an edit to any of them compiles the loop afresh.
_SOURCE_PATTERNS = ('stepper.py', 'kernels/**/*.py', 'contacts/**/*.py')
_SOURCES = sorted({path for pattern in _SOURCE_PATTERNS
                   for path in pathlib.Path(__file__).parent.glob(pattern)})
SOURCE_DIGEST = hashlib.sha256(b''.join(path.read_bytes() for path in _SOURCES)).hexdigest()[:16]
# The contact solver run_steps calls: each configuration's copy has its own (_compose).
_solve_collisions = SOLVERS[DEFAULT_SOLVER]

# Below this many spheres launching the parallel loop costs more than vectorising saves.
# A launch costs ~5 us with the OpenMP or TBB threading layer and ~100 us with numba's own
# workqueue, the one left where neither library is installed (measured, one thread: at
# 1 000 spheres 21 against 55 us a step with OpenMP, 107 against 58 us with workqueue; at
# 10 000, 299 against 433 us with workqueue).
PARALLEL_FROM_SPHERES = {'omp': 64, 'tbb': 64, 'workqueue': 4096}
_threading_layer = None  # numba knows it only after a parallel launch: set after our first
# numba's default threading layer (workqueue) aborts the process when two threads launch
# parallel loops at once: simulations stepped from several threads take turns.
_parallel_launch = threading.Lock()


def use_threads(count):
    """Threads the parallel loop may use when the calling thread steps (numba's setting,
    per thread; numba's default is one per core)."""
    numba.set_num_threads(count)


def parallel_from_spheres():
    """How many spheres make the parallel build worth launching, for numba's threading
    layer (taken to be OpenMP's until our first launch shows which it is)."""
    return PARALLEL_FROM_SPHERES.get(_threading_layer or 'omp',
                                     PARALLEL_FROM_SPHERES['workqueue'])


@compiled
def _integrate(integrator_code, listed, env, body, start, start_velocity, dt):
    """One smooth step of one sphere by the integrator of integrator_code (a constant where
    it is inlined, so the other branches fold away): (x, y, z, vx, vy, vz)."""
    if integrator_code == _EXPLICIT_EULER:
        return explicit_euler(listed, env, body, start, start_velocity, dt)
    if integrator_code == _SEMI_IMPLICIT_EULER:
        return semi_implicit_euler(listed, env, body, start, start_velocity, dt)
    if integrator_code == _VELOCITY_VERLET:
        return velocity_verlet(listed, env, body, start, start_velocity, dt)
    if integrator_code == _RK4:
        return rk4(listed, env, body, start, start_velocity, dt)
    return linearly_implicit_euler(listed, env, body, start, start_velocity, dt)


@compiled
def _face_mark(has_contact, faces, r, s):
    """_FACE_MARK for a sphere of radius r (m) that ends the smooth step s on or past a face
    (with has_contact) or not finite (a NaN position is inside no face either), else 0."""
    low_x, low_y, low_z, high_x, high_y, high_z = faces
    # & rather than `and`: no branch for the vectoriser to undo.
    inside = ((low_x + r < s[0]) & (s[0] < high_x - r) & (low_y + r < s[1])
              & (s[1] < high_y - r) & (low_z + r < s[2]) & (s[2] < high_z - r)
              if has_contact else True)
    return 0 if finite(s) & inside else _FACE_MARK


@compiled
def _smooth_step(integrator_code, listed, band_pass, environment, wave_table, properties, i,
                 old_position, old_velocity, new_position, new_velocity, has_contact, faces,
                 dt):
    """The first pass for sphere i: its smooth step from the old state arrays (3, n) to the
    new ones; returns its face mark (_face_mark) and, with band_pass, whether it crosses the
    surface where it starts, where it is headed or where it ends (1 or 0)."""
    # Made here, not captured: numba's parallel loop cannot take a namedtuple in.
    env = env_of(environment, wave_table)
    body = body_of(properties, i)
    start = (old_position[0, i], old_position[1, i], old_position[2, i])
    start_velocity = (old_velocity[0, i], old_velocity[1, i], old_velocity[2, i])
    s = _integrate(integrator_code, listed, env, body, start, start_velocity, dt)
    new_position[0, i], new_position[1, i], new_position[2, i] = s[0], s[1], s[2]
    new_velocity[0, i], new_velocity[1, i], new_velocity[2, i] = s[3], s[4], s[5]
    crossing = (band_pass and (near_surface(env, body, start[2]) | near_surface(env, body, s[2])
                               | near_surface(env, body, start[2] + dt * start_velocity[2])))
    return _face_mark(has_contact, faces, body.radius, s), 1 if crossing else 0


@compiled
def sphere_faces(listed, has_contact, has_friction, env, faces, contact_parameters, body, old,
                 state, dt):
    """One sphere's contacts with the pool's faces (with has_contact) after its smooth step
    from old to state (x, y, z, vx, vy, vz): (the state, whether the step guard must put it
    back: the step or its bounce left it non-finite). The second pass's and the GPU's."""
    overflow = not finite(state)
    s = state
    if has_contact and not overflow:
        s, overflow = resolve_contacts(faces, contact_parameters, has_friction, body.radius,
                                       old, state, dt)
        if listed.wave_radiation and not overflow:
            # Moved by the contact to where it may carry more water.
            added = heave_radiation(listed, env, body, state[2])[0]
            inertia_z = inertia(listed, env, body, water_fraction(
                listed, env, body, state[2])) + added
            s = (s[0], s[1], s[2], s[3], s[4],
                 water_taken_on(listed, env, body, inertia_z, added, s[2], s[5]))
    return s, overflow


@compiled
def _faces_and_guard(listed, has_contact, has_friction, env, faces, contact_parameters,
                     properties, old_position, old_velocity, new_position, new_velocity,
                     flagged, marked, failed, dt):
    """The second pass (see the module's docstring) over the spheres flagged (n,) marks
    (marked of them: none, no pass): sphere_faces, then the step guard. properties: the
    spheres' arrays (layout.properties_of). Returns how many spheres the guard put back
    (flagged in failed (n,))."""
    put_back = 0
    for i in range(flagged.shape[0] if marked else 0):
        if flagged[i] == 0:
            continue
        old = (old_position[0, i], old_position[1, i], old_position[2, i],
               old_velocity[0, i], old_velocity[1, i], old_velocity[2, i])
        state = (new_position[0, i], new_position[1, i], new_position[2, i],
                 new_velocity[0, i], new_velocity[1, i], new_velocity[2, i])
        s, overflow = sphere_faces(listed, has_contact, has_friction, env, faces,
                                   contact_parameters, body_of(properties, i), old, state, dt)
        if overflow:
            put_back_sphere(new_position, new_velocity, old_position, failed, i)
            put_back += 1
        else:
            new_position[0, i], new_position[1, i], new_position[2, i] = s[0], s[1], s[2]
            new_velocity[0, i], new_velocity[1, i], new_velocity[2, i] = s[3], s[4], s[5]
    return put_back


def _band_pass(integrator_code, listed):
    """Whether run_steps leaves wave radiation to a pass over the spheres crossing the
    surface (the module's docstring), and the effects its first pass computes.

    The plain loop skips the table look-ups per sphere by a branch; a vectorised one would
    pay for them for every sphere. Only for the default integrator, which looks the table up
    at the step's start, where it is headed and its end, all three checked for the marks:
    the others look it up at stages in between."""
    band_pass = (listed.wave_radiation and not listed.scalar
                 and integrator_code == _LINEARLY_IMPLICIT_EULER)
    return band_pass, listed._replace(wave_radiation=False) if band_pass else listed


def _compose(integrator_code, listed, has_contact, has_friction, has_collisions,
             contact_solver, parallel, source_digest):
    """The compiled step loop of one configuration (see the module's docstring).

    Every argument is a compile-time constant of the function made here (a closure
    variable: numba folds each branch on it away). source_digest, with the configuration,
    names the function, which is what numba's cache tells functions apart by."""
    each_sphere = numba.prange if parallel else range
    solver_first = has_collisions and contact_solver in SOLVES_FACES
    band_pass, smooth = _band_pass(integrator_code, listed)

    def run_steps(position, velocity, mass, radius, volume, cross_section, drag_coefficient,
                  lift_coefficient, lift_area, lift_normal, external_force, lift_slope,
                  stall_angle, environment, wave_table, pool, contact, solver_settings, spare_position,
                  spare_velocity, flagged, failed, collision_reals, collision_wholes,
                  identity, memory_keys, memory_forces, memory_held, steps, dt):
        """Take `steps` steps of dt s in place; returns how many times the step guard put a
        sphere back (flagged in failed (n,), which must be zero on entry).

        Each step reads one pair of state arrays and writes the other (position and
        velocity, spare_position and spare_velocity, in turn), so the start of the step is
        still there for the few spheres that need it: those the smooth pass marks in
        flagged (n,) uint8, on or past a face or non-finite. The result ends in position
        and velocity. collision_reals, collision_wholes: the collision pass's scratch
        (contacts.workspace; empty without collisions)."""
        world = env_of(environment, wave_table)  # the parallel loop makes its own (see there)
        properties = (mass, radius, volume, cross_section, drag_coefficient, lift_coefficient,
                      lift_area, lift_normal, external_force, lift_slope, stall_angle)
        faces = (pool[0], pool[1], pool[2], pool[3], pool[4], pool[5])
        contact_parameters = (contact[0], contact[1], contact[2], contact[3])
        gx, gy, gz = world.gravity_x, world.gravity_y, world.gravity_z
        # A rebound slower than gravity adds in one step is resting contact.
        resting_speed = math.sqrt(gx * gx + gy * gy + gz * gz) * dt if listed.gravity else 0.0
        floor_supports = listed.gravity and gz < 0.0  # piles rest on the floor (contacts/)
        gravity_step = (gx * dt, gy * dt, gz * dt) if listed.gravity else (0.0, 0.0, 0.0)
        count = position.shape[1]
        scratch = band_scratch(count if band_pass else 0, properties)  # the crossing spheres'
        # The first step's choice, from where the spheres are now.
        dense = (band_pass and crossing_count(world, properties, position) * DENSE_BAND_SHARE
                 > count)
        put_back = 0
        for step in range(steps):
            if step % 2 == 0:
                old_position, old_velocity = position, velocity
                new_position, new_velocity = spare_position, spare_velocity
            else:
                old_position, old_velocity = spare_position, spare_velocity
                new_position, new_velocity = position, velocity
            # Marks stored and counted in reductions (a conditional store stops vectorising).
            marked = near = 0
            if not (band_pass and dense):  # without the waves, when band_pass
                for i in each_sphere(count):
                    face, crossing = _smooth_step(
                        integrator_code, smooth, band_pass, environment, wave_table,
                        properties, i, old_position, old_velocity, new_position, new_velocity,
                        has_contact, faces, dt)
                    flagged[i] = face | crossing * BAND_MARK
                    marked += face
                    near += crossing
            if band_pass:  # the step with the waves: every sphere, or the crossing ones
                if dense:
                    again = count
                    band_properties, start, end = properties, old_position, new_position
                    start_velocity, end_velocity, marks = old_velocity, new_velocity, flagged
                else:
                    again = gather_band(flagged, properties, old_position, old_velocity,
                                        scratch) if near > 0 else 0
                    band_properties, start, end = scratch[1], scratch[2], scratch[4]
                    start_velocity, end_velocity, marks = scratch[3], scratch[5], scratch[6]
                faced = crossed = 0
                for k in each_sphere(again):  # the spheres whose step is taken again
                    face, crossing = _smooth_step(
                        integrator_code, listed, True, environment, wave_table,
                        band_properties, k, start, start_velocity, end, end_velocity,
                        has_contact, faces, dt)
                    marks[k] = face
                    faced += face
                    crossed += crossing
                if not dense:
                    scatter_band(scratch, again, new_position, new_velocity, flagged)
                marked, near = marked + faced, crossed if dense else near
                dense = near * DENSE_BAND_SHARE > count  # the next step's choice
            # Stage 1, faces and the guard; a solver of its spheres' faces before it (stage
            # 0), any other after (stage 2).
            for stage in range(3):
                if stage == 1:
                    put_back += _faces_and_guard(
                        listed, has_contact, has_friction, world, faces, contact_parameters,
                        properties, old_position, old_velocity, new_position,
                        new_velocity, flagged, marked, failed, dt)
                elif has_collisions and (stage == 0) == solver_first:
                    put_back += _solve_collisions(
                        old_position, old_velocity, new_position, new_velocity, mass, radius,
                        faces, has_contact, contact_parameters, has_friction, resting_speed,
                        gravity_step, floor_supports, failed, collision_reals,
                        collision_wholes, dt, flagged, identity, memory_keys, memory_forces,
                        memory_held, solver_settings)
        if steps % 2 == 1:  # the last step wrote the spare pair
            for i in range(count):
                for axis in range(3):
                    position[axis, i] = spare_position[axis, i]
                    velocity[axis, i] = spare_velocity[axis, i]
        return put_back

    # numba's cache keys on the function's name, its own file and its closure: the name
    # carries the configuration and the digest of every physics source, so each
    # configuration has a cache index of its own (no two processes saving different ones
    # into one index) and an edit to any source compiles afresh.
    # The solver is a global of this configuration's own copy (numba's cache cannot key a
    # compiled function held in a closure: it pickles one differently in every process).
    flags = ''.join('1' if flag else '0'
                    for flag in (*listed, has_contact, has_friction, has_collisions))
    name = (f'run_steps_{INTEGRATORS_BY_CODE[integrator_code]}_{flags}_{contact_solver}_'
            f'{"parallel" if parallel else "plain"}_{source_digest}')
    configured = types.FunctionType(
        run_steps.__code__, {**globals(), '_solve_collisions': SOLVERS[contact_solver]}, name,
        None, run_steps.__closure__)
    configured.__qualname__ = name
    return numba.njit(cache=True, nogil=True, error_model='numpy', parallel=parallel)(
        configured)


class Stepper:
    """The compiled step of one scene configuration.

    integrator: a name of INTEGRATORS.  effects: the scene's effects list.
    submerged_volume: 'cap' or 'linear'.  contact_solver: a name of contacts.SOLVERS, the
    solver of the `collisions` effect. Builds are compiled (or loaded from the cache) on
    first use: the plain one for few spheres, the parallel one for many.
    """

    _builds = {}  # configuration -> compiled function, shared by every Stepper
    _builds_lock = threading.Lock()

    def __init__(self, integrator, effects, submerged_volume='cap',
                 contact_solver=DEFAULT_SOLVER):
        if contact_solver not in SOLVERS:
            raise ValueError(f'contact_solver: one of {sorted(SOLVERS)}, got {contact_solver!r}')
        self.configuration = (INTEGRATOR_CODES[integrator],
                              effect_flags(effects, submerged_volume),
                              'contact' in effects, 'friction' in effects,
                              'collisions' in effects, contact_solver)
        self._listed = {parallel: effect_flags(effects, submerged_volume, scalar=not parallel)
                        for parallel in (False, True)}  # the parallel loop is the vectorised
        self._mine = [None, None]  # this Stepper's plain and parallel build, once looked up

    def build(self, parallel):
        """The compiled function for this configuration, plain or parallel."""
        (integrator_code, _, has_contact, has_friction, has_collisions,
         contact_solver) = self.configuration
        parallel = bool(parallel)
        key = (integrator_code, self._listed[parallel], has_contact, has_friction,
               has_collisions, contact_solver, parallel)
        with self._builds_lock:
            function = self._builds.get(key)
            if function is None:
                function = self._builds[key] = _compose(*key, SOURCE_DIGEST)
        return function

    def run(self, arrays, scratch, steps, dt):
        """`steps` steps of dt s on arrays (the kernel's leading arguments, as
        Simulation packs them) with scratch = (spare_position, spare_velocity, flagged,
        failed, collision_reals, collision_wholes, identity, memory_keys, memory_forces,
        memory_held).

        Returns how many times the guard put a sphere back."""
        global _threading_layer
        parallel = arrays[0].shape[1] >= parallel_from_spheres()
        function = self._mine[parallel] or self.build(parallel)
        self._mine[parallel] = function
        if parallel:
            with _parallel_launch:
                put_back = function(*arrays, *scratch, steps, dt)
                _threading_layer = _threading_layer or numba.threading_layer()
            return put_back
        return function(*arrays, *scratch, steps, dt)


def environment_array(env):
    """The world as run_steps takes it: (12,) float64, in Env's order (kernels/layout.py)."""
    return np.array([*env.gravity, env.air.density, *env.air.flow_velocity,
                     env.water.density, *env.water.flow_velocity, env.surface_z], dtype=float)


def scene_constants(scene):
    """What run_steps takes of a scene's world, after the spheres' arrays: (environment
    (12,), the wave table, pool (6,) m: corner_min then corner_max, contact (4,):
    ContactParameters' fields, the soft_step solver's settings (5,): SOLVER_SETTINGS, then
    1 if it colours by priority, else 0), float64."""
    environment = scene.environment()
    pool = environment.pool
    priority = by_priority(scene['soft_step.colouring'], scene['backend'])
    return (environment_array(environment), WAVE_TABLE,
            np.concatenate([pool.corner_min, pool.corner_max]).astype(float),
            np.array(dataclasses.astuple(scene.contact_parameters()), dtype=float),
            np.array([*(scene[key] for key in SOLVER_SETTINGS), float(priority)]))


def environment_tuple(env):
    """The world as the compiled per-sphere functions take it, an Env."""
    return Env(*environment_array(env).tolist(), WAVE_TABLE)


def body_tuple(spheres, index):
    """Sphere `index` of spheres (a Spheres) as the compiled per-sphere functions take it,
    a Body, packed by the loop's own body_of."""
    pack = getattr(body_of, 'py_func', body_of)  # numba's, or plain under NUMBA_DISABLE_JIT
    return Body(*(float(field) for field in pack(properties_of(spheres), index)))
