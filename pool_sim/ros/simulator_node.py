"""The pool_sim node: the physics core on a clock of its own, its state on topics, forces
and changes in.

Simulation time is the only clock that counts: physics steps are a fixed dt, publishing and
wrench timeouts are in simulated seconds, and wall time only sets how fast that time runs
(real_time_factor). A machine that cannot keep up drops the backlog beyond a bound and the
simulation runs slower, instead of spiralling.

One node, two threads. The clock thread steps and publishes; the executor that spins the
node (rclpy.spin, a user's, a test's) runs only the inputs and services. rclpy's executor
walks every subscription of a node each time it wakes (about 16 us each: 16 ms at 1 000
per-sphere wrench topics), so a clock on the executor's timer paid that on every tick; on
its own thread it pays nothing, and the executor wakes only when something arrives. One
lock keeps the two apart: a service, a parameter change or a spawn happens between ticks.

With `lockstep` on, the clock steps one publish period at a time, each once the inputs in
`lockstep_inputs` have answered the instant before (lockstep.py). Without a clock thread
(run_clock=False, as pool_sim.testing runs it) whoever drives the node calls
advance_period() itself.
"""
from functools import partial
import math
import sys
import threading
import time

import numpy as np
from geometry_msgs.msg import PoseArray
from nav_msgs.msg import Odometry
from rcl_interfaces.msg import SetParametersResult
from rcl_interfaces.srv import SetParameters
from rclpy.event_handler import PublisherEventCallbacks
from rclpy.node import Node
from rclpy.parameter import Parameter, parameter_value_to_python
from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy
from rosgraph_msgs.msg import Clock as ClockMessage
from std_msgs.msg import Float64MultiArray
from std_srvs.srv import SetBool, Trigger
from visualization_msgs.msg import MarkerArray

from pool_sim.physics import InvalidInput, Scene, Simulation, stepper
from pool_sim.physics.scene import check_some_sphere_names, read_params_document, SPHERE_KEYS
from pool_sim.physics.spheres import named_few, NAMES_SHOWN, RADIUS_RANGE_M
from pool_sim.physics.stability import stable_at, stable_step_bound
from pool_sim.ros.executables import process_age_s, run_node
from pool_sim.ros.inputs import expired_forces, ForceInputs
from pool_sim.ros.lockstep import Lockstep
from pool_sim.ros.messages import (LAST_STAMP_S, scene_markers, SphereMessages,
                                   stamp_nanoseconds, stamp_of)
from pool_sim.ros.parameters import (ARRAY_PREFIX, array_parameter, as_declared_types,
                                     declare_scene, describe, is_read_only, is_ros_own,
                                     doubles, LIVE_SPHERE_KEYS, LOCKSTEP_KEYS, overrides_of,
                                     params_files, plain,
                                     retable, scene_from_overrides, sphere_parameters)
from pool_sim.ros.services import (guard_services, KNOWN_PARAMETER_TYPES, THROTTLE_S,
                                   unknown_type_reason, unknown_type_refusal)

# Wall time one tick may spend stepping, in every mode, so services stay responsive.
TICK_BUDGET_S = 0.02
# Wall seconds between ticks: never longer, so a slow publish rate or a small
# real_time_factor does not owe more than the catch-up bound at once; never shorter, so a
# huge real_time_factor does not spin for nothing.
TICK_PERIOD_RANGE_S = (0.001, 0.05)
# Requests a service queues before DDS drops one: many clients at once must all be answered.
SERVICE_QOS = QoSProfile(depth=1000, reliability=ReliabilityPolicy.RELIABLE)
# The state topics keep their last message for subscribers that join later (a new RViz,
# `ros2 topic echo --once` while paused); while paused it is also sent again this often
# (wall s), for subscribers that ask for volatile durability.
STATE_QOS = QoSProfile(depth=1, durability=DurabilityPolicy.TRANSIENT_LOCAL,
                       reliability=ReliabilityPolicy.RELIABLE)
PAUSED_REPUBLISH_S = 1.0
# Per-sphere odometry goes out in chunks on its own thread, taking at most this share of
# the wall time (see OdometrySender).
ODOMETRY_CHUNK = 100
ODOMETRY_SHARE = 0.4
# Wall time the node may fall behind and still catch up (then it drops the backlog).
MAX_BACKLOG_WALL_S = 0.1
# Wall seconds between the status lines in the log.
STATUS_PERIOD_S = 5.0


