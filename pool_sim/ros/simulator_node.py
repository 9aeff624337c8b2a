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
from rcl_interfaces.srv import SetParameters
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
from pool_sim.physics.stability import stable_step_bound
from pool_sim.ros.messages import scene_markers, SphereMessages, stamp_of
from pool_sim.ros.parameters import (declare_scene, live_key, overrides_of,
                                     ROS_OWN_PARAMETERS, scene_from_overrides)

# Wall time one tick may spend stepping at real_time_factor 0, so services stay responsive.
FAST_TICK_BUDGET_S = 0.02
# Wall time the node may fall behind and still catch up (then it drops the backlog).
MAX_BACKLOG_WALL_S = 0.1
# Wall seconds between the status lines in the log, and how many spheres they name.
STATUS_PERIOD_S = 5.0
STATUS_SPHERES = 4


def named_few(items, count=None):
    """The first STATUS_SPHERES of `items` (of `count` in all), then how many more: a log
    line stays a line with thousands of spheres."""
    count = len(items) if count is None else count
    more = count - STATUS_SPHERES
    return ', '.join(items[:STATUS_SPHERES]) + (f' and {more} more' if more > 0 else '')


class PoolSimNode(Node):
    """node_kwargs go to rclpy's Node (context, parameter_overrides, namespace, ...)."""

    def __init__(self, node_name='pool_sim', default_scene=None, **node_kwargs):
        super().__init__(node_name, **node_kwargs)
        default_scene = default_scene or Scene.default()
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
        self.create_service(SetParameters, '~/set_mass', partial(self._on_set_sphere, 'mass'))
        self.create_service(SetParameters, '~/set_radius',
                            partial(self._on_set_sphere, 'radius'))
        self.create_service(Trigger, '~/reset', self._on_reset)
        self.create_service(SetBool, '~/pause', self._on_pause)
        self.add_on_set_parameters_callback(self._check_parameters)
        self.add_post_set_parameters_callback(self._apply_parameters)

        self._torque_warned = set()
        # Wall seconds spent in each part, for the status line and the benchmarks.
        self.time_spent = {'physics': 0.0, 'build': 0.0, 'publish': 0.0}
        self.next_listener_check, self.odometry_wanted = 0.0, []
        # Counted across resets (which restart simulation time): what the node has done.
        self.publishes, self.steps_taken, self.simulated_s = 0, 0, 0.0
        # Simulated seconds the catch-up bound let go when the node fell behind.
        self.given_up_s = 0.0
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
                       / self.real_time_factor if self.real_time_factor > 0 else 0.001)
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

    def _warn_if_unstable(self):
        bound = stable_step_bound(self.scene)
        if self.simulation.max_step > bound:
            self.get_logger().warning(
                f'{self.scene["integrator"]} is unstable at {self.scene["physics_rate_hz"]:g} Hz '
                f'for this scene: its stiffest sphere needs a step under {bound * 1e3:.3g} ms '
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
        if self.real_time_factor > 0:
            limit = max(2.0 * dt, MAX_BACKLOG_WALL_S * self.real_time_factor)
            owed = self.backlog_s + elapsed * self.real_time_factor
            self.backlog_s = min(owed, limit)
            self.given_up_s += owed - self.backlog_s
            while self.backlog_s >= dt * (1.0 - 1e-9):
                self._step()
                self.backlog_s -= dt
                stepped = True
        else:
            deadline = now + FAST_TICK_BUDGET_S
            while time.monotonic() < deadline:
                self._step()
                stepped = True
        if stepped and self.clock_publisher is not None:
            self.clock_publisher.publish(ClockMessage(clock=stamp_of(self.simulation.time)))

    def _step(self):
        sim = self.simulation
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

    def _log_status(self):
        spheres = self.simulation.spheres
        heights = [f'{name} z={z:.2f} m' for name, z in zip(
            spheres.names[:STATUS_SPHERES], spheres.position[2, :STATUS_SPHERES].tolist())]
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
                f'the catch-up bound; wall time in {parts}')

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
        self.wrench_inputs.stop()
        return super().destroy_node()

    def _on_wrench(self, name, message):
        force = (message.force.x, message.force.y, message.force.z)
        if not all(math.isfinite(f) for f in force):
            self.get_logger().warning(
                f'{name}/wrench: refused a force that is not finite {force}; keeping the last',
                throttle_duration_sec=1.0)
            return
        torque = (message.torque.x, message.torque.y, message.torque.z)
        if any(torque) and name not in self._torque_warned:
            self._torque_warned.add(name)
            self.get_logger().warning(
                f'{name}/wrench: torque {torque} ignored: a point mass cannot turn')
        self.simulation.set_external_force(name, force)
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
        for parameter in parameters:
            key = live_key(parameter.name, self.scene.sphere_names)
            sphere = parameter.name.rpartition('.')[0]
            if key == 'mass':
                self.simulation.set_mass(sphere, parameter.value)
            elif key == 'radius':
                self.simulation.set_radius(sphere, parameter.value)

    def _on_set_sphere(self, key, request, response):
        """Each entry: name = sphere, value = new mass (kg) or radius (m); a result each."""
        for entry in request.parameters:
            try:
                self.simulation.spheres.lookup(entry.name)
            except InvalidInput as error:
                response.results.append(SetParametersResult(successful=False, reason=str(error)))
                continue
            value = parameter_value_to_python(entry.value)
            if isinstance(value, int) and not isinstance(value, bool):
                value = float(value)  # kept a double, so the parameter keeps one type
            try:
                parameter = Parameter(f'{entry.name}.{key}', value=value)
            except TypeError as error:
                response.results.append(SetParametersResult(successful=False,
                                                            reason=str(error)))
                continue
            response.results.extend(self.set_parameters([parameter]))
        return response

    def _on_reset(self, request, response):
        self.pending_wrenches.clear()  # forces sent before the reset do not outlive it
        self.simulation.reset()
        self._reset_timing()
        self.set_parameters([
            Parameter(f'{name}.{key}', value=self.scene[f'{name}.{key}'])
            for name in self.scene.sphere_names for key in ('mass', 'radius')])
        self._publish_state()
        self.next_publish_time = self.publish_period
        response.success, response.message = True, 'back to the initial scene at time 0'
        return response

    def _on_pause(self, request, response):
        self.paused = bool(request.data)
        response.success = True
        response.message = 'paused' if self.paused else 'running'
        return response


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
    """`ros2 run pool_sim pool_sim [--ros-args ...]`; exit code 1 for a bad params file."""
    rclpy.init(args=args)
    node, code = None, 0
    try:
        node = PoolSimNode()
        rclpy.spin(node)
    except (KeyboardInterrupt, ExternalShutdownException):
        pass
    except InvalidInput as error:
        rclpy.logging.get_logger('pool_sim').fatal(f'refusing to start: {error}')
        code = 1
    finally:
        if node is not None:
            node.destroy_node()
        rclpy.try_shutdown()
    return code


if __name__ == '__main__':
    sys.exit(main())
