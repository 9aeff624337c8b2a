"""The pool_sim node: the physics core on a timer, its state on topics, forces and changes in.

Simulation time is the only clock that counts: physics steps are a fixed dt, publishing and
wrench timeouts are in simulated seconds, and wall time only sets how fast that time runs
(real_time_factor). A machine that cannot keep up drops the backlog beyond a bound and the
simulation runs slower, instead of spiralling.
"""
from functools import partial
import math
import sys
import threading
import time

import numpy as np
from geometry_msgs.msg import PoseArray, Wrench
from nav_msgs.msg import Odometry
from rcl_interfaces.msg import SetParametersResult
from rcl_interfaces.srv import SetParameters, SetParametersAtomically
import rclpy
from rclpy.clock import Clock, ClockType
from rclpy.event_handler import PublisherEventCallbacks, SubscriptionEventCallbacks
from rclpy.executors import ExternalShutdownException, SingleThreadedExecutor
from rclpy.node import Node
from rclpy.parameter import Parameter, parameter_value_to_python
from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy
from rosgraph_msgs.msg import Clock as ClockMessage
from std_srvs.srv import SetBool, Trigger
from visualization_msgs.msg import MarkerArray

from pool_sim.physics import fused, InvalidInput, Scene, Simulation
from pool_sim.physics.scene import read_params_document
from pool_sim.physics.spheres import named_few, NAMES_SHOWN, shortened, shown
from pool_sim.physics.stability import stable_at, stable_step_bound
from pool_sim.ros.executables import run_node
from pool_sim.ros.messages import LAST_STAMP_S, scene_markers, SphereMessages, stamp_of
from pool_sim.ros.parameters import (declare_scene, live_key, overrides_of, params_files,
                                     ROS_OWN_PARAMETERS, scene_from_overrides)

# Wall time one tick may spend stepping, in every mode, so services stay responsive.
TICK_BUDGET_S = 0.02
# Wall seconds between ticks: never longer, so a slow publish rate or a small
# real_time_factor does not owe more than the catch-up bound at once; never shorter, so a
# huge real_time_factor does not spin the timer for nothing.
TICK_PERIOD_RANGE_S = (0.001, 0.05)
# Requests a service queues before DDS drops one: many clients at once must all be answered.
SERVICE_QOS = QoSProfile(depth=1000, reliability=ReliabilityPolicy.RELIABLE)
# Wall time the node may fall behind and still catch up (then it drops the backlog).
MAX_BACKLOG_WALL_S = 0.1
# Wall seconds between the status lines in the log.
STATUS_PERIOD_S = 5.0
# Wall seconds between two error lines of the same kind (a step guard, a refused input).
THROTTLE_S = 1.0
KNOWN_PARAMETER_TYPES = frozenset(t.value for t in Parameter.Type)
# The most entries one request may carry: every entry of a set is applied in the request's
# callback (about 0.25 ms each), every name of a read looked up, while the clock waits.
MAX_SET_ENTRIES = 256
MAX_READ_NAMES = 10_000


