"""DeviceState: one Simulation's spheres on the GPU, and what its host arrays have of them.

The state lives on the GPU between calls. What the host holds is brought home only when
someone reads it (a publish, a service, a recording: Simulation.spheres), into pinned
buffers, so the cost of a step does not depend on how often the node publishes. What the
host writes (a set_mass, forces, a spawn or a reset, all through Simulation's methods) is
marked and goes up before the next step; nothing else does.
"""
import numpy as np

from ..kernels.effects import WAVE_TABLE
from ..kernels.layout import PROPERTIES, SPHERE_ARRAYS
from ..spheres import InvalidInput
from . import blocks_for, load_cuda, THREADS_PER_BLOCK, unavailable
from .kernels import advance_source

STATE = ('position', 'velocity')
ARRAYS = SPHERE_ARRAYS  # every array of the spheres the kernel reads


class DeviceState:
    """The GPU's copy of one simulation's spheres, and its compiled step.

    configuration: (integrator code, Listed (scalar), has_contact, has_friction), as
    Stepper.configuration names them. constants: (environment (12,), pool (6,), contact
    (4,), the soft step's settings (5,)) float64, as the CPU step takes them
    (stepper.scene_constants).
    """

    _kernels = {}  # configuration -> the compiled kernel, shared by every DeviceState

    @classmethod
    def for_scene(cls, scene, submerged_volume='cap'):
        """The DeviceState of a scene's configuration and world (no spheres yet: the first
        run sends them)."""
        from ..effects import effect_flags
        from ..stepper import INTEGRATOR_CODES, scene_constants
        effects = scene['effects']
        configuration = (INTEGRATOR_CODES[scene['integrator']],
                         effect_flags(effects, submerged_volume, scalar=True),
                         'contact' in effects, 'friction' in effects)
        if 'collisions' in effects and scene['contact_solver'] != 'soft_step':
            raise InvalidInput('backend: cuda runs the collisions effect with contact_solver: '
                               f"soft_step only, not {scene['contact_solver']}")
        if 'collisions' in effects and scene['soft_step.colouring'] == 'found':
            raise InvalidInput('backend: cuda colours contacts by priority only '
                               '(soft_step.colouring: auto or priority, not found; '
                               'docs/gpu.md)')
        environment, _, pool, contact, settings = scene_constants(scene)
        return cls(effects, configuration, (environment, pool, contact, settings))

    def __init__(self, effects, configuration, constants):
        reason = unavailable()
        if reason is not None:
            raise InvalidInput(f'backend: cuda cannot run here: {reason}')
        self.cuda = load_cuda()
        kernel = self._kernels.get(configuration)
        if kernel is None:
            kernel = self._kernels[configuration] = self.cuda.jit(
                advance_source(*configuration))
        self.kernel = kernel
        self.colliding = None  # the steps with collisions (device_steps.py), if listed
        if 'collisions' in effects:
            from .device_steps import CollidingSteps
            try:
                self.colliding = CollidingSteps(self.cuda, configuration, constants)
            except ImportError as error:  # CuPy, for the sorts (device_detect.py)
                raise InvalidInput(f'backend: cuda cannot run collisions here: {error}') \
                    from None
        environment, pool, contact, _ = constants
        self._constants = tuple(self.cuda.to_device(np.ascontiguousarray(array))
                                for array in (environment, WAVE_TABLE, pool, contact))
        self._arrays = {}  # name -> its device array
        self._pinned = {}  # name -> a pinned host buffer it comes home through
        self._stale = set(ARRAYS)  # the host's arrays the device does not have yet
        self._host_behind = False  # whether the device's state is newer than the host's
        self._put_back = self.cuda.to_device(np.zeros(1, dtype=np.int64))
        self._failed = None
        self._configured = {}  # count -> the kernel's launch configuration for it

    def memory_home(self, memory):
        """With collisions, the device's contact memory into the host's (the Simulation's
        arrays, as last handed to run)."""
        if self.colliding is not None:
            self.colliding.memory_home(memory)

    def host_changed(self, names=ARRAYS):
        """The host wrote these arrays of the spheres (all by default): they go up before
        the next step. Read them first (bring_home), or what the device has is lost."""
        self._stale.update(names)

    def replace(self):
        """The host's spheres were replaced (a reset, a spawn, a remove): the host's arrays
        are the current ones, and all of them go up before the next step."""
        self._stale.update(ARRAYS)
        self._host_behind = False

    def bring_home(self, spheres):
        """The device's state into spheres' position and velocity, if it is newer. While it
        is not, those two arrays are read-only: a write into one held from before a step
        would be lost (and would send the stale rest of it up), so it fails instead."""
        if not self._host_behind:
            return
        for name in STATE:
            host = getattr(spheres, name)
            host.flags.writeable = True
            if host.size:  # no pinned buffer of no bytes
                pinned = self._pinned[name]
                self._arrays[name].copy_to_host(pinned)
                host[...] = pinned
        self._host_behind = False

    def _upload(self, spheres):
        """Every stale array of spheres to the device."""
        cuda = self.cuda
        for name in sorted(self._stale):
            host = np.ascontiguousarray(getattr(spheres, name), dtype=float)
            device = self._arrays.get(name)
            if device is None or device.shape != host.shape:
                self._arrays[name] = cuda.to_device(host)
                if name in STATE and host.size:
                    self._pinned[name] = cuda.pinned_array(host.shape, dtype=float)
            else:
                device.copy_to_device(host)
        if self._failed is None or self._failed.shape[0] != spheres.count:
            self._failed = cuda.to_device(np.zeros(spheres.count, dtype=np.uint8))
        self._stale.clear()

    def launch(self, count, steps, dt):
        """(a launch configuration of the kernel for count spheres, its arguments): calling
        the one with the others enqueues `steps` steps of dt s. The configuration is made
        once per count (kernel[grid, block] makes one on every call)."""
        configured = self._configured.get(count)
        if configured is None:
            self._configured = {count: self.kernel[blocks_for(count), THREADS_PER_BLOCK]}
            configured = self._configured[count]
        arrays = self._arrays
        environment, wave_table, pool, contact = self._constants
        properties = tuple(arrays[name] for name in PROPERTIES)
        return configured, (arrays['position'], arrays['velocity'], properties, environment,
                            wave_table, pool, contact, self._failed, self._put_back, steps,
                            dt)

    def run(self, spheres, steps, dt, remembered=None):
        """`steps` steps of dt s in one launch (with collisions, a step's passes each);
        spheres: a Spheres, or anything with its arrays (ARRAYS) and count; remembered:
        with collisions, the Simulation's (identity, contact memory). Returns (how many
        times the step guard put a sphere back, the indices of the spheres it put back)."""
        self._upload(spheres)
        count = spheres.count
        put_back = 0
        if count and self.colliding is not None:
            self.colliding.remembered(*remembered)
            arrays = self._arrays
            properties = tuple(arrays[name] for name in PROPERTIES)
            if not steps:  # compiles the kernels, on copies: moves nothing
                self.colliding.warm_up(arrays, properties, self._constants, dt)
            put_back = self.colliding.run(arrays, properties, self._constants, self._failed,
                                          self._put_back, steps, dt)
        elif count:  # none steps too: it compiles the kernel (prepare), moves nothing
            configured, arguments = self.launch(count, steps, dt)
            configured(*arguments)
        if count and steps:
            self._host_behind = True
            for name in STATE:  # stale until brought home (bring_home)
                getattr(spheres, name).flags.writeable = False
        put_back += int(self._put_back.copy_to_host()[0])  # waits for the launch
        if not put_back:
            return 0, np.empty(0, dtype=np.intp)
        indices = np.flatnonzero(self._failed.copy_to_host())
        self._put_back.copy_to_device(np.zeros(1, dtype=np.int64))
        self._failed.copy_to_device(np.zeros(count, dtype=np.uint8))
        return put_back, indices
