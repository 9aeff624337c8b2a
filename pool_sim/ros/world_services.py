"""The node's world services: ~/set_mass, ~/set_radius, ~/reset, ~/pause and ~/step."""
from functools import partial

from rcl_interfaces.msg import SetParametersResult
from rcl_interfaces.srv import SetParameters
from rclpy.parameter import parameter_value_to_python
from rclpy.qos import QoSProfile, ReliabilityPolicy
from std_srvs.srv import SetBool, Trigger

from pool_sim.physics import InvalidInput
from pool_sim.ros.parameters import LIVE_SPHERE_KEYS
from pool_sim.ros.services import KNOWN_PARAMETER_TYPES, unknown_type_reason

# Requests a service queues before DDS drops one: many clients at once must all be answered.
SERVICE_QOS = QoSProfile(depth=1000, reliability=ReliabilityPolicy.RELIABLE)
STAMP_LIMIT_REACHED = 'at the last time a ROS stamp can carry (2^31 s)'


class WorldServices:
    """The services of `node`; each runs under the node's lock, between two ticks."""

    def __init__(self, node, clock, parameter_changes, publishing, inputs, lockstep):
        self.node, self.clock, self.parameter_changes = node, clock, parameter_changes
        self.publishing, self.inputs, self.lockstep = publishing, inputs, lockstep
        node.create_service(SetParameters, '~/set_mass', partial(self._on_set_sphere, 'mass'),
                            qos_profile=SERVICE_QOS)
        node.create_service(SetParameters, '~/set_radius',
                            partial(self._on_set_sphere, 'radius'), qos_profile=SERVICE_QOS)
        node.create_service(Trigger, '~/reset', self._on_reset, qos_profile=SERVICE_QOS)
        node.create_service(SetBool, '~/pause', self._on_pause, qos_profile=SERVICE_QOS)
        node.create_service(Trigger, '~/step', self._on_step, qos_profile=SERVICE_QOS)

    def _on_set_sphere(self, key, request, response):
        """Each entry: name = sphere, value = new mass (kg) or radius (m); a result each.
        Each value is checked once, by the core; those accepted are applied together."""
        with self.node.lock():
            results, accepted = [], []
            for entry in request.parameters:
                results.append(self._check_sphere_entry(key, entry, accepted))
            if accepted:
                self.parameter_changes.set_checked(accepted)
        done = SetParametersResult(successful=True)
        response.results = [done if result is None else result for result in results]
        return response

    def _check_sphere_entry(self, key, entry, accepted):
        """A refusal, or None with (sphere, CheckedChange) appended to accepted."""
        if entry.value.type not in KNOWN_PARAMETER_TYPES:
            return SetParametersResult(successful=False, reason=unknown_type_reason(entry))
        try:
            value = parameter_value_to_python(entry.value)
            if isinstance(value, int) and not isinstance(value, bool):
                value = float(value)  # kept a double, so the parameter keeps one type
            accepted.append((entry.name,
                             self.node.simulation.check_change(entry.name, key, value)))
        except InvalidInput as error:
            return SetParametersResult(successful=False, reason=str(error))
        return None

    def _on_reset(self, request, response):
        with self.node.lock():
            self.inputs.clear()  # forces sent before the reset do not outlive it
            self.lockstep.forget()
            simulation = self.node.simulation
            before = {key: getattr(simulation.spheres, key).copy() for key in LIVE_SPHERE_KEYS}
            simulation.reset()
            self.clock.restart()
            if self.clock.stamp_limit_reached:  # paused at the end of ROS time stamps: go on
                self.clock.set_paused(False)
                self.clock.stamp_limit_reached = False
            self.parameter_changes.show_initial_values(before)
            self.publishing.publish_state()
        response.success, response.message = True, 'back to the initial scene at time 0'
        return response

    def _on_step(self, request, response):
        """While paused: one publish period on, that instant published, then the answer
        (with the new simulated time). Lockstep answers are not waited for here (they come
        through the executor that runs this service): it applies what has arrived."""
        with self.node.lock():
            if not self.clock.paused or self.clock.stamp_limit_reached:
                response.success = False
                response.message = (
                    f'{STAMP_LIMIT_REACHED}; call ~/reset' if self.clock.stamp_limit_reached
                    else 'not paused: ~/step advances a paused simulation by one publish '
                    'period; pause it first (~/pause true)')
                return response
            started = self.node.simulation.time
            response.success = self.clock.advance()
            response.message = (f'stepped from t={started:.9f} s to '
                                f't={self.node.simulation.time:.9f} s' if response.success
                                else f'{STAMP_LIMIT_REACHED}: not stepped; call ~/reset')
        return response

    def _on_pause(self, request, response):
        with self.node.lock():
            if not request.data and self.clock.stamp_limit_reached:
                response.success = False
                response.message = (f'paused {STAMP_LIMIT_REACHED}; call ~/reset to start '
                                    'again from 0')
                return response
            self.clock.set_paused(bool(request.data))
        response.success = True
        response.message = 'paused' if self.clock.paused else 'running'
        return response