class PoolSimNode(Node):
    """node_kwargs go to rclpy's Node (context, parameter_overrides, namespace, ...)."""

    def __init__(self, node_name='pool_sim', default_scene=None, **node_kwargs):
        super().__init__(node_name, **node_kwargs)
        try:
            self._build(default_scene or Scene.default())
        except BaseException:
            # Refused, or stopped by a signal half-way: nothing of it may outlive it (a
            # wrench thread left spinning aborts the process at exit).
            self.destroy_node()
            raise

    def _build(self, default_scene):
        self.scene = scene_from_overrides(overrides_of(self), default_scene)
        declare_scene(self, self.scene)
        self.simulation = Simulation(self.scene)
        # The physics loop on one thread (this one, which spins the timer): the machine's
        # other cores serve DDS, the wrench thread and the subscribers.
        fused.use_threads(1)
        scene, names = self.scene, self.scene.sphere_names

        self.real_time_factor = scene['real_time_factor']
        self.publish_period = 1.0 / scene['publish_rate_hz']
        self.wrench_timeout = scene['wrench_timeout']
        self.paused = False
        self._reset_timing()

        self.messages = SphereMessages(names, scene['frame_id'])
        self.pose_publisher = self.create_publisher(PoseArray, '~/poses', 10)
        self.marker_publisher = self.create_publisher(MarkerArray, '~/markers', 10)
        latched = QoSProfile(depth=1, durability=DurabilityPolicy.TRANSIENT_LOCAL,
                             reliability=ReliabilityPolicy.RELIABLE)
        self.scene_marker_publisher = self.create_publisher(
            MarkerArray, '~/scene_markers', latched)
        # Per-sphere topics without rclpy's default QoS-event handlers: each is a waitable
        # the executor walks on every wake-up, 2 000 of them at 1 000 spheres.
        self.odometry_publishers = [
            self.create_publisher(Odometry, f'~/{name}/odom', 10, event_callbacks=
                                  PublisherEventCallbacks(use_default_callbacks=False))
            for name in names]
        self.clock_publisher = (self.create_publisher(ClockMessage, '/clock', 10)
                                if scene['publish_clock'] else None)
        # Latest wrench per sphere, filled by the WrenchInputs thread, emptied by each tick.
        self.pending_wrenches = {}
        self.wrench_inputs = WrenchInputs(self, names, self.pending_wrenches_put)
        self.create_service(SetParameters, '~/set_mass', partial(self._on_set_sphere, 'mass'),
                            qos_profile=SERVICE_QOS)
        self.create_service(SetParameters, '~/set_radius',
                            partial(self._on_set_sphere, 'radius'), qos_profile=SERVICE_QOS)
        self.create_service(Trigger, '~/reset', self._on_reset, qos_profile=SERVICE_QOS)
        self.create_service(SetBool, '~/pause', self._on_pause, qos_profile=SERVICE_QOS)
        self.add_on_set_parameters_callback(self._check_parameters)
        self.add_post_set_parameters_callback(self._apply_parameters)
        guard_services(self)

        self._torque_warned = set()
        # Wall seconds spent in each part, for the status line and the benchmarks.
        self.time_spent = {'physics': 0.0, 'build': 0.0, 'publish': 0.0}
        self.next_listener_check, self.odometry_wanted = 0.0, []
        # Counted across resets (which restart simulation time): what the node has done.
        self.publishes, self.steps_taken, self.simulated_s = 0, 0, 0.0
        # Simulated seconds the catch-up bound let go when the node fell behind.
        self.given_up_s = 0.0
        # True once simulated time reached the last second a ROS stamp holds (then paused).
        self.stamp_limit_reached = False
        self.next_recovery_log_wall = 0.0
        self.started_wall = time.monotonic()  # both set again once set-up is done
        self.next_status_wall = self.started_wall + STATUS_PERIOD_S
        self.scene_marker_publisher.publish(scene_markers(
            self.simulation.environment.pool, scene['water.surface_z'], scene['frame_id']))
        self._publish_state()
        # A steady clock: with use_sim_time the ROS clock would wait for our own /clock.
        # One wake-up per publish period, not per physics step: each wake-up costs rclpy's
        # executor a walk over every subscription (one per sphere), so at 1 000 spheres
        # waking per step left it 85 % of the time. The steps inside stay a fixed dt.
        tick_period = (max(self.simulation.max_step, self.publish_period)
                       / self.real_time_factor if self.real_time_factor > 0 else 0.0)
        tick_period = min(max(tick_period, TICK_PERIOD_RANGE_S[0]), TICK_PERIOD_RANGE_S[1])
        self.timer = self.create_timer(tick_period, self._on_tick,
                                       clock=Clock(clock_type=ClockType.STEADY_TIME))
        self._warn_if_unstable()
        self.get_logger().info(
            f'{len(names)} spheres ({named_few(names)}); {scene["integrator"]} at '
            f'{scene["physics_rate_hz"]:g} Hz, publishing at {scene["publish_rate_hz"]:g} Hz '
            f'of simulated time, real_time_factor {self.real_time_factor:g}; effects: '
            f'{", ".join(scene["effects"]) or "none"}')
        # Load the compiled kernel on a throwaway copy now, and start the clock after it and
        # after the set-up above: neither is the node falling behind.
        Simulation(self.scene, initial_spheres=self.simulation.spheres.copy()).step()
        self.last_wall = self.started_wall = time.monotonic()
        self.next_status_wall = self.started_wall + STATUS_PERIOD_S

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

    # -- time --------------------------------------------------------------------------------

    def _reset_timing(self):
        count = len(self.scene.sphere_names)
        self.next_publish_time = 0.0
        self.backlog_s = 0.0
        self.last_wall = time.monotonic()
        self.wrench_time = np.full(count, -math.inf)

    def _on_tick(self):
        now = time.monotonic()
        elapsed, self.last_wall = now - self.last_wall, now
        self._apply_pending_wrenches()
        if self.paused:
            return
        dt = self.simulation.max_step
        stepped = False
        deadline = now + TICK_BUDGET_S
        if self.real_time_factor > 0:
            limit = max(2.0 * dt, MAX_BACKLOG_WALL_S * self.real_time_factor)
            owed = self.backlog_s + elapsed * self.real_time_factor
            self.backlog_s = min(owed, limit)
            self.given_up_s += owed - self.backlog_s
            # Bounded by the budget too: a real_time_factor the machine cannot reach leaves
            # the rest owed (then given up at the bound), never a tick that blocks services.
            while (self.backlog_s >= dt * (1.0 - 1e-9) and time.monotonic() < deadline
                   and self._step()):
                self.backlog_s -= dt
                stepped = True
        else:
            while time.monotonic() < deadline and self._step():
                stepped = True
        if stepped and self.clock_publisher is not None:
            self.clock_publisher.publish(ClockMessage(clock=stamp_of(self.simulation.time)))
        self._report_recovered()

    def _step(self) -> bool:
        """One physics step (and the publish it is due); False when time cannot go on."""
        sim = self.simulation
        if sim.time + sim.max_step > LAST_STAMP_S:
            # builtin_interfaces/Time counts seconds in an int32: 68 years of simulated time.
            self.paused = self.stamp_limit_reached = True
            self.get_logger().error(
                f'simulated time reached {sim.time:.0f} s, the last a ROS time stamp can '
                'carry (2^31 s): paused; ~/reset starts again from 0')
            return False
        if self.wrench_timeout > 0.0:
            expired = sim.time - self.wrench_time > self.wrench_timeout
            if expired.any():
                sim.spheres.external_force[:, expired] = 0.0
                self.wrench_time[expired] = math.inf
        started = time.perf_counter()
        sim.step()
        self.time_spent['physics'] += time.perf_counter() - started
        self.steps_taken += 1
        self.simulated_s += sim.max_step
        if sim.time >= self.next_publish_time - 1e-9:
            self._publish_state()
            self.next_publish_time += self.publish_period
            if self.next_publish_time <= sim.time:
                self.next_publish_time = sim.time + self.publish_period
        return True

    def _publish_state(self):
        started = time.perf_counter()
        spheres = self.simulation.spheres
        wanted = self._odometry_listened_to()
        self.messages.fill(self.simulation.time, spheres.position, spheres.velocity,
                           spheres.radius, wanted)
        built = time.perf_counter()
        self.pose_publisher.publish(self.messages.poses.to_bytes())
        self.marker_publisher.publish(self.messages.markers.to_bytes())
        for i in wanted:
            self.odometry_publishers[i].publish(self.messages.odometry[i])
        self.time_spent['build'] += built - started
        self.time_spent['publish'] += time.perf_counter() - built
        self.publishes += 1
        if time.monotonic() >= self.next_status_wall:
            self.next_status_wall = time.monotonic() + STATUS_PERIOD_S
            self._log_status()

    def _odometry_listened_to(self):
        """Indices of spheres whose odometry has subscribers, looked up every half wall
        second: odometry is a message per sphere, built only where someone listens."""
        now = time.monotonic()
        if now >= self.next_listener_check:
            self.next_listener_check = now + 0.5
            self.odometry_wanted = [i for i, publisher in enumerate(self.odometry_publishers)
                                    if publisher.get_subscription_count() > 0]
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

    def time_report(self) -> str:
        """Where the wall time went since start; part of the status line every 5 s."""
        wall = max(time.monotonic() - self.started_wall, 1e-9)
        parts = ', '.join(f'{name} {seconds / wall:.1%}'
                          for name, seconds in self.time_spent.items())
        return (f'{self.simulated_s:.2f} s simulated in {wall:.2f} s '
                f'(real-time factor {self.simulated_s / wall:.3f}), {self.steps_taken} '
                f'steps, {self.publishes} publishes, {self.given_up_s:.2f} s given up to '
                f'the catch-up bound, {self.simulation.recoveries} put-backs by the step '
                f'guard; wall time in {parts}')

    # -- inputs ------------------------------------------------------------------------------

    def pending_wrenches_put(self, name, message):
        """Called on the WrenchInputs thread: only records; the tick applies it."""
        self.pending_wrenches[name] = message

    def _apply_pending_wrenches(self):
        # popitem and the other thread's setitem are each atomic: nothing is lost and the
        # dict is never walked while it changes (walking it raised if a wrench landed).
        pending = self.pending_wrenches
        while pending:
            name, message = pending.popitem()
            self._on_wrench(name, message)

    def destroy_node(self):
        wrench_inputs = getattr(self, 'wrench_inputs', None)
        if wrench_inputs is not None:
            wrench_inputs.stop()
        return super().destroy_node()

    def _on_wrench(self, name, message):
        force = (message.force.x, message.force.y, message.force.z)
        try:
            self.simulation.set_external_force(name, force)
        except InvalidInput as error:
            self.get_logger().warning(f'{name}/wrench: refused: {error}; keeping the last',
                                      throttle_duration_sec=THROTTLE_S)
            return
        torque = (message.torque.x, message.torque.y, message.torque.z)
        if any(torque) and name not in self._torque_warned:
            self._torque_warned.add(name)
            self.get_logger().warning(
                f'{name}/wrench: torque {torque} ignored: a point mass cannot turn')
        self.wrench_time[self.simulation.spheres.lookup(name)] = self.simulation.time

    def _check_parameters(self, parameters):
        """One validation path for `ros2 param set`, set_mass and set_radius."""
        for parameter in parameters:
            key = live_key(parameter.name, self.scene.sphere_names)
            if parameter.name in ROS_OWN_PARAMETERS:
                continue
            if not key:
                return SetParametersResult(successful=False, reason=(
                    f'{parameter.name}: cannot change while running; only <sphere>.mass and '
                    '<sphere>.radius can. Set it in a params file and restart.'))
            sphere = parameter.name.rpartition('.')[0]
            try:
                if key == 'mass':
                    self.simulation.spheres.check_mass(sphere, parameter.value)
                else:
                    self.simulation.spheres.check_radius(
                        sphere, parameter.value, self.simulation.environment.pool)
            except InvalidInput as error:
                return SetParametersResult(successful=False, reason=str(error))
        return SetParametersResult(successful=True)

    def _apply_parameters(self, parameters):
        changed = []
        for parameter in parameters:
            key = live_key(parameter.name, self.scene.sphere_names)
            sphere = parameter.name.rpartition('.')[0]
            if key == 'mass':
                self.simulation.set_mass(sphere, parameter.value)
            elif key == 'radius':
                self.simulation.set_radius(sphere, parameter.value)
            if key:
                changed.append(self.simulation.spheres.lookup(sphere))
        if changed:
            self._warn_if_unstable(sorted(set(changed)))

    def _on_set_sphere(self, key, request, response):
        """Each entry: name = sphere, value = new mass (kg) or radius (m); a result each."""
        for entry in request.parameters:
            response.results.append(self._set_sphere_entry(key, entry))
        return response

    def _set_sphere_entry(self, key, entry) -> SetParametersResult:
        try:
            self.simulation.spheres.lookup(entry.name)
        except InvalidInput as error:
            return SetParametersResult(successful=False, reason=str(error))
        if entry.value.type not in KNOWN_PARAMETER_TYPES:
            return SetParametersResult(successful=False, reason=unknown_type_reason(entry))
        value = parameter_value_to_python(entry.value)
        if isinstance(value, int) and not isinstance(value, bool):
            value = float(value)  # kept a double, so the parameter keeps one type
        parameter = Parameter(f'{entry.name}.{key}', value=value)
        # Our checks first, so the reason is ours; then rclpy's path, which checks again.
        checked = self._check_parameters([parameter])
        if not checked.successful:
            return checked
        return self.set_parameters([parameter])[0]

    def _on_reset(self, request, response):
        self.pending_wrenches.clear()  # forces sent before the reset do not outlive it
        # Only the parameters a live change moved go back (each set costs ~0.25 ms).
        changed = [Parameter(f'{name}.{key}', value=self.scene[f'{name}.{key}'])
                   for name in self.scene.sphere_names for key in ('mass', 'radius')
                   if self.get_parameter(f'{name}.{key}').value != self.scene[f'{name}.{key}']]
        self.simulation.reset()
        self._reset_timing()
        if self.stamp_limit_reached:  # paused at the end of ROS time stamps: go on again
            self.paused = self.stamp_limit_reached = False
        if changed:
            self.set_parameters_atomically(changed)
        self._publish_state()
        self.next_publish_time = self.publish_period
        response.success, response.message = True, 'back to the initial scene at time 0'
        return response

    def _on_pause(self, request, response):
        if not request.data and self.stamp_limit_reached:
            response.success = False
            response.message = ('paused at the last time a ROS stamp can carry (2^31 s); '
                                'call ~/reset to start again from 0')
            return response
        self.paused = bool(request.data)
        response.success = True
        response.message = 'paused' if self.paused else 'running'
        return response


