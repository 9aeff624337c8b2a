"""The pool_sim node: the physics core on a clock of its own, its state on topics, forces
and changes in.

The node is wiring: it builds the scene from its parameters, the simulation, and one helper
per job, each handed the node (as rclpy's own ParameterService and TimeSource are):
- clock.py: steps paced against wall time on a thread of its own, pause, the lockstep wait,
  advance by one publish period, the status line;
- publishing.py: the state topics, odometry, /clock, and listeners on each instant;
- parameter_changes.py: one parameter request, one transaction (plan, check once, apply);
- world_services.py: set_mass, set_radius, reset, pause, step;
- inputs.py: the wrench topics, applied through the core's setters, and the wrench clock;
- diagnostics.py: warnings about unstable steps and spheres the step guard put back;
- recorder.py: every instant and input into an MCAP file, when `record` names one;
- foxglove_view.py: the live view in Foxglove, with foxglove_port >= 0.

One node, two threads: the clock thread steps and publishes; the executor that spins the
node (rclpy.spin, a user's, a test's) runs only the inputs and services. One lock keeps them
apart (lock()): a service, a parameter change or a spawn happens between ticks. Without a
clock thread (run_clock=False, as pool_sim.testing runs it) whoever drives the node calls
advance() itself; with `lockstep` on, each period once ready() says the instant published
last is answered (lockstep.py).
"""
import sys
import threading

from rclpy.node import Node

from pool_sim.physics import InvalidInput, Scene, Simulation, stepper
from pool_sim.physics.params_file import read_params_document
from pool_sim.physics.spheres import named_few
from pool_sim.ros.clock import SimulationClock
from pool_sim.ros.diagnostics import Diagnostics
from pool_sim.ros.executables import process_age_s, run_node
from pool_sim.ros.foxglove_view import FoxgloveView
from pool_sim.ros.inputs import ForceInputs
from pool_sim.ros.lockstep import Lockstep
from pool_sim.ros.parameter_changes import ParameterChanges
from pool_sim.ros.parameters import declare_scene, is_ros_own, overrides_of, params_files, \
    scene_from_overrides
from pool_sim.ros.publishing import StatePublishing
from pool_sim.ros.recorder import Recorder
from pool_sim.ros.services import guard_services
from pool_sim.ros.world_services import WorldServices


