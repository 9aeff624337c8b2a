"""depth_keeper: holds one sphere at a depth by publishing forces, as any other node could.

Reads `pool_sim/<sphere>/odom` and answers each odometry message with a force on
`pool_sim/wrench` (WrenchStamped: frame_id the sphere, stamp the odometry's), so it works in
pool_sim's lockstep out of the box (names relative to this node's namespace, so remap them
like any topic). A PD law on the height error, with an
optional integral term (ki, default 0) that removes the offset a net weight or buoyancy
leaves: with PD alone the sphere settles (net force) / kp away from the target. The integral
term (ki times the integrated error) is kept within max_force, so it cannot wind up.

Every parameter is checked the same way at start-up and on `ros2 param set`: numbers may be
given as integers, a wrong type or a value out of its range is refused naming the key and
what is allowed (at start-up the node stops with exit code 1). Setting `sphere` while running
lets go of the old sphere (one zero wrench) and holds the new one.
"""
import math
import sys
import time

from builtin_interfaces.msg import Time
from geometry_msgs.msg import WrenchStamped
from nav_msgs.msg import Odometry
from rcl_interfaces.msg import FloatingPointRange, ParameterDescriptor, SetParametersResult
from rclpy.clock import Clock, ClockType
from rclpy.duration import Duration
from rclpy.node import Node
from rclpy.parameter import Parameter

from pool_sim.physics.spheres import NAME_MAX_CHARACTERS, NAME_TOKEN, shown
from pool_sim.ros.executables import run_node

GAIN_MAX = 1e9
FORCE_MAX_N = 1e9
HEIGHT_MAX_M = 1e4
NAME_RULE = (f"a ROS name token: a letter or '_', then letters, digits or '_', no '__', "
             f'at most {NAME_MAX_CHARACTERS} characters')
# Each term of the law is clipped to this before they are added, so their sum cannot overflow
# (inf - inf = NaN) even for absurd odometry; no physical input comes near it.
TERM_LIMIT = 1e300


class InvalidParameter(ValueError):
    """A parameter value the keeper refuses; the message names the key and what is allowed."""


class Number:
    """A numeric parameter: a finite float in [low, high] (or (low, high] when low_open)."""

    def __init__(self, default, low, high, unit, description, low_open=False):
        self.default, self.low, self.high, self.unit = default, low, high, unit
        self.description, self.low_open = description, low_open

    def allowed(self):
        low, high = _number(self.low), _number(self.high)
        if self.low_open:
            return f'a number > {low} and <= {high} {self.unit}'
        return f'a number from {low} to {high} {self.unit}'

    def check(self, name, value):
        if isinstance(value, bool) or not isinstance(value, (int, float)):
            raise InvalidParameter(f'{name}: expected {self.allowed()}, got {_shown(value)}')
        try:
            number = float(value)
        except OverflowError:  # an int beyond any float
            number = math.copysign(math.inf, value)
        too_low = number <= self.low if self.low_open else number < self.low
        if not math.isfinite(number) or too_low or number > self.high:
            raise InvalidParameter(f'{name}: must be {self.allowed()}, got {value!r}')
        return number

    def descriptor(self):
        return ParameterDescriptor(
            description=f'{self.description} ({self.allowed()}; an integer is fine)',
            additional_constraints=self.allowed(), dynamic_typing=True,
            floating_point_range=[FloatingPointRange(
                from_value=self.low, to_value=self.high, step=0.0)])


class Name:
    """A string parameter that must be one ROS name token (a sphere's name)."""

    def __init__(self, default, description):
        self.default, self.description = default, description

    def check(self, name, value):
        if not isinstance(value, str):
            raise InvalidParameter(f'{name}: expected {NAME_RULE}, got {_shown(value)}')
        if (not NAME_TOKEN.fullmatch(value) or '__' in value or len(value) > NAME_MAX_CHARACTERS):
            quoted = value if len(value) <= 40 else f'{value[:40]}... ({len(value)} characters)'
            raise InvalidParameter(f'{name}: must be {NAME_RULE}, got {quoted!r}')
        return value

    def descriptor(self):
        return ParameterDescriptor(description=self.description,
                                   additional_constraints=NAME_RULE, dynamic_typing=True)