class PoolSimNode(Node):
    """node_kwargs go to rclpy's Node (context, parameter_overrides, namespace, ...).

    lock: held by every tick of the clock thread and by every service and parameter
    change; take it to look at or change the simulation from another thread.
    run_clock: False makes no clock thread; then time goes on only by advance_period().
    """

    def __init__(self, node_name='pool_sim', default_scene=None, run_clock=True,
                 **node_kwargs):
        # Undeclared names reach our checks (which refuse them) instead of rclpy's
        # exception: a spawn request carries the new spheres' keys, not declared yet.
        super().__init__(node_name, allow_undeclared_parameters=True, **node_kwargs)
        self.lock = threading.RLock()
        self._one_thread = set()  # threads that step with one numba thread
        self.clock_thread = None
        self.run_clock = run_clock
        try:
            self._build(default_scene or Scene.default())
        except BaseException:
            # Refused, or stopped by a signal half-way: nothing of it may outlive it.
            self.destroy_node()
            raise

    def _build(self, default_scene):
        self.scene = scene_from_overrides(overrides_of(self), default_scene)
        # The scene holds them now, as arrays; rclpy's copy (a Python float per number,
        # 32 bytes each) would stay for the node's life. rclpy's own keep theirs.
        self._parameter_overrides = {name: parameter for name, parameter
                                     in self._parameter_overrides.items() if is_ros_own(name)}
        scene, names = self.scene, self.scene.sphere_names
        self.per_sphere = scene['per_sphere_topics']
        declare_scene(self, scene, self.per_sphere)
        self.simulation = Simulation(scene)

        self.real_time_factor = scene['real_time_factor']
        self.publish_period = 1.0 / scene['publish_rate_hz']
        self.wrench_timeout = scene['wrench_timeout']
        self.paused = False
        self._reset_timing()

        self.messages = SphereMessages(names, scene['frame_id'], odometry=self.per_sphere)
        self.pose_publisher = self.create_publisher(PoseArray, '~/poses', STATE_QOS)
        self.marker_publisher = self.create_publisher(MarkerArray, '~/markers', STATE_QOS)
        self.state_publisher = self.create_publisher(Float64MultiArray, '~/states', STATE_QOS)
        self.scene_marker_publisher = self.create_publisher(MarkerArray, '~/scene_markers',
                                                            STATE_QOS)
        self.odometry_publishers = {}
        self._add_odometry(names)
        self.odometry_sender = OdometrySender(self.get_logger())
        self.clock_publisher = (self.create_publisher(ClockMessage, '/clock', 10)
                                if scene['publish_clock'] else None)
        self.lockstep = Lockstep(self.get_logger())
        self.inputs = ForceInputs(self, names, self.per_sphere, on_answer=self._on_answer)
        self._configure_lockstep()
        self.create_service(SetParameters, '~/set_mass', partial(self._on_set_sphere, 'mass'),
                            qos_profile=SERVICE_QOS)
        self.create_service(SetParameters, '~/set_radius',
                            partial(self._on_set_sphere, 'radius'), qos_profile=SERVICE_QOS)
        self.create_service(Trigger, '~/reset', self._on_reset, qos_profile=SERVICE_QOS)
        self.create_service(SetBool, '~/pause', self._on_pause, qos_profile=SERVICE_QOS)
        self.create_service(Trigger, '~/step', self._on_step, qos_profile=SERVICE_QOS)
        self.add_pre_set_parameters_callback(self._complete_parameters)
        self.add_on_set_parameters_callback(self._check_parameters)
        self.add_post_set_parameters_callback(self._apply_parameters)
        self._planned = None  # what the last accepted parameter request changes
        self._following_lift_areas = set()  # names the pre-set callback added to a request
        guard_services(self, around_set_parameters=self._spawn_together)

        # Wall seconds spent in each part, for the status line and the benchmarks.
        self.time_spent = {'physics': 0.0, 'build': 0.0, 'publish': 0.0}
        self.next_listener_check, self.odometry_wanted = 0.0, []
        # Counted across resets (which restart simulation time): what the node has done.
        self.publishes, self.steps_taken, self.simulated_s = 0, 0, 0.0
        self.step_cost_s = None  # wall s per physics step, as the last call took
        # Simulated seconds the catch-up bound let go when the node fell behind.
        self.given_up_s = 0.0
        # True once simulated time reached the last second a ROS stamp holds (then paused).
        self.stamp_limit_reached = False
        self.next_recovery_log_wall = 0.0
        self.started_wall = time.monotonic()  # both set again once set-up is done
        self.next_status_wall = self.started_wall + STATUS_PERIOD_S
        self.paused_wall_s, self.paused_since = 0.0, None
        compiling_s = self.simulation.prepare()
        self._publish_scene_markers()
        self._publish_state()
        age = process_age_s()
        if age is not None:
            self.get_logger().info(f'first state published; this process started '
                                   f'{age:.2f} s ago (the physics step took '
                                   f'{compiling_s:.2f} s to compile or load from the cache)')
        tick_period = (max(self.simulation.max_step, self.publish_period)
                       / self.real_time_factor if self.real_time_factor > 0 else 0.0)
        self.tick_period = min(max(tick_period, TICK_PERIOD_RANGE_S[0]),
                               TICK_PERIOD_RANGE_S[1])
        self._warn_if_unstable()
        self.get_logger().info(
            f'{len(names)} spheres ({named_few(names)}); {scene["integrator"]} at '
            f'{scene["physics_rate_hz"]:g} Hz, publishing at {scene["publish_rate_hz"]:g} Hz '
            f'of simulated time, real_time_factor {self.real_time_factor:g}; effects: '
            f'{", ".join(scene["effects"]) or "none"}; per-sphere topics '
            f'{"on" if self.per_sphere else "off"}')
        # Load the compiled kernel on a throwaway copy now, and start the clock after it and
        # after the set-up above: neither is the node falling behind.
        stepper.use_threads(1)
        Simulation(scene, initial_spheres=self.simulation.spheres.copy()).step()
        self.last_wall = self.started_wall = time.monotonic()
        self.next_status_wall = self.started_wall + STATUS_PERIOD_S
        self.next_paused_publish = 0.0
        self.clock_stop, self.clock_wake = threading.Event(), threading.Event()
        if self.run_clock:
            self.clock_thread = threading.Thread(target=self._run_clock,
                                                 name='pool_sim_clock', daemon=True)
            self.clock_thread.start()

    def _add_odometry(self, names):
        if not self.per_sphere:
            return
        no_default_events = PublisherEventCallbacks(use_default_callbacks=False)
        for name in names:
            # Transient-local as the other state topics: a controller that starts after
            # the node still gets the instant lockstep waits for it to answer.
            self.odometry_publishers[name] = self.create_publisher(
                Odometry, f'~/{name}/odom', STATE_QOS, event_callbacks=no_default_events)

    def _warn_if_unstable(self, indices=None):
        """Warn when the integrator is unstable at the configured rate for the scene's
        stiffest sphere (at start-up) or for the spheres `indices` just changed."""
        if indices is not None and stable_at(self.scene, self.simulation.max_step,
                                             spheres=self.simulation.spheres, indices=indices):
            return  # one look at the step map; the bound (a bisection) only for the warning
        if indices is None:
            bound, what = stable_step_bound(self.scene), 'this scene: its stiffest sphere'
        else:
            bound = stable_step_bound(self.scene, spheres=self.simulation.spheres,
                                      indices=indices)
            names = named_few([self.simulation.spheres.names[i] for i in indices])
            what = f'{names} as changed: it'
        if self.simulation.max_step > bound:
            self.get_logger().warning(
                f'{self.scene["integrator"]} is unstable at {self.scene["physics_rate_hz"]:g} Hz '
                f'for {what} needs a step under {bound * 1e3:.3g} ms '
                f'({1.0 / bound if bound > 0 else math.inf:.4g} Hz or more); '
                'linearly_implicit_euler is stable at any rate')

    # -- the clock thread --------------------------------------------------------------------

    def _run_clock(self):
        # The physics loop on one thread, this one (numba's thread count is per calling
        # thread: set here, not where the node was built): the machine's other cores serve
        # DDS, the executor and the subscribers.
        stepper.use_threads(1)
        while not self.clock_stop.is_set():
            behind = False
            try:
                with self.lock:
                    behind = self._on_tick()
            except Exception as error:  # a fault must not stop the clock: say it, go on
                if not self.context.ok():
                    return
                self.get_logger().error(f'a tick raised {type(error).__name__}: {error}',
                                        throttle_duration_sec=THROTTLE_S)
            # Behind, the next tick comes once services have had the lock, not a whole
            # period later: waiting the period after a full budget left the node idle
            # for most of the wall time it had no time to spare (RTF 0.21 at 10 000
            # colliding spheres, physics a third of the wall time).
            self.clock_wake.wait(TICK_PERIOD_RANGE_S[0] if behind else self.tick_period)
            self.clock_wake.clear()

    def destroy_node(self):
        if self.clock_thread is not None:
            self.clock_stop.set()
            self.clock_wake.set()
            self.clock_thread.join(timeout=5.0)
        sender = getattr(self, 'odometry_sender', None)
        if sender is not None:
            sender.stop()
        return super().destroy_node()

    # -- time --------------------------------------------------------------------------------

    def _reset_timing(self):
        self.next_publish_time = self.publish_period  # time 0 is published as it starts
        self.backlog_s = 0.0
        self.last_wall = time.monotonic()
        self.wrench_time = np.full(len(self.scene.sphere_names), -math.inf)

    def _on_tick(self) -> bool:
        """Steps owed since the last tick, within TICK_BUDGET_S. Returns whether steps are
        still owed when the budget ran out (the node is behind real_time_factor)."""
        now = time.monotonic()
        elapsed, self.last_wall = now - self.last_wall, now
        if self.paused:
            self.inputs.apply(self.simulation, self.wrench_time)
            if now >= self.next_paused_publish:  # for subscribers that joined meanwhile
                self.next_paused_publish = now + PAUSED_REPUBLISH_S
                self._publish_state()
            return False
        # Looked at before the inputs are applied: every answer that made it ready is.
        answered = self.lockstep_ready()
        self.inputs.apply(self.simulation, self.wrench_time)
        if not answered:
            return False  # waiting is not falling behind: nothing owed for it
        dt = self.simulation.max_step
        steps_before = self.steps_taken
        deadline = now + TICK_BUDGET_S
        if self.real_time_factor > 0:
            limit = max(2.0 * dt, MAX_BACKLOG_WALL_S * self.real_time_factor)
            owed = self.backlog_s + elapsed * self.real_time_factor
            self.backlog_s = min(owed, limit)
            self.given_up_s += owed - self.backlog_s
            # Bounded by the budget too: a real_time_factor the machine cannot reach leaves
            # the rest owed (then given up at the bound), never a tick that blocks services.
            # In lockstep a publish ends the tick's steps (_step is False then).
            going_on = True
            while self.backlog_s >= dt * (1.0 - 1e-9) and time.monotonic() < deadline:
                owed_steps = max(int(self.backlog_s / dt * (1.0 + 1e-9)), 1)
                going_on, taken = self._steps(owed_steps, deadline)
                self.backlog_s -= taken * dt
                if not going_on:
                    break
            behind = going_on and self.backlog_s >= dt * (1.0 - 1e-9)
        else:
            behind = False  # as fast as it can: every tick is
            while time.monotonic() < deadline and self._steps(None, deadline)[0]:
                pass
        if self.steps_taken > steps_before:
            self._publish_clock()
        self._report_recovered()
        return behind

    def _publish_clock(self):
        if self.clock_publisher is not None:
            self.clock_publisher.publish(ClockMessage(clock=stamp_of(self.simulation.time)))

    def advance_period(self) -> bool:
        """Step to the next publish instant and publish it (with /clock), whether paused or
        not and without waiting for lockstep answers; inputs that came are applied first.
        False when simulated time cannot go on (the end of ROS stamps)."""
        with self.lock:
            self.inputs.apply(self.simulation, self.wrench_time)
            publishes = self.publishes
            while self.publishes == publishes:
                if not self._steps(None, None)[0] and self.publishes == publishes:
                    return False  # the end of ROS stamps
            self._publish_clock()
            self._report_recovered()
            return True

    def lockstep_ready(self) -> bool:
        """True when the instant published last is answered by every lockstep input (or
        timed out, or lockstep is off): then advance_period() may go on. While it waits,
        the instant's state goes out again now and then, for controllers that came late."""
        with self.lock:
            if self.lockstep.ready(self.inputs):
                return True
            if (self.lockstep.republish_due()
                    and not self.inputs.any_unstamped(self.lockstep.waiting)):
                self.republish_state()
            return False

    def republish_state(self):
        """Publish the present instant's state again (for subscribers that joined since)."""
        with self.lock:
            self.next_listener_check = 0.0  # and to odometry listeners that are new
            self._publish_state()

    def set_external_force(self, sphere, force):
        """Push a sphere (N, world axes) as an input message does: checked (InvalidInput if
        refused), holding until replaced or until wrench_timeout."""
        with self.lock:
            index = self.simulation.spheres.lookup(sphere)
            self.simulation.set_external_force(sphere, force)
            self.wrench_time[index] = self.simulation.time

    def _on_answer(self):
        """On the executor's thread, after each input: in lockstep, go on at once."""
        if self.lockstep.awaited_ns is None or self.clock_thread is None:
            return
        if self.real_time_factor > 0 or self.paused:
            self.clock_wake.set()  # pacing is the clock thread's
            return
        # As fast as possible: the answer that completes the instant runs the next period
        # right here, sparing the hand-over to the clock thread (half a millisecond of a
        # period's two). Bounded as every tick is (TICK_BUDGET_S); the clock thread still
        # keeps the timeouts. A fault is said and the input goes on, as on the clock.
        with self.lock:
            if threading.get_ident() not in self._one_thread:
                stepper.use_threads(1)  # per calling thread, as on the clock thread
                self._one_thread.add(threading.get_ident())
            try:
                self._on_tick()
            except Exception as error:
                self.get_logger().error(f'a tick raised {type(error).__name__}: {error}',
                                        throttle_duration_sec=THROTTLE_S)

    def _configure_lockstep(self):
        scene = self.scene
        self.lockstep.configure(scene['lockstep'], scene['lockstep_inputs'],
                                scene['lockstep_timeout'])
        self.inputs.warn_future = scene['lockstep']

    def _steps(self, limit, deadline):
        """Physics steps in one compiled call, up to the next publish (and that publish),
        at most `limit` (None: no limit) and as many as fit before the wall-clock
        `deadline` (monotonic s; None: no deadline) at the cost measured so far.

        Returns (going_on, steps taken): going_on is False when time cannot go on, or when
        it published an instant lockstep now waits on."""
        sim = self.simulation
        dt = sim.max_step
        if sim.time + dt > LAST_STAMP_S:
            # builtin_interfaces/Time counts seconds in an int32: 68 years of simulated time.
            self._set_paused(True)
            self.stamp_limit_reached = True
            self.get_logger().error(
                f'simulated time reached {sim.time:.0f} s, the last a ROS time stamp can '
                'carry (2^31 s): paused; ~/reset starts again from 0')
            return False, 0
        expired_forces(sim, self.wrench_time, self.wrench_timeout)
        steps = max(math.ceil((self.next_publish_time - 1e-9 - sim.time) / dt), 1)
        steps = max(min(steps, int((LAST_STAMP_S - sim.time) / dt)), 1)
        if limit is not None:
            steps = min(steps, limit)
        if self.wrench_timeout > 0.0 and self.wrench_time.size:  # none past the first expiry
            expiry = float(np.min(self.wrench_time)) + self.wrench_timeout
            if expiry < math.inf:
                steps = min(steps, max(math.floor((expiry - sim.time) / dt) + 1, 1))
        if deadline is not None:
            # At the cost per step of the last call: the first, and one that compiled a
            # build, take a step alone and the next goes on from their measure.
            affordable = (1 if self.step_cost_s is None
                          else (deadline - time.monotonic()) / max(self.step_cost_s, 1e-9))
            steps = min(steps, max(int(affordable), 1))
        started = time.perf_counter()
        sim.run(steps, dt)
        spent = time.perf_counter() - started
        self.step_cost_s = spent / steps
        self.time_spent['physics'] += spent
        self.steps_taken += steps
        self.simulated_s += steps * dt
        if sim.time >= self.next_publish_time - 1e-9:
            self._publish_state()
            self.next_publish_time += self.publish_period
            if self.next_publish_time <= sim.time:
                self.next_publish_time = sim.time + self.publish_period
            return self.lockstep.awaited_ns is None, steps
        return True, steps

    def _publish_scene_markers(self):
        self.scene_marker_publisher.publish(scene_markers(
            self.simulation.environment.pool, self.scene['water.surface_z'],
            self.scene['frame_id']))

    def _publish_state(self):
        started = time.perf_counter()
        spheres = self.simulation.spheres
        wanted = self._odometry_listened_to()
        if self.lockstep.enabled and self.per_sphere:
            # A controller that has not matched yet gets it too (transient-local).
            listed = {spheres.index[name] for name in self.lockstep.inputs
                      if name in spheres.index}
            wanted = sorted(listed.union(wanted)) if listed else wanted
        self.messages.fill(self.simulation.time, spheres.position, spheres.velocity,
                           spheres.radius, wanted)
        built = time.perf_counter()
        instant_ns = stamp_nanoseconds(self.simulation.time)
        with self.inputs.lock:  # before it is out: an unstamped answer to it comes after
            self.inputs.instant_ns = instant_ns
        self.pose_publisher.publish(self.messages.poses.to_bytes())
        self.marker_publisher.publish(self.messages.markers.to_bytes())
        self.state_publisher.publish(self.messages.states_bytes())
        if wanted:
            odometry = [(self.odometry_publishers[spheres.names[i]],
                         self.messages.odometry_bytes(i)) for i in wanted]
            if self.lockstep.enabled:
                # Every instant to every controller, before the wait: none may be left out.
                for publisher, message in odometry:
                    publisher.publish(message)
            else:
                self.odometry_sender.send(odometry)
        if self.lockstep.enabled:
            self.lockstep.published(instant_ns)
        self.time_spent['build'] += built - started
        self.time_spent['publish'] += time.perf_counter() - built
        self.publishes += 1
        if time.monotonic() >= self.next_status_wall:
            self.next_status_wall = time.monotonic() + STATUS_PERIOD_S
            self._log_status()

    def _odometry_listened_to(self):
        """Indices of spheres whose odometry has subscribers, looked up every half wall
        second: odometry is a message per sphere, filled only where someone listens."""
        now = time.monotonic()
        if now >= self.next_listener_check:
            self.next_listener_check = now + 0.5
            publishers = self.odometry_publishers
            self.odometry_wanted = [
                i for i, name in enumerate(self.simulation.spheres.names)
                if name in publishers and publishers[name].get_subscription_count() > 0]
        return self.odometry_wanted

    def _report_recovered(self):
        """Name the spheres the step guard put back in this tick, and the likely cause."""
        recovered = self.simulation.take_recovered()
        if recovered and time.monotonic() >= self.next_recovery_log_wall:
            # Throttled here, not by the logger: the likely cause costs a bisection.
            self.next_recovery_log_wall = time.monotonic() + THROTTLE_S
            names = named_few([self.simulation.spheres.names[i] for i in recovered])
            self.get_logger().error(
                f'a step would have left {names} non-finite or outside the pool: put back at '
                f'rest where the step began; likely cause: '
                f'{self.simulation.likely_cause(recovered[0])}')

    def _log_status(self):
        spheres = self.simulation.spheres
        heights = [f'{name} z={z:.2f} m' for name, z in zip(
            spheres.names[:NAMES_SHOWN], spheres.position[2, :NAMES_SHOWN].tolist())]
        self.get_logger().info(f't={self.simulation.time:.1f} s: '
                               f'{named_few(heights, spheres.count)}. {self.time_report()}')

    def running_wall_s(self) -> float:
        """Wall seconds since start, less the time spent paused."""
        now = time.monotonic()
        paused = self.paused_wall_s + (now - self.paused_since if self.paused_since else 0.0)
        return max(now - self.started_wall - paused, 1e-9)

    def time_report(self) -> str:
        """Where the wall time went since start; part of the status line every 5 s. The
        real-time factor counts running time only: paused time is no falling behind."""
        wall = self.running_wall_s()
        parts = ', '.join(f'{name} {seconds / wall:.1%}'
                          for name, seconds in self.time_spent.items())
        return (f'{self.simulated_s:.2f} s simulated in {wall:.2f} s running '
                f'(real-time factor {self.simulated_s / wall:.3f}), {self.steps_taken} '
                f'steps, {self.publishes} publishes ({self.odometry_sender.dropped} odometry '
                f'sets left out for slow subscribers), {self.given_up_s:.2f} s given up to '
                f'the catch-up bound, {self.simulation.recoveries} put-backs by the step '
                f'guard{self.lockstep.report()}; wall time in {parts}')

    def _set_paused(self, paused: bool):
        now = time.monotonic()
        if paused and not self.paused:
            self.paused_since = now
            self.next_paused_publish = now + PAUSED_REPUBLISH_S
        elif not paused and self.paused:
            self.paused_wall_s += now - self.paused_since
            self.paused_since = None
            self.last_wall = now  # paused time is not owed
            self.lockstep.restart_wait()  # nor does it count against lockstep_timeout
        self.paused = paused

    # -- parameters: one path for ros2 param set, set_mass, set_radius, spawn and remove -----

    def _complete_parameters(self, parameters):
        """Before rclpy's checks: integers for doubles become doubles, and a radius change
        brings the lift area along where the area follows the radius."""
        parameters = as_declared_types(parameters)
        given = {p.name for p in parameters}
        spheres = self.simulation.spheres
        extra = []
        for parameter in parameters:
            value = parameter.value
            # Only a radius of the right type and within its range brings an area along;
            # anything else is left for rclpy's and our checks to refuse, with their reason.
            if (self.per_sphere and parameter.name.endswith('.radius')
                    and parameter.type_ == Parameter.Type.DOUBLE
                    and RADIUS_RANGE_M[0] <= value <= RADIUS_RANGE_M[1]):
                sphere = parameter.name[:-len('.radius')]
                i = spheres.index.get(sphere)
                if (i is not None and spheres.lift_area_follows_radius[i]
                        and f'{sphere}.lift_area' not in given):
                    extra.append(Parameter(f'{sphere}.lift_area', value=math.pi * value * value))
            elif (not self.per_sphere and parameter.name == f'{ARRAY_PREFIX}radius'
                  and parameter.type_ == Parameter.Type.DOUBLE_ARRAY
                  and f'{ARRAY_PREFIX}lift_area' not in given
                  and 'sphere_names' not in given and len(value) == spheres.count):
                radius = np.clip(np.asarray(value, dtype=float), *RADIUS_RANGE_M)
                area = np.where(spheres.lift_area_follows_radius, math.pi * radius**2,
                                spheres.lift_area)
                extra.append(Parameter(f'{ARRAY_PREFIX}lift_area', value=area.tolist()))
        # The parameter table shows them; the core's set_radius moves a following area
        # itself, and setting it as given would stop it following.
        self._following_lift_areas = {parameter.name for parameter in extra}
        return parameters + extra

    def _check_parameters(self, parameters):
        """Accept or refuse a whole request; what it changes is applied after rclpy stores
        it (_apply_parameters)."""
        with self.lock:
            try:
                self._planned = self._plan(parameters)
            except InvalidInput as error:
                self._planned = None
                return SetParametersResult(successful=False, reason=str(error))
            finally:
                self._following_lift_areas = set()  # this request's only
        return SetParametersResult(successful=True)

    def _plan(self, parameters):
        for parameter in parameters:
            if is_ros_own(parameter.name) and not self.has_parameter(parameter.name):
                # rclpy's own names are rclpy's to take, once declared (a qos_overrides
                # key is read_only); undeclared, they are names like any unknown one.
                raise InvalidInput(unknown_key_reason(parameter.name, self.per_sphere,
                                                      self.simulation.spheres.names))
        values = {p.name: plain(p.value) for p in parameters
                  if not is_ros_own(p.name) and p.name not in self._following_lift_areas}
        settings = {name: values.pop(name) for name in LOCKSTEP_KEYS if name in values}
        if 'sphere_names' in values and tuple(values['sphere_names'] or ()) != \
                self.simulation.spheres.names:
            planned = self._plan_spheres(values, settings)
        else:
            planned = {'scene': None, 'live': self._live_changes(values, self.scene)}
            if settings:  # checked as a scene checks them (against sphere_names too)
                planned['settings'] = self.scene.with_values(**settings)
        return planned

    def _live_changes(self, values, scene):
        """[(sphere, key, value)] of a request's live keys, each checked; InvalidInput for
        anything that cannot change while running."""
        spheres = self.simulation.spheres
        changes = []
        for name, value in values.items():
            if name == 'sphere_names':
                continue
            if not self.per_sphere and name.startswith(ARRAY_PREFIX):
                changes += self._live_array_changes(name, value, scene, values)
                continue
            sphere, _, key = name.rpartition('.')
            if sphere not in spheres.index or key not in SPHERE_KEYS or not self.per_sphere:
                raise InvalidInput(unknown_key_reason(name, self.per_sphere, spheres.names))
            changes.append(self._live_change(name, value))
        return changes

    def _live_change(self, name, value):
        """(sphere, key, checked value) of a kept sphere's '<sphere>.<key>', or InvalidInput
        if the key cannot change while running or the value is refused."""
        sphere, _, key = name.rpartition('.')
        if key not in LIVE_SPHERE_KEYS:
            raise InvalidInput(f'{name}: cannot change while running')
        return sphere, key, check_live(self.simulation.spheres,
                                       self.simulation.environment.pool, sphere, key, value)

    def _live_array_changes(self, name, value, scene, values):
        found = array_parameter(name)
        if found is None:
            raise InvalidInput(unknown_key_reason(name, False, scene.sphere_names))
        key, component = found
        spheres, pool = self.simulation.spheres, self.simulation.environment.pool
        rows = as_rows(name, value, spheres.count)
        if key not in LIVE_SPHERE_KEYS:
            initial = scene.sphere_array(key)
            if not np.array_equal(rows, initial if component is None else initial[:, component]):
                raise InvalidInput(f'{name}: cannot change while running (only '
                                   f'{", ".join(ARRAY_PREFIX + k for k in LIVE_SPHERE_KEYS)} '
                                   'can, and sphere_names, to add and remove spheres)')
            return []
        current = getattr(spheres, key)
        if key == 'lift_area':
            # Given where it differs from what it would be after this request: a following
            # area moves with a radius in the same request (an edited dump loaded at once).
            radius = values.get(f'{ARRAY_PREFIX}radius')
            radius = (spheres.radius if radius is None
                      else as_rows(f'{ARRAY_PREFIX}radius', radius, spheres.count))
            current = np.where(spheres.lift_area_follows_radius, np.pi * radius**2, current)
        changed = np.flatnonzero(~(rows == current))  # NaN counts as changed
        return [(spheres.names[i], key, check_live(spheres, pool, spheres.names[i], key,
                                                   float(rows[i]))) for i in changed]

    def _plan_spheres(self, values, settings):
        """Spawn and remove: the new scene (with the lockstep `settings` of the request),
        and the live changes of the spheres kept. The new scene keeps the kept spheres'
        initial values (reset goes back to them); keys of a kept sphere in the request are
        live changes, as in any other request."""
        names = check_some_sphere_names(values['sphere_names'])
        index = self.simulation.spheres.index
        given, live = {}, {}
        if self.per_sphere:
            for name, value in values.items():
                sphere = name.rpartition('.')[0]
                if name == 'sphere_names':
                    continue
                if sphere not in names:
                    raise InvalidInput(unknown_key_reason(name, True, names))
                (live if sphere in index else given)[name] = value
        else:
            # Vectorised over the kept spheres: a spawn at 100 000 spheres is one request.
            kept = [(i, index[name]) for i, name in enumerate(names) if name in index]
            new_at = np.array([i for i, _ in kept], dtype=int)
            old_at = np.array([j for _, j in kept], dtype=int)
            for name, value in values.items():
                if name == 'sphere_names':
                    continue
                found = array_parameter(name)
                if found is None:
                    raise InvalidInput(unknown_key_reason(name, False, names))
                key, component = found
                rows = as_rows(name, value, len(names))
                initial = self.scene.sphere_array(key)[old_at]
                initial = initial if component is None else initial[:, component]
                if key in LIVE_SPHERE_KEYS:
                    current = getattr(self.simulation.spheres, key)[old_at]
                    for j in np.flatnonzero(~(rows[new_at] == current)):  # NaN: changed
                        live[f'{names[new_at[j]]}.{key}'] = float(rows[new_at[j]])
                else:
                    differs = ~(rows[new_at] == initial)
                    if differs.any():
                        first = int(new_at[np.flatnonzero(differs)[0]])
                        raise InvalidInput(f'{name}: {names[first]} (index {first}) is kept and '
                                           'cannot change it while running')
                rows[new_at] = initial
                given[name] = rows.tolist()
        scene = self.scene.with_spheres(names, {**given, **settings})
        return {'scene': scene,
                'live': [self._live_change(name, value) for name, value in live.items()]}

    def _apply_parameters(self, parameters):
        with self.lock:
            planned, self._planned = self._planned, None
            if planned is None:
                return
            if planned['scene'] is not None:
                self._change_spheres(planned['scene'])
            if 'settings' in planned:
                self.scene = planned['settings']
            self._configure_lockstep()
            touched = set()
            for sphere, key, value in planned['live']:
                getattr(self.simulation, f'set_{key}')(sphere, value)
                touched.add(self.simulation.spheres.lookup(sphere))
            if touched:
                self._warn_if_unstable(sorted(touched))

    def _change_spheres(self, scene):
        """Spawn and remove: the simulation, the topics and the parameter table follow."""
        before = self.simulation.spheres.names
        after = scene.sphere_names
        removed = [name for name in before if name not in set(after)]
        added = [name for name in after if name not in set(before)]
        wrench_time = dict(zip(before, self.wrench_time.tolist()))
        self.simulation.change_spheres(scene)
        self.step_cost_s = None  # measured anew: the count (and so the build) changed
        self.scene = scene
        self.wrench_time = np.array([wrench_time.get(name, -math.inf) for name in after])
        self.inputs.remove_spheres(removed)
        self.inputs.add_spheres(added)
        for name in removed:
            publisher = self.odometry_publishers.pop(name, None)
            if publisher is not None:
                self.destroy_publisher(publisher)
        self._add_odometry(added)
        self.messages = SphereMessages(after, scene['frame_id'], odometry=self.per_sphere)
        self.next_listener_check = 0.0
        if self.per_sphere:
            gone = [f'{name}.{key}' for name in removed for key in SPHERE_KEYS]
            new = [(name, value, describe(name, is_read_only(name)))
                   for name, value, _ in sphere_parameters(scene, True, names=added)]
            retable(self, removed=gone, declared=new)
        else:
            live = {key: getattr(self.simulation.spheres, key) for key in LIVE_SPHERE_KEYS}
            retable(self, declared=sphere_parameters(scene, False, live=live))
        self._publish_state()
        self.get_logger().info(
            f'spheres now {named_few(after)}: added {named_few(added) or "none"}, removed '
            f'{named_few(removed) or "none"}')
        if added:
            self._warn_if_unstable([self.simulation.spheres.lookup(name) for name in added])

    def _spawn_together(self, set_each):
        """rclpy's set_parameters service sets entry by entry; `ros2 param load` sends a
        file's keys that way. A request that changes sphere_names sets it together with the
        new spheres' keys (and the spheres.<key> arrays), in one atomic change, as a spawn
        must be; the other entries go on one by one. Results stay in the request's order."""
        def set_parameters(request, response):
            entries = list(request.parameters)
            names = [e for e in entries if e.name == 'sphere_names'
                     and e.value.type == Parameter.Type.STRING_ARRAY.value]
            if not names or tuple(names[-1].value.string_array_value) == \
                    self.simulation.spheres.names:
                return set_each(request, response)
            new = set(names[-1].value.string_array_value) - set(self.simulation.spheres.names)
            together = [i for i, e in enumerate(entries) if e.name == 'sphere_names'
                        or e.name.rpartition('.')[0] in new or e.name.startswith(ARRAY_PREFIX)
                        or e.name in LOCKSTEP_KEYS]  # they name the spheres
            outcome = unknown_type_refusal([entries[i] for i in together],
                                           'nothing of the spawn')
            if outcome is None:
                outcome = self.set_parameters_atomically(
                    [Parameter.from_parameter_msg(entries[i]) for i in together])
            rest = [e for i, e in enumerate(entries) if i not in set(together)]
            each = set_each(SetParameters.Request(parameters=rest),
                            SetParameters.Response()).results if rest else []
            each = iter(each)
            response.results = [outcome if i in set(together) else next(each)
                                for i in range(len(entries))]
            return response
        return set_parameters

    def _on_set_sphere(self, key, request, response):
        """Each entry: name = sphere, value = new mass (kg) or radius (m); a result each.
        Checked entry by entry, then applied as one parameter change."""
        results, accepted = [], {}
        for entry in request.parameters:
            result = self._check_sphere_entry(key, entry, accepted)
            results.append(result)
        if accepted:
            if self.per_sphere:
                parameters = [Parameter(f'{name}.{key}', value=value)
                              for name, value in accepted.items()]
            else:
                values = getattr(self.simulation.spheres, key).copy()
                for name, value in accepted.items():
                    values[self.simulation.spheres.index[name]] = value
                parameters = [Parameter(f'{ARRAY_PREFIX}{key}', value=values.tolist())]
            outcome = self.set_parameters_atomically(parameters)
            results = [outcome if result is None else result for result in results]
        response.results = results
        return response

    def _check_sphere_entry(self, key, entry, accepted):
        """A refusal, or None with the value put in accepted[name]."""
        if entry.value.type not in KNOWN_PARAMETER_TYPES:
            return SetParametersResult(successful=False, reason=unknown_type_reason(entry))
        spheres = self.simulation.spheres
        try:
            spheres.lookup(entry.name)
            value = parameter_value_to_python(entry.value)
            if isinstance(value, int) and not isinstance(value, bool):
                value = float(value)  # kept a double, so the parameter keeps one type
            value = check_live(spheres, self.simulation.environment.pool, entry.name, key,
                               value)
        except InvalidInput as error:
            return SetParametersResult(successful=False, reason=str(error))
        accepted[entry.name] = value
        return None

    def _on_reset(self, request, response):
        with self.lock:
            self.inputs.clear()  # forces sent before the reset do not outlive it
            self.lockstep.forget()
            spheres = self.simulation.spheres
            live = {key: getattr(spheres, key).copy() for key in LIVE_SPHERE_KEYS}
            self.simulation.reset()
            self._reset_timing()
            if self.stamp_limit_reached:  # paused at the end of ROS time stamps: go on
                self._set_paused(False)
                self.stamp_limit_reached = False
            # The parameters of what a live change moved show the initial values again: the
            # table is written directly (the simulation is already back, and a lift area
            # set back as if given would stop following its radius).
            changed = []
            for key, before in live.items():
                initial = getattr(self.simulation.spheres, key)
                moved = np.flatnonzero(before != initial)
                if moved.size and self.per_sphere:
                    changed += [(f'{spheres.names[i]}.{key}', float(initial[i])) for i in moved]
                elif moved.size:
                    changed.append((f'{ARRAY_PREFIX}{key}', doubles(initial)))
            if changed:
                retable(self, changed=changed)
            self._publish_state()
        response.success, response.message = True, 'back to the initial scene at time 0'
        return response

    def _on_step(self, request, response):
        """While paused: one publish period on, that instant published, then the answer
        (with the new simulated time). Lockstep answers are not waited for here (they come
        through the executor that runs this service): it applies what has arrived."""
        with self.lock:
            if not self.paused or self.stamp_limit_reached:
                response.success = False
                response.message = (
                    'at the last time a ROS stamp can carry (2^31 s); call ~/reset'
                    if self.stamp_limit_reached else
                    'not paused: ~/step advances a paused simulation by one publish period; '
                    'pause it first (~/pause true)')
                return response
            started = self.simulation.time
            response.success = self.advance_period()
            response.message = (f'stepped from t={started:.9f} s to '
                                f't={self.simulation.time:.9f} s' if response.success else
                                'at the last time a ROS stamp can carry (2^31 s): not '
                                'stepped; call ~/reset')
        return response

    def _on_pause(self, request, response):
        with self.lock:
            if not request.data and self.stamp_limit_reached:
                response.success = False
                response.message = ('paused at the last time a ROS stamp can carry (2^31 s); '
                                    'call ~/reset to start again from 0')
                return response
            self._set_paused(bool(request.data))
        response.success = True
        response.message = 'paused' if self.paused else 'running'
        return response