class PoolSimNode(Node):
    """node_kwargs go to rclpy's Node (context, parameter_overrides, namespace, ...).

    run_clock: False makes no clock thread; then time goes on only by advance().
    scene: the running scene (its spheres change with a spawn or remove); simulation: the
    physics core, to read or change only while holding lock().
    """

    def __init__(self, node_name='pool_sim', default_scene=None, run_clock=True,
                 **node_kwargs):
        # Undeclared names reach our checks (which refuse them) instead of rclpy's
        # exception: a spawn request carries the new spheres' keys, not declared yet.
        super().__init__(node_name, allow_undeclared_parameters=True, **node_kwargs)
        self._lock = threading.RLock()
        self.clock = self.recorder = self.live_view = None
        try:
            self._build(default_scene or Scene.default(), run_clock)
        except BaseException:
            # Refused, or stopped by a signal half-way: nothing of it may outlive it.
            self.destroy_node()
            raise

    def _build(self, default_scene, run_clock):
        self.scene = scene_from_overrides(overrides_of(self), default_scene)
        # The scene holds them now, as arrays; rclpy's copy (a Python float per number,
        # 32 bytes each) would stay for the node's life. rclpy's own keep theirs.
        self._parameter_overrides = {name: parameter for name, parameter
                                     in self._parameter_overrides.items() if is_ros_own(name)}
        scene = self.scene
        self.per_sphere = scene['per_sphere_topics']
        declare_scene(self, scene, self.per_sphere)
        self.simulation = Simulation(scene)
        self.lockstep = Lockstep(self.get_logger())
        self.diagnostics = Diagnostics(self)
        self.inputs = ForceInputs(self, scene.sphere_names, self.per_sphere,
                                  on_answer=self._on_answer)
        self.publishing = StatePublishing(self, self.lockstep, self.inputs)
        self.clock = SimulationClock(self, self.publishing, self.inputs, self.lockstep,
                                     self.diagnostics, run_clock)
        # Before the scene markers go out, so the live view hears them too.
        if scene['foxglove_port'] >= 0:
            self.live_view = FoxgloveView.for_node(self)
        self.parameter_changes = ParameterChanges(self, self.clock, self.publishing,
                                                  self.inputs, self.lockstep, self.diagnostics)
        self.world_services = WorldServices(self, self.clock, self.parameter_changes,
                                            self.publishing, self.inputs, self.lockstep)
        guard_services(self, around_set_parameters=self.parameter_changes.spawn_together)
        # Listening before the first instant goes out: the recording starts with it.
        self.recorder = Recorder.for_node(self) if scene['record'] else None
        compiling_s = self.simulation.prepare()
        self.publishing.publish_scene_markers()
        self.publishing.publish_state()
        age = process_age_s()
        if age is not None:
            self.get_logger().info(f'first state published; this process started '
                                   f'{age:.2f} s ago (the physics step took '
                                   f'{compiling_s:.2f} s to compile or load from the cache)')
        self.diagnostics.warn_if_unstable()
        self.get_logger().info(
            f'{len(scene.sphere_names)} spheres ({named_few(scene.sphere_names)}); '
            f'{scene["integrator"]} at {scene["physics_rate_hz"]:g} Hz, publishing at '
            f'{scene["publish_rate_hz"]:g} Hz of simulated time, real_time_factor '
            f'{scene["real_time_factor"]:g}; effects: {", ".join(scene["effects"]) or "none"}; '
            f'per-sphere topics {"on" if self.per_sphere else "off"}')
        # Load the compiled kernel on a throwaway copy now, and start the clock after it and
        # after the set-up above: neither is the node falling behind.
        stepper.use_threads(1)
        Simulation(scene, initial_spheres=self.simulation.spheres.copy()).step()
        self.clock.start()

    def destroy_node(self):
        if self.clock is not None:
            self.clock.stop()
        if self.recorder is not None:
            self.recorder.close()  # after the clock: nothing more comes
        if self.live_view is not None:
            self.live_view.close()
        publishing = getattr(self, 'publishing', None)
        if publishing is not None:
            publishing.destroy()
        return super().destroy_node()

    def _on_answer(self):
        self.clock.on_answer()

    # -- the verbs for those who drive the node ----------------------------------------------

    def lock(self):
        """The node's lock, as a context manager (`with node.lock(): ...`): held by every
        tick of the clock and by every service and parameter change; hold it to look at or
        change the simulation from another thread."""
        return self._lock

    @property
    def runs_clock(self) -> bool:
        """True while the node's own clock thread paces time (then advance() is not for
        you)."""
        return self.clock is not None and self.clock.thread is not None

    def advance(self) -> bool:
        """Step to the next publish instant and publish it (with /clock), whether paused or
        not and without waiting for lockstep answers; inputs that came are applied first.
        False when simulated time cannot go on (the end of ROS stamps)."""
        return self.clock.advance()

    def ready(self) -> bool:
        """True when the instant published last is answered by every lockstep input (or
        timed out, or lockstep is off): then advance() may go on."""
        return self.clock.ready()

    def wait_left_s(self) -> float:
        """Wall seconds until the instant awaited times out (0 when nothing is awaited)."""
        return self.lockstep.wall_left()

    def republish_state(self):
        """Publish the present instant's state again (for subscribers that joined since)."""
        with self._lock:
            self.publishing.publish_state(new_listeners=True)

    def set_external_force(self, sphere, force):
        """Push a sphere (N, world axes) as an input message does: checked (InvalidInput if
        refused), holding until replaced or until wrench_timeout."""
        with self._lock:
            self.inputs.set_force(self.simulation, sphere, force)

    def time_report(self) -> str:
        """Where the wall time went since start (the status line's second half)."""
        return self.clock.time_report()


def main(args=None):
    """`ros2 run pool_sim pool_sim [--ros-args ...]`: exit code 1, and one line naming the
    key or the file, for a bad params file or argument; 0 on SIGINT or SIGTERM."""
    return run_node('pool_sim', PoolSimNode, InvalidInput, args, check_params_files)


def check_params_files(argv):
    """Each --params-file can be read as a mapping (rcl takes `42` as a file of nothing)."""
    for path in params_files(argv):
        read_params_document(path)


if __name__ == '__main__':
    sys.exit(main())