PARAMETERS = {
    'sphere': Name('ice', "name of the sphere to hold, one of pool_sim's sphere_names"),
    'target_depth': Number(1.0, -HEIGHT_MAX_M, HEIGHT_MAX_M, 'm',
                           'depth of the sphere centre below surface_z, m'),
    'surface_z': Number(0.0, -HEIGHT_MAX_M, HEIGHT_MAX_M, 'm',
                        'height of the water surface, m'),
    'kp': Number(600.0, 0.0, GAIN_MAX, 'N/m', 'proportional gain, N/m'),
    'kd': Number(150.0, 0.0, GAIN_MAX, 'N*s/m', 'derivative gain on the vertical velocity'),
    'ki': Number(0.0, 0.0, GAIN_MAX, 'N/(m*s)', 'integral gain; 0 = pure PD'),
    'max_force': Number(2000.0, 0.0, FORCE_MAX_N, 'N', 'largest force it will publish',
                        low_open=True),
}


def check_parameter(name, value):
    """The value the keeper uses (numbers as floats); InvalidParameter if it is refused."""
    return PARAMETERS[name].check(name, value)


def _number(value):
    return f'{value:g}'.replace('e+0', 'e').replace('e+', 'e')


def _shown(value):
    """The value and its kind, for a refusal; a long one cut (core's `shown`)."""
    if value is None:
        return 'no value'
    if isinstance(value, bool):
        return f'{str(value).lower()} (a bool)'
    if isinstance(value, str):
        return f'{shown(value)} (a string)'
    if isinstance(value, (list, tuple)) or hasattr(value, 'tolist'):
        return f'{shown(list(value))} (an array)'
    return shown(value)


def _finite(odometry):
    pose, twist = odometry.pose.pose, odometry.twist.twist
    return all(math.isfinite(v) for vector in (pose.position, pose.orientation, twist.linear,
                                               twist.angular)
               for v in (vector.x, vector.y, vector.z, getattr(vector, 'w', 0.0)))


def _clip(value, limit):
    return max(-limit, min(limit, value))