def refusal(service_type, request, reason):
    """A response of `service_type` that refuses `request` with `reason`."""
    response = service_type.Response()
    if service_type is SetParameters:
        # One result object for every entry: a huge request costs one, not thousands.
        response.results = [SetParametersResult(successful=False, reason=reason)] * len(
            request.parameters)
    elif service_type is SetParametersAtomically:
        response.result = SetParametersResult(successful=False, reason=reason)
    elif hasattr(response, 'success'):
        response.success, response.message = False, reason
    return response


def unknown_type_reason(entry):
    return (f'{shortened(entry.name)}: value of unknown type code {entry.value.type} '
            '(ROS parameter types are 0 to 9)')


def guard_services(node):
    """Every service of `node`, rclpy's parameter services too, answers every request.

    rclpy's set_parameters services raise on a value of an unknown type code and the
    exception ends the node: here such an entry is refused with a reason (and, atomically,
    the whole request). Whatever else a callback raises is logged and refused: a request
    never takes the node down.
    """
    for service in node.services:
        callback, service_type = service.callback, service.srv_type
        if service_type is SetParameters and service.srv_name.endswith('/set_parameters'):
            callback = _per_entry_with_known_types(callback)
        elif service_type is SetParametersAtomically:
            callback = _atomic_with_known_types(callback)
        callback = _bounded(node, service.srv_name, service_type, callback)
        service.callback = _refusing_on_error(node, service.srv_name, service_type, callback)


