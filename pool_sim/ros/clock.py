"""The node's clock: physics steps paced against wall time on a thread of its own, pause,
the lockstep wait, advance by one publish period, and the status line.

Simulation time is the only clock that counts: physics steps are a fixed dt, publishing and
wrench timeouts are in simulated seconds, and wall time only sets how fast that time runs
(real_time_factor). A machine that cannot keep up drops the backlog beyond a bound and the
simulation runs slower, instead of spiralling.

The clock thread steps and publishes; the executor that spins the node runs only the inputs
and services. rclpy's executor walks every subscription of a node each time it wakes (about
16 us each: 16 ms at 1 000 per-sphere wrench topics), so a clock on the executor's timer paid
that on every tick; on its own thread it pays nothing. The node's lock keeps the two apart.
"""
import math
import threading
import time

from pool_sim.physics import stepper
from pool_sim.physics.spheres import named_few, NAMES_SHOWN
from pool_sim.ros.messages import LAST_STAMP_S
from pool_sim.ros.services import THROTTLE_S

# Wall time one tick may spend stepping, in every mode, so services stay responsive.
TICK_BUDGET_S = 0.02
# Wall seconds between ticks: never longer, so a slow publish rate or a small
# real_time_factor does not owe more than the catch-up bound at once; never shorter, so a
# huge real_time_factor does not spin for nothing.
TICK_PERIOD_RANGE_S = (0.001, 0.05)
# Wall time the node may stay behind after a tick's budget (then it drops the rest).
MAX_BACKLOG_WALL_S = 0.1
# Wall seconds between the status lines in the log.
STATUS_PERIOD_S = 5.0
# A state that has not gone out for this long (wall s) while time stood still (paused, or
# a real_time_factor so small that no step is owed yet) goes out again, for subscribers
# that joined meanwhile asking for volatile durability, and to odometry subscribers that
# are new.
QUIET_REPUBLISH_S = 1.0



def steps_to_instant(instant_s, time_s, dt) -> int:
    """Steps of dt from time_s that reach the publish instant instant_s (at least one)."""
    return max(math.ceil((instant_s - 1e-9 - time_s) / dt), 1)


def next_instant(instant_s, period_s, time_s) -> float:
    """The publish instant after instant_s; one period from time_s if that is already past
    (a step longer than the publish period)."""
    instant_s += period_s
    return instant_s if instant_s > time_s else time_s + period_s

