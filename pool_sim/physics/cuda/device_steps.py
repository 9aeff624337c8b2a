"""CollidingSteps: steps with the collisions effect on the GPU, for DeviceState. A step is
run_steps' three passes (physics/stepper.py), each on the device: the smooth step
(kernels.smooth_source, each sphere's face mark), the soft step's collision pass
(DeviceCollisions), then the faces and the step guard of the spheres still marked
(kernels.faces_source). What comes back to the host each step is small: the sizes the
collision pass allocates by (its pairs, members, faces, contacts), a count each round of
the colouring and the waves, and the guard's count; the spheres' state stays.

The contact memory and the spheres' identities live on the device too: sent when the
Simulation hands over new ones (a reset, a spawn or a remove), brought home when it needs
them (memory_home).
"""
import numpy as np

from . import grid_for
from .device_collisions import DeviceCollisions, pass_constants
from .kernels import faces_source, smooth_source


class CollidingSteps:
    """The colliding step of one configuration (integrator code, Listed, has_contact,
    has_friction) and world (environment (12,), pool (6,), contact (4,), settings (5,):
    scene_constants')."""

    _kernels = {}  # configuration -> (smooth, faces) compiled, shared by every instance

    def __init__(self, cuda, configuration, constants):
        integrator_code, listed, has_contact, has_friction = configuration
        kernels = self._kernels.get(configuration)
        if kernels is None:
            kernels = self._kernels[configuration] = (
                cuda.jit(smooth_source(integrator_code, listed, has_contact)),
                cuda.jit(faces_source(listed, has_contact, has_friction)))
        self.cuda, self.smooth, self.faces = cuda, *kernels
        self._world = (constants, (has_contact, has_friction, listed.gravity))
        self.collisions = DeviceCollisions()
        self._sent = (None, None)  # the host's identity and memory last sent
        self._identity = self._memory = None
        self._spare = None  # the other pair of state arrays and the face marks

    def remembered(self, identity, memory):
        """The Simulation's identities (n,) and contact memory (contact_memory's), sent
        before the next step if they are not the ones last sent."""
        if identity is not self._sent[0]:
            self._identity = self.cuda.to_device(identity)
        if memory is not self._sent[1]:
            self._memory = tuple(self.cuda.to_device(array) for array in memory)
        self._sent = (identity, memory)

    def memory_home(self, memory):
        """The device's contact memory into the host's arrays (memory, the ones sent)."""
        if self._memory is not None and memory is self._sent[1]:
            for host, device in zip(memory, self._memory):
                device.copy_to_host(host)

    def warm_up(self, arrays, properties, constants, dt):
        """Compiles every kernel a step of dt s from the spheres' state reaches, by taking
        that step on copies (Simulation.prepare: the node's first step does not stall on
        numba-cuda's compiler); nothing the spheres or the memory hold changes."""
        cuda = self.cuda

        def copy(array):
            made = cuda.device_array_like(array)
            made.copy_to_device(array)
            return made
        kept = self._memory
        self._memory = tuple(copy(array) for array in kept)
        count = arrays['position'].shape[1]
        try:
            self.run({**arrays, 'position': copy(arrays['position']),
                      'velocity': copy(arrays['velocity'])}, properties, constants,
                     cuda.to_device(np.zeros(count, dtype=np.uint8)),
                     cuda.to_device(np.zeros(1, dtype=np.int64)), 1, dt)
        finally:
            self._memory = kept

    def run(self, arrays, properties, constants, failed, put_back, steps, dt):
        """`steps` steps of dt s on DeviceState's arrays (position and velocity are
        swapped with the spare pair each step: arrays names the current ones after);
        properties, constants (environment, wave_table, pool, contact) as the kernels take
        them; failed (n,) uint8 and put_back (1,) int64, the faces' pass's guard. Returns how
        many spheres the collision pass's guard put back."""
        count = arrays['position'].shape[1]
        if self._spare is None or self._spare[0].shape[1] != count:
            self._spare = (self.cuda.device_array((3, count)),
                           self.cuda.device_array((3, count)),
                           self.cuda.device_array(count, dtype=np.uint8))
        environment, wave_table, pool, contact = constants
        world = pass_constants(*self._world[0], self._world[1], dt)
        grid = grid_for(count)
        put_back_by_pass = 0
        for _ in range(steps):
            old = (arrays['position'], arrays['velocity'])
            new = self._spare[:2]
            flagged = self._spare[2]
            self.smooth[grid](*old, *new, properties, environment, wave_table, pool, flagged,
                              dt)
            put_back_by_pass += self.collisions.resolve(
                (*old, *new), (arrays['mass'], arrays['radius']), self._identity,
                self._memory, flagged, failed, world)
            self.faces[grid](*old, *new, properties, environment, wave_table, pool, contact,
                             flagged, failed, put_back, dt)
            arrays['position'], arrays['velocity'] = new
            self._spare = (*old, flagged)
        return put_back_by_pass