def _request_size(request):
    """(entries, the most allowed) of a request: values to set, or names to read."""
    if hasattr(request, 'parameters'):
        return len(request.parameters), MAX_SET_ENTRIES
    for field in ('names', 'prefixes'):
        if hasattr(request, field):
            return len(getattr(request, field)), MAX_READ_NAMES
    return 0, 1


def _bounded(node, name, service_type, callback):
    """Refuses, as a whole, a request with more entries than one callback may take."""
    def bounded(request, response):
        size, most = _request_size(request)
        if size <= most:
            return callback(request, response)
        reason = f'{name}: {size} entries in one request; at most {most}: send them in parts'
        node.get_logger().warning(reason, throttle_duration_sec=THROTTLE_S)
        return refusal(service_type, request, reason)
    return bounded


def _per_entry_with_known_types(callback):
    def set_parameters(request, response):
        for entry in request.parameters:
            if entry.value.type in KNOWN_PARAMETER_TYPES:
                one = callback(SetParameters.Request(parameters=[entry]),
                               SetParameters.Response())
                response.results.extend(one.results)
            else:
                response.results.append(SetParametersResult(
                    successful=False, reason=unknown_type_reason(entry)))
        return response
    return set_parameters


def _atomic_with_known_types(callback):
    def set_parameters_atomically(request, response):
        for entry in request.parameters:
            if entry.value.type not in KNOWN_PARAMETER_TYPES:
                response.result = SetParametersResult(
                    successful=False, reason=unknown_type_reason(entry) + '; nothing was set')
                return response
        return callback(request, response)
    return set_parameters_atomically


