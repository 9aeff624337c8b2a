"""A running simulation: a scene's spheres stepped by its integrator, contacts resolved.

This is what the node, the tests and the benchmarks drive. Every setter validates before it
writes, so a refused input leaves the state exactly as it was.
"""
import math
import time

import numpy as np

from .contacts import contact_memory, SOLVES_FACES, workspace as collision_workspace
from .contacts.memory import carried_memory
from .kernels.effects import heave_added_masses
from .kernels.layout import properties_of, SPHERE_ARRAYS
from .media import cap_volume_integral, linear_volume_integral
from .schema import GLOBAL_KEYS
from .spheres import InvalidInput, shown
from .stability import stable_step_bound
from .stepper import environment_array, scene_constants, Stepper

VOLUME_INTEGRALS = {'cap': cap_volume_integral, 'linear': linear_volume_integral}


class Simulation:
    """scene: a Scene.  submerged_volume: 'cap' (exact) or 'linear' (the seed's, to compare).
    initial_spheres: Spheres to start from instead of the scene's; reset returns here.

    time: simulated seconds since the start or the last reset.
    max_step: the configured step, s (1 / physics_rate_hz); no step is ever longer.
    recoveries: times the step guard has put a sphere back since construction (reset keeps
    it).

    The step guard is the last line of defence: a sphere a step would leave non-finite (or,
    with contact, outside the pool) goes back to where that step began, at rest.
    take_recovered() says which, likely_cause(index) why.

    change_spheres spawns, removes and reorders spheres while it runs.
    """

    def __init__(self, scene, submerged_volume='cap', initial_spheres=None):
        self.scene = scene
        self.initial_spheres = initial_spheres
        self.environment = scene.environment()
        self.contact_parameters = scene.contact_parameters()
        if submerged_volume not in VOLUME_INTEGRALS:
            raise InvalidInput("submerged_volume: 'cap' or 'linear', got "
                               f'{shown(submerged_volume)}')
        self.submerged_volume = submerged_volume
        self.stepper = Stepper(scene['integrator'], scene['effects'], submerged_volume,
                               scene['contact_solver'])
        self.max_step = 1.0 / scene['physics_rate_hz']
        self.recoveries = 0
        self._recovered = set()  # indices put back, until taken
        self._failed_step = {}  # index -> the last step (s) it was put back in
        # The spare state, marks, failure flags and the collision pass's scratch, kept
        # between calls.
        self._scratch = None
        self._constants = scene_constants(scene)
        # What the contact solver remembers between steps (contacts/memory.py), and each
        # sphere's identity it is keyed by: unique over the run, kept by a sphere that
        # change_spheres carries over, never handed to another.
        self._remembers = ('collisions' in scene['effects']
                           and scene['contact_solver'] in SOLVES_FACES)
        self._memory = None
        self._device = self._device_state(scene, submerged_volume)
        self.reset()

    def _device_state(self, scene, submerged_volume):
        """The GPU's copy of the spheres with `backend: cuda` (cuda/device.py), else None."""
        if scene['backend'] != 'cuda':
            return None
        from .cuda.device import DeviceState  # numba-cuda: an optional extra
        return DeviceState.for_scene(scene, submerged_volume)

    @property
    def spheres(self):
        """The spheres (a Spheres). With `backend: cuda` their state is brought home from
        the GPU when read (read it afresh after a step: position and velocity held from
        before it are read-only until then); write them through this class's methods, or
        say what was written with mark_written."""
        if self._device is not None:
            self._device.bring_home(self._spheres)
        return self._spheres

    @spheres.setter
    def spheres(self, spheres):
        self._spheres = spheres
        if self._device is not None:
            self._device.replace()

    def reset(self):
        """Back to the scene's initial state; time restarts at 0."""
        self.spheres = (self.scene.build_spheres() if self.initial_spheres is None
                        else self.initial_spheres.copy())
        self.time = 0.0
        self._memory = None  # a reset forgets every contact
        self._identities, self._next_identity = {}, 0
        self._identify()

    def _identify(self):
        """Each sphere's identity (int64, in sphere order): its old one if it has one, else
        the next never used."""
        identities = self._identities
        for name in self.spheres.names:
            if name not in identities:
                identities[name] = self._next_identity
                self._next_identity += 1
        self._identity = np.array([identities[name] for name in self.spheres.names],
                                  dtype=np.int64)

    def step(self, dt=None):
        """One step of dt seconds (default: max_step)."""
        self.run(1, self.max_step if dt is None else dt)

    def run(self, steps, dt):
        """`steps` steps of dt seconds each, in one compiled call."""
        if (type(steps) is not int and (isinstance(steps, bool) or not isinstance(
                steps, (int, np.integer)))) or steps < 0:  # the type first: then a number
            raise InvalidInput(f'steps: a whole number >= 0, got {shown(steps)}')
        dt = float(dt)
        if not 0.0 < dt < math.inf:  # NaN is not either
            raise InvalidInput(f'dt: must be finite and > 0, got {shown(dt)}')
        if self._device is not None:
            remembered = None
            if self._remembers:
                self._memory = self._contact_memory(self._spheres.count)
                remembered = (self._identity, self._memory)
            put_back, indices = self._device.run(self._spheres, int(steps), dt, remembered)
            if put_back:
                self._count_recovered(indices, dt, put_back)
            self.time += steps * dt
            return
        spheres = self.spheres
        if self._scratch is None or self._scratch[0].shape != spheres.position.shape:
            self._scratch = (np.empty_like(spheres.position), np.empty_like(spheres.velocity),
                             np.zeros(spheres.count, dtype=np.uint8),
                             np.zeros(spheres.count, dtype=np.uint8),
                             *collision_workspace(spheres.count if 'collisions' in
                                                  self.scene['effects'] else 0))
        self._memory = self._contact_memory(spheres.count if self._remembers else 0)
        arrays = (spheres.position, spheres.velocity, *properties_of(spheres),
                  *self._constants)
        put_back = self.stepper.run(arrays, (*self._scratch, self._identity, *self._memory),
                                    int(steps), dt)
        if put_back:
            failed = self._scratch[3]
            indices = np.flatnonzero(failed)
            failed[indices] = 0
            self._count_recovered(indices, dt, put_back)
        self.time += steps * dt

    def _contact_memory(self, count):
        """The contact memory for count spheres: the one kept, or a new one, empty."""
        if self._memory is None or self._memory[0].shape[0] != count:
            return contact_memory(count)
        return self._memory

    def prepare(self):
        """Compile the step this many spheres take (or load it from numba's cache) without
        stepping; returns the wall seconds that took (next to none once done)."""
        started = time.perf_counter()
        self.run(0, self.max_step)
        return time.perf_counter() - started

    def _count_recovered(self, indices, dt, put_back):
        """indices: the spheres put back in a call; put_back: how many times (a sphere may
        be put back in several of its steps)."""
        for index in indices.tolist():
            self._recovered.add(index)
            self._failed_step[index] = dt
        self.recoveries += put_back

    def take_recovered(self):
        """Indices of the spheres the step guard put back since the last call, ascending."""
        indices = sorted(self._recovered)
        self._recovered.clear()
        return indices

    def likely_cause(self, index):
        """A short phrase for why the step guard put sphere `index` back."""
        integrator = self.scene['integrator']
        step = self._failed_step.get(index, self.max_step)
        bound = stable_step_bound(self.scene, integrator, self.spheres, [index])
        if step > bound:
            below = f'stable below {bound:.3g} s' if bound > 0.0 else 'no step is stable'
            return (f'{integrator} is unstable at {step:.3g} s for this sphere ({below}); '
                    'use linearly_implicit_euler or a higher physics_rate_hz')
        return ('forces beyond what float arithmetic can hold: check mass, radius and '
                'external force')

    def advance(self, duration):
        """Advance `duration` s in equal steps, none longer than max_step."""
        duration = float(duration)
        if not math.isfinite(duration) or duration < 0.0:
            raise InvalidInput(f'duration: must be finite and >= 0, got {duration!r}')
        steps = math.ceil(duration / self.max_step - 1e-9)
        if steps:
            self.run(steps, duration / steps)

    def check_change(self, name, key, value):
        """A live change of sphere `name`: key 'mass' (kg), 'radius' (m) or 'lift_area'
        (m^2), checked once; apply_change writes it. InvalidInput if refused."""
        return self.spheres.check_change(name, key, value, self.environment.pool)

    def apply_change(self, change):
        """Write a change check_change accepted; its index is the sphere's in the spheres
        now (after a spawn or remove, give it the sphere's new index)."""
        self.spheres.apply_change(change, self.environment.pool)
        self.mark_written()  # a radius moves the sphere inside the pool: every array

    def set_mass(self, name, mass_kg):
        self.apply_change(self.check_change(name, 'mass', mass_kg))

    def set_radius(self, name, radius_m):
        self.apply_change(self.check_change(name, 'radius', radius_m))

    def set_lift_area(self, name, area_m2):
        self.apply_change(self.check_change(name, 'lift_area', area_m2))

    def set_external_force(self, name, force_n):
        self._spheres.set_external_force(name, force_n)  # the state need not come home
        self.mark_written('external_force')

    def set_external_forces(self, forces_n):
        """(n, 3) N, every sphere at once, in sphere order; checked, InvalidInput if not."""
        self._spheres.set_external_forces(forces_n)
        self.mark_written('external_force')

    def release_external_forces(self, which):
        """No external force on the spheres `which` selects (a bool mask or indices)."""
        self._spheres.release_external_forces(which)
        self.mark_written('external_force')

    def mark_written(self, *names):
        """Say that these arrays of `spheres` (their names on Spheres; all when none is
        named) were written directly, not through this class's setters: with `backend:
        cuda` they go up to the GPU before the next step (on the CPU this does nothing)."""
        unknown = [name for name in names if name not in SPHERE_ARRAYS]
        if unknown:
            raise InvalidInput(f'mark_written: the spheres have no array {shown(unknown[0])}; '
                               f'they have {", ".join(SPHERE_ARRAYS)}')
        if self._device is not None:
            self.spheres  # a step's state first: the rest of an array goes up beside it
            self._device.host_changed(*((names,) if names else ()))

    def change_spheres(self, scene):
        """Go on with the spheres of `scene` (a Scene whose global keys are this one's): it
        may add, remove and reorder them.

        A sphere in both keeps its whole state (position, velocity, mass, radius, lift
        area, external force, ...); a new one starts at the scene's initial values with no
        external force; time goes on. reset() then returns to the new scene at time 0.
        """
        if self._device is not None and self._memory is not None:
            self._device.memory_home(self._memory)  # carried below
        for key in GLOBAL_KEYS:  # the physics' own: a runner's keys are its own business
            value = scene[key]
            if key != 'sphere_names' and value != self.scene[key]:
                raise InvalidInput(f'{key}: change_spheres changes the spheres only; the new '
                                   f'scene has {shown(value)}, the running one '
                                   f'{shown(self.scene[key])}')
        spheres = scene.build_spheres()
        spheres.carry_over(self.spheres)
        # Pending put-backs follow their spheres to the new indices; removed ones are gone.
        old_names, new_index = self.spheres.names, spheres.index
        self._recovered = {new_index[old_names[i]] for i in self._recovered
                           if old_names[i] in new_index}
        self._failed_step = {new_index[old_names[i]]: step
                             for i, step in self._failed_step.items()
                             if old_names[i] in new_index}
        self.scene, self.initial_spheres, self.spheres = scene, None, spheres
        # Identities of spheres removed are retired (a later sphere of that name is another).
        self._identities = {name: self._identities[name] for name in old_names
                            if name in new_index}
        old_identity = self._identity
        self._identify()
        # Each kept sphere's remembered contacts move with it to its new index.
        if self._memory is not None and self._memory[0].shape[0] == old_identity.size:
            self._memory = carried_memory(self._memory, old_identity, self._identity)

    def sphere_state(self, name):
        """(position (3,), velocity (3,)) copies for one sphere, m and m/s."""
        i = self.spheres.lookup(name)
        return self.spheres.position[:, i].copy(), self.spheres.velocity[:, i].copy()

    def mechanical_energy(self):
        """(n,) J: kinetic + gravitational + buoyancy potential, for vertical gravity, and
        with wave_radiation the kinetic energy 1/2 A33 vz^2 of the water a sphere carries
        as it heaves at the surface.

        The buoyancy potential U_b(z) has -dU_b/dz = the buoyant force, built from the
        integral of the submerged volume. added_mass's 1/2 rho V_sub is not counted.
        """
        effects = self.scene['effects']
        return mechanical_energy(self.environment, self.spheres, 'buoyancy' in effects,
                                 'gravity' in effects, self.submerged_volume,
                                 'wave_radiation' in effects)


def mechanical_energy(env, spheres, with_buoyancy=True, with_gravity=True,
                      submerged_volume='cap', with_wave_radiation=False):
    """(n,) J of each sphere; see Simulation.mechanical_energy.

    submerged_volume: 'cap' or 'linear', the model whose buoyancy the potential integrates.
    """
    kinetic = 0.5 * spheres.mass * np.einsum('ij,ij->j', spheres.velocity, spheres.velocity)
    energy = kinetic
    if with_wave_radiation:
        carried = heave_added_masses(environment_array(env), properties_of(spheres),
                                     np.ascontiguousarray(spheres.position[2]))
        energy = energy + 0.5 * carried * spheres.velocity[2]**2
    if with_gravity:
        energy = energy - spheres.mass * (env.gravity @ spheres.position)
    if with_buoyancy:
        z = spheres.position[2]
        energy = energy + env.gravity[2] * (
            env.air.density * spheres.volume * z
            - (env.water.density - env.air.density)
            * VOLUME_INTEGRALS[submerged_volume](z, spheres.radius, env.surface_z))
    return energy