class OdometrySender:
    """Publishes the per-sphere odometry on a thread of its own, the newest set only.

    A message per sphere is the one output whose cost grows with the subscribers: DDS
    delivers each at ~20 us, so 1 000 listened-to spheres at 30 Hz would take the clock
    more than half its time (measured: real-time factor 0.38). Here the clock hands each
    publish's messages over and goes on; a set still waiting when the next comes is
    replaced by it (counted in `dropped`), so slow subscribers get fewer, newer messages and
    the clock loses nothing.
    """

    def __init__(self, logger):
        self.logger = logger
        self.waiting = None  # [(publisher, serialized Odometry)] of the newest publish
        self.dropped = 0
        self.running = True
        self.ready = threading.Condition()
        self.thread = threading.Thread(target=self._run, name='pool_sim_odometry',
                                       daemon=True)
        self.thread.start()

    def send(self, messages):
        with self.ready:
            if self.waiting is not None:
                self.dropped += 1
            self.waiting = messages
            self.ready.notify()

    def _run(self):
        while True:
            with self.ready:
                while self.running and self.waiting is None:
                    self.ready.wait()
                if not self.running:
                    return
                messages, self.waiting = self.waiting, None
            for first in range(0, len(messages), ODOMETRY_CHUNK):
                started = time.perf_counter()
                for publisher, message in messages[first:first + ODOMETRY_CHUNK]:
                    try:
                        publisher.publish(message)
                    except Exception as error:  # its sphere removed meanwhile, or stopping
                        if self.running:
                            self.logger.warning(f'odometry not sent: {error}',
                                                throttle_duration_sec=THROTTLE_S)
                # rclpy holds the interpreter while it publishes: rest in proportion, so
                # the clock thread always has the interpreter when it needs it.
                busy = time.perf_counter() - started
                time.sleep(busy * (1.0 - ODOMETRY_SHARE) / ODOMETRY_SHARE)

    def stop(self):
        with self.ready:
            self.running = False
            self.ready.notify()
        self.thread.join(timeout=5.0)