class DepthKeeper(Node):
    """odometry_timeout_s: wall seconds without odometry before it warns (throttled to one
    warning per that many seconds)."""

    def __init__(self, odometry_timeout_s=5.0, **node_kwargs):
        super().__init__('depth_keeper', **node_kwargs)
        try:
            self.settings = self._declare()
        except BaseException:
            self.destroy_node()
            raise
        self.add_pre_set_parameters_callback(self._as_floats)
        self.add_on_set_parameters_callback(self._check_parameters)
        self.add_post_set_parameters_callback(self._apply_parameters)
        self.odometry_timeout_s = odometry_timeout_s
        self.publisher = self.create_publisher(WrenchStamped, 'pool_sim/wrench', 10)
        self.message = WrenchStamped()
        self.subscription = None
        self._wire(self.settings['sphere'])
        # Wall time, so it also warns under use_sim_time with no /clock.
        self.create_timer(min(0.5, odometry_timeout_s / 5), self._check_odometry_arrives,
                          clock=Clock(clock_type=ClockType.STEADY_TIME))

    def _declare(self):
        """Declare every parameter, check the values the overrides gave, then attach ranges.

        Declared first without ranges, so that rclpy's own range check does not refuse a
        value before ours can name the key and what is allowed."""
        declared = self.declare_parameters('', [
            (name, spec.default, ParameterDescriptor(dynamic_typing=True))
            for name, spec in PARAMETERS.items()])
        settings = {p.name: check_parameter(p.name, p.value) for p in declared}
        self.set_parameters([Parameter(name, value=value) for name, value in settings.items()])
        for name, spec in PARAMETERS.items():
            self.set_descriptor(name, spec.descriptor())
        return settings

    # `ros2 param set`: the same checks as at start-up.

    def _as_floats(self, parameters):
        """Integers for numeric parameters become floats, so each keeps one type."""
        converted = []
        for parameter in parameters:
            if (isinstance(PARAMETERS.get(parameter.name), Number)
                    and parameter.type_ == Parameter.Type.INTEGER):
                try:
                    parameter = Parameter(parameter.name, value=float(parameter.value))
                except OverflowError:
                    pass  # left for the check to refuse
            converted.append(parameter)
        return converted

    def _check_parameters(self, parameters):
        for parameter in parameters:
            if parameter.name not in PARAMETERS:
                continue
            try:
                check_parameter(parameter.name, parameter.value)
            except InvalidParameter as error:
                # rclpy has already set each dynamically typed descriptor's type to the new
                # value's; the value stays, so its type does too.
                for other in parameters:
                    if other.name in PARAMETERS:
                        self.describe_parameter(other.name).type = (
                            self.get_parameter(other.name).type_.value)
                return SetParametersResult(successful=False, reason=str(error))
        return SetParametersResult(successful=True)

    def _apply_parameters(self, parameters):
        sphere = self.settings['sphere']
        for parameter in parameters:
            if parameter.name in PARAMETERS:
                self.settings[parameter.name] = check_parameter(parameter.name, parameter.value)
        if self.settings['sphere'] != sphere:
            self._wire(self.settings['sphere'])

    def _wire(self, sphere):
        """Subscribe to the sphere's odometry, push it; let go of the previous one."""
        if self.subscription is not None:
            # Or the old sphere keeps our last force until pool_sim's wrench_timeout (0 = for
            # ever).
            self.destroy_subscription(self.subscription)
            self._publish_force(self.wired, 0.0, self.last_stamp_message)
            self.publisher.wait_for_all_acked(Duration(seconds=0.2))
        self.wired = sphere
        self.last_stamp_message = None  # the header stamp of the last odometry answered
        self.integral_force = 0.0  # ki * integral of the error, N
        self.last_stamp = None
        self.heard_since_wired = False
        self.last_heard = time.monotonic()
        self.next_warning = 0.0
        self.subscription = self.create_subscription(
            Odometry, f'pool_sim/{sphere}/odom', self._on_odometry, 10)
        self.get_logger().info(
            f'holding {sphere} at {_number(self.settings["target_depth"])} m depth')

    def _check_odometry_arrives(self):
        now = time.monotonic()
        quiet = now - self.last_heard
        if quiet < self.odometry_timeout_s or now < self.next_warning:
            return
        self.next_warning = now + self.odometry_timeout_s
        topic, sphere = self.subscription.topic_name, self.settings['sphere']
        if self.heard_since_wired:
            self.get_logger().warning(
                f'no odometry on {topic} for {quiet:.1f} s: has pool_sim stopped?')
        else:
            self.get_logger().warning(
                f"no odometry on {topic} after {quiet:.1f} s: is '{sphere}' one of "
                "pool_sim's sphere_names?")

    # The control law.

    def force_for(self, odometry):
        """The vertical force (N) for this odometry, or None when it is not finite."""
        if not _finite(odometry):
            return None
        p = self.settings
        limit = p['max_force']
        error = p['surface_z'] - p['target_depth'] - odometry.pose.pose.position.z
        stamp = odometry.header.stamp.sec + 1e-9 * odometry.header.stamp.nanosec
        if self.last_stamp is not None and stamp > self.last_stamp:
            # ki first: with ki = 0 the increment is 0 even if error * dt overflows. Kept
            # within the force limit (anti-windup), so it cannot grow past use or to inf.
            increment = p['ki'] * error * (stamp - self.last_stamp)
            self.integral_force = _clip(self.integral_force + increment, limit)
        self.last_stamp = stamp
        force = (_clip(p['kp'] * error, TERM_LIMIT)
                 - _clip(p['kd'] * odometry.twist.twist.linear.z, TERM_LIMIT)
                 + self.integral_force)
        return _clip(force, limit)

    def _on_odometry(self, odometry):
        self.last_heard, self.heard_since_wired = time.monotonic(), True
        force = self.force_for(odometry)
        if force is None:
            self.get_logger().warning(
                f'{self.subscription.topic_name}: odometry with a value that is not finite; '
                'no force published for it', throttle_duration_sec=5.0)
            return
        self.last_stamp_message = odometry.header.stamp
        self._publish_force(self.wired, force, odometry.header.stamp)

    def _publish_force(self, sphere, force_z, stamp):
        """A vertical force on `sphere`, stamped with the instant it answers (None: time 0,
        for the zero force that lets go of a sphere)."""
        message = self.message  # one message refilled: building one costs more than the law
        message.header.frame_id = sphere
        message.header.stamp = stamp if stamp is not None else Time()
        message.wrench.force.z = force_z
        self.publisher.publish(message)


def main(args=None):
    """`ros2 run pool_sim depth_keeper [--ros-args ...]`; exit code 1 for a bad parameter,
    0 on SIGINT or SIGTERM at any moment."""
    return run_node('depth_keeper', DepthKeeper, InvalidParameter, args)


if __name__ == '__main__':
    sys.exit(main())