def _refusing_on_error(node, name, service_type, callback):
    def guarded(request, response):
        try:
            return callback(request, response)
        except Exception as error:  # the last line: log it, refuse it, keep running
            reason = f'{name}: the request raised {type(error).__name__}: {shown(str(error))}'
            node.get_logger().error(reason, throttle_duration_sec=THROTTLE_S)
            return refusal(service_type, request, reason)
    return guarded


class WrenchInputs:
    """The `~/<sphere>/wrench` subscriptions, on a helper node spun by a thread of its own.

    rclpy's executor walks every subscription each time it wakes. With one per sphere on the
    simulator's own node, every timer tick paid for all of them (16 ms at 1 000 spheres);
    here they cost something only when a wrench arrives. Callbacks only hand the message
    over (`deliver(name, message)`); the simulator applies it on its own thread.
    """

    def __init__(self, simulator, names, deliver):
        self.node = Node(f'{simulator.get_name()}_wrench_inputs',
                         namespace=simulator.get_namespace(), context=simulator.context,
                         start_parameter_services=False)
        no_default_events = SubscriptionEventCallbacks(use_default_callbacks=False)
        for name in names:
            topic = simulator.resolve_topic_name(f'~/{name}/wrench')
            self.node.create_subscription(Wrench, topic, partial(deliver, name), 10,
                                          event_callbacks=no_default_events)
        # Woken only by a wrench or by stop(): each wake-up walks every subscription while
        # holding the GIL (40 ms at 5 000 spheres), so it must not poll.
        self.stop_signal = self.node.create_guard_condition(lambda: None)
        self.executor = SingleThreadedExecutor(context=simulator.context)
        self.executor.add_node(self.node)
        self.running = True
        self.thread = threading.Thread(target=self._spin, name='wrench_inputs', daemon=True)
        self.thread.start()

    def _spin(self):
        try:
            while self.running and self.executor.context.ok():
                self.executor.spin_once(timeout_sec=None)
        except (ExternalShutdownException, rclpy.executors.ShutdownException):
            pass

    def stop(self):
        self.running = False
        self.stop_signal.trigger()
        self.thread.join(timeout=5.0)
        self.executor.shutdown()
        self.node.destroy_node()


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