class SimulationClock:
    """Time for `node` (its simulation, lock and logger): publishing sends each instant,
    inputs are applied at the start of each tick, lockstep holds the steps until the
    instant published last is answered, diagnostics names spheres the step guard put
    back. run_clock: False makes no thread; then time goes on only by advance()."""

    def __init__(self, node, publishing, inputs, lockstep, diagnostics, run_clock=True):
        self.node, self.publishing, self.inputs = node, publishing, inputs
        self.lockstep, self.diagnostics, self.run_clock = lockstep, diagnostics, run_clock
        scene = node.scene
        self.real_time_factor = scene['real_time_factor']
        self.publish_period = 1.0 / scene['publish_rate_hz']
        self.wrench_timeout = scene['wrench_timeout']
        self.paused = False
        # True once simulated time reached the last second a ROS stamp holds (then paused).
        self.stamp_limit_reached = False
        self.restart()
        # Counted across resets (which restart simulation time): what the clock has done.
        self.steps_taken, self.simulated_s, self.physics_s = 0, 0.0, 0.0
        self.step_cost_s = None  # wall s per physics step, as the last call took
        # Simulated seconds the catch-up bound let go when the node fell behind.
        self.given_up_s = 0.0
        self.paused_wall_s, self.paused_since = 0.0, None
        self.started_wall = time.monotonic()  # set again by start()
        # No status line before start(): the first instant goes out while the node builds,
        # and a cold compile (seconds) is no running time.
        self.next_status_wall = math.inf
        tick_period = (max(node.simulation.max_step, self.publish_period)
                       / self.real_time_factor if self.real_time_factor > 0 else 0.0)
        self.tick_period = min(max(tick_period, TICK_PERIOD_RANGE_S[0]),
                               TICK_PERIOD_RANGE_S[1])
        self._one_thread = set()  # threads that step with one numba thread
        self.thread = None
        self.stopping, self.wake = threading.Event(), threading.Event()
        # Callables whose words end the status line (a recorder's, a live view's counts).
        self.reports = []
        publishing.listen(self._log_status_when_due)

    # -- life --------------------------------------------------------------------------------

    def start(self):
        """Running time counts from now; the thread starts (with run_clock)."""
        self.last_wall = self.started_wall = time.monotonic()
        self.next_status_wall = self.started_wall + STATUS_PERIOD_S
        if self.run_clock:
            self.thread = threading.Thread(target=self._run, name='pool_sim_clock',
                                           daemon=True)
            self.thread.start()

    def stop(self):
        if self.thread is not None:
            self.stopping.set()
            self.wake.set()
            self.thread.join(timeout=5.0)

    def restart(self):
        """Time starts again (at start-up and after a reset): time 0 is published as it
        starts, nothing is owed."""
        self.next_publish_time = self.publish_period
        self.backlog_s = 0.0
        self.last_wall = time.monotonic()

    def spheres_changed(self):
        """A spawn or remove: the cost of a step is measured anew (the build changed)."""
        self.step_cost_s = None

    def _run(self):
        # The physics loop on one thread, this one (numba's thread count is per calling
        # thread: set here, not where the node was built): the machine's other cores serve
        # DDS, the executor and the subscribers.
        stepper.use_threads(1)
        while not self.stopping.is_set():
            behind = False
            try:
                with self.node.lock():
                    behind = self.tick()
            except Exception as error:  # a fault must not stop the clock: say it, go on
                if not self.node.context.ok():
                    return
                self.node.get_logger().error(f'a tick raised {type(error).__name__}: {error}',
                                             throttle_duration_sec=THROTTLE_S)
            # Behind, the next tick comes once services have had the lock, not a whole
            # period later: waiting the period after a full budget left the node idle
            # for most of the wall time it had no time to spare (RTF 0.21 at 10 000
            # colliding spheres, physics a third of the wall time).
            self.wake.wait(TICK_PERIOD_RANGE_S[0] if behind else self.tick_period)
            self.wake.clear()

    # -- ticks -------------------------------------------------------------------------------

    def tick(self) -> bool:
        """Steps owed since the last tick, within TICK_BUDGET_S. Returns whether steps are
        still owed when the budget ran out (the node is behind real_time_factor)."""
        now = time.monotonic()
        elapsed, self.last_wall = now - self.last_wall, now
        simulation = self.node.simulation
        if self.paused:
            self.inputs.apply(simulation)
            self._republish_if_quiet()
            return False
        # Looked at before the inputs are applied: every answer that made it ready is.
        answered = self.ready()
        self.inputs.apply(simulation)
        if not answered:
            return False  # waiting is not falling behind: nothing owed for it
        dt = simulation.max_step
        steps_before = self.steps_taken
        deadline = now + TICK_BUDGET_S
        if self.real_time_factor > 0:
            self.backlog_s += elapsed * self.real_time_factor
            # Bounded by the budget: a real_time_factor the machine cannot reach leaves the
            # rest owed, never a tick that blocks services. In lockstep a publish ends the
            # tick's steps (going_on is False then).
            going_on = True
            while self.backlog_s >= dt * (1.0 - 1e-9) and time.monotonic() < deadline:
                owed_steps = max(int(self.backlog_s / dt * (1.0 + 1e-9)), 1)
                going_on, taken = self._steps(owed_steps, deadline)
                self.backlog_s -= taken * dt
                if not going_on:
                    break
            # What the budget left owed beyond the catch-up bound is given up: a tick that
            # came late (the thread held up by a full collection, a busy core, a long
            # request) makes up its lateness within its budget and gives up nothing.
            limit = max(2.0 * dt, MAX_BACKLOG_WALL_S * self.real_time_factor)
            self.given_up_s += max(self.backlog_s - limit, 0.0)
            self.backlog_s = min(self.backlog_s, limit)
            behind = going_on and self.backlog_s >= dt * (1.0 - 1e-9)
        else:
            behind = False  # as fast as it can: every tick is
            while time.monotonic() < deadline and self._steps(None, deadline)[0]:
                pass
        if self.steps_taken > steps_before:
            self.publishing.publish_clock()
        self.diagnostics.report_recovered()
        self._republish_if_quiet()
        return behind

    def _republish_if_quiet(self):
        """The instant published last again, when it went out QUIET_REPUBLISH_S ago and
        time has not moved since: while paused (as always), and at a pace so slow that no
        step is owed yet (real_time_factor 1e-12). Never a state between two instants, and
        in lockstep only while paused: lockstep sends its own copies of what it awaits."""
        publishing = self.publishing
        if time.monotonic() - publishing.last_publish_wall < QUIET_REPUBLISH_S:
            return
        still = publishing.last_instant_s == self.node.simulation.time
        if self.paused or (still and not self.lockstep.enabled):
            publishing.publish_state(new_listeners=True)

    def advance(self) -> bool:
        """Step to the next publish instant and publish it (with /clock), whether paused or
        not and without waiting for lockstep answers; inputs that came are applied first.
        False when simulated time cannot go on (the end of ROS stamps)."""
        with self.node.lock():
            self.inputs.apply(self.node.simulation)
            publishes = self.publishing.publishes
            while self.publishing.publishes == publishes:
                if not self._steps(None, None)[0] and self.publishing.publishes == publishes:
                    return False  # the end of ROS stamps
            self.publishing.publish_clock()
            self.diagnostics.report_recovered()
            return True

    def ready(self) -> bool:
        """True when the instant published last is answered by every lockstep input (or
        timed out, or lockstep is off): then advance() may go on. While it waits, the
        instant's state goes out again now and then, for controllers that came late."""
        with self.node.lock():
            if self.lockstep.ready(self.inputs):
                return True
            if (self.lockstep.republish_due()
                    and not self.inputs.any_unstamped(self.lockstep.waiting)):
                self.publishing.publish_state(new_listeners=True)
            return False

    def on_answer(self):
        """On the executor's thread, after each input: in lockstep, go on at once."""
        if self.lockstep.awaited_ns is None or self.thread is None:
            return
        if self.real_time_factor > 0 or self.paused:
            self.wake.set()  # pacing is the clock thread's
            return
        # As fast as possible: the answer that completes the instant runs the next period
        # right here, sparing the hand-over to the clock thread (half a millisecond of a
        # period's two). Bounded as every tick is (TICK_BUDGET_S); the clock thread still
        # keeps the timeouts. A fault is said and the input goes on, as on the clock.
        with self.node.lock():
            if threading.get_ident() not in self._one_thread:
                stepper.use_threads(1)  # per calling thread, as on the clock thread
                self._one_thread.add(threading.get_ident())
            try:
                self.tick()
            except Exception as error:
                self.node.get_logger().error(f'a tick raised {type(error).__name__}: {error}',
                                             throttle_duration_sec=THROTTLE_S)

    def _steps(self, limit, deadline):
        """Physics steps in one compiled call, up to the next publish (and that publish),
        at most `limit` (None: no limit) and as many as fit before the wall-clock
        `deadline` (monotonic s; None: no deadline) at the cost measured so far.

        Returns (going_on, steps taken): going_on is False when time cannot go on, or when
        it published an instant lockstep now waits on."""
        simulation = self.node.simulation
        dt = simulation.max_step
        if simulation.time + dt > LAST_STAMP_S:
            # builtin_interfaces/Time counts seconds in an int32: 68 years of simulated time.
            self.set_paused(True)
            self.stamp_limit_reached = True
            self.node.get_logger().error(
                f'simulated time reached {simulation.time:.0f} s, the last a ROS time stamp '
                'can carry (2^31 s): paused; ~/reset starts again from 0')
            return False, 0
        self.inputs.release_expired(simulation, self.wrench_timeout)
        steps = steps_to_instant(self.next_publish_time, simulation.time, dt)
        steps = max(min(steps, int((LAST_STAMP_S - simulation.time) / dt)), 1)
        if limit is not None:
            steps = min(steps, limit)
        expiry = self.inputs.first_expiry(self.wrench_timeout)
        if expiry < math.inf:  # no step past the first expiry
            steps = min(steps, max(math.floor((expiry - simulation.time) / dt) + 1, 1))
        if deadline is not None:
            # At the cost per step of the last call: the first, and one that compiled a
            # build, take a step alone and the next goes on from their measure.
            affordable = (1 if self.step_cost_s is None
                          else (deadline - time.monotonic()) / max(self.step_cost_s, 1e-9))
            steps = min(steps, max(int(affordable), 1))
        started = time.perf_counter()
        simulation.run(steps, dt)
        spent = time.perf_counter() - started
        self.step_cost_s = spent / steps
        self.physics_s += spent
        self.steps_taken += steps
        self.simulated_s += steps * dt
        if simulation.time >= self.next_publish_time - 1e-9:
            self.publishing.publish_state()
            self.next_publish_time = next_instant(self.next_publish_time,
                                                  self.publish_period, simulation.time)
            return self.lockstep.awaited_ns is None, steps
        return True, steps

    # -- pause -------------------------------------------------------------------------------

    def set_paused(self, paused: bool):
        now = time.monotonic()
        if paused and not self.paused:
            self.paused_since = now
        elif not paused and self.paused:
            self.paused_wall_s += now - self.paused_since
            self.paused_since = None
            self.last_wall = now  # paused time is not owed
            self.lockstep.restart_wait()  # nor does it count against lockstep_timeout
        self.paused = paused

    # -- the status line ---------------------------------------------------------------------

    def running_wall_s(self) -> float:
        """Wall seconds since start, less the time spent paused."""
        now = time.monotonic()
        paused = self.paused_wall_s + (now - self.paused_since if self.paused_since else 0.0)
        return max(now - self.started_wall - paused, 1e-9)

    def time_report(self) -> str:
        """Where the wall time went since start; part of the status line every 5 s. The
        real-time factor counts running time only: paused time is no falling behind."""
        wall = self.running_wall_s()
        spent = {'physics': self.physics_s, **self.publishing.time_spent}
        parts = ', '.join(f'{name} {seconds / wall:.1%}' for name, seconds in spent.items())
        return (f'{self.simulated_s:.2f} s simulated in {wall:.2f} s running '
                f'(real-time factor {self.simulated_s / wall:.3f}), {self.steps_taken} '
                f'steps, {self.publishing.publishes} publishes '
                f'({self.publishing.odometry_sender.dropped} odometry sets left out for slow '
                f'subscribers), {self.given_up_s:.2f} s given up to the catch-up bound, '
                f'{self.node.simulation.recoveries} put-backs by the step '
                f'guard{self.lockstep.report()}; wall time in {parts}'
                + ''.join(f'; {report()}' for report in self.reports))

    def _log_status_when_due(self, published):
        if time.monotonic() < self.next_status_wall:
            return
        self.next_status_wall = time.monotonic() + STATUS_PERIOD_S
        spheres = self.node.simulation.spheres
        heights = [f'{name} z={z:.2f} m' for name, z in zip(
            spheres.names[:NAMES_SHOWN], spheres.position[2, :NAMES_SHOWN].tolist())]
        self.node.get_logger().info(f't={published.time_s:.1f} s: '
                                    f'{named_few(heights, spheres.count)}. {self.time_report()}')