def check_live(spheres, pool, sphere, key, value) -> float:
    """A live key's new value, checked as the core checks it; InvalidInput if refused."""
    if key == 'mass':
        return spheres.check_mass(sphere, value)
    if key == 'radius':
        return spheres.check_radius(sphere, value, pool)
    return spheres.check_lift_area(sphere, value)


def as_rows(name, value, count) -> np.ndarray:
    """A spheres.<key> array parameter as (count,) floats, or InvalidInput."""
    try:
        rows = np.array(value, dtype=float)
    except (TypeError, ValueError):
        raise InvalidInput(f'{name}: expected {count} numbers, got {value!r:.60}') from None
    if rows.ndim != 1 or rows.size != count:
        raise InvalidInput(f'{name}: expected {count} values (one per sphere in '
                           f'sphere_names), got {rows.size}')
    return rows


def unknown_key_reason(name, per_sphere, sphere_names) -> str:
    form = ('<sphere>.mass, <sphere>.radius and <sphere>.lift_area' if per_sphere else
            ', '.join(ARRAY_PREFIX + key for key in LIVE_SPHERE_KEYS))
    return (f'{name}: not a parameter of this node (spheres: {named_few(sphere_names)}); '
            f'while running {form} can change, and sphere_names (with the new spheres\' '
            'keys in the same request) adds and removes spheres')


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
