"""Every service of a node answers every request, rclpy's own parameter services too.

rclpy's set_parameters services raise on a value of an unknown type code, and an exception
in a callback ends the node: here such an entry is refused with a reason, a request too big
for one callback is refused whole, and whatever else a callback raises is logged and
refused.
"""
from rcl_interfaces.msg import SetParametersResult
from rcl_interfaces.srv import SetParameters, SetParametersAtomically
from rclpy.parameter import Parameter

from pool_sim.physics.spheres import shortened, shown

# Wall seconds between two error lines of the same kind.
THROTTLE_S = 1.0
KNOWN_PARAMETER_TYPES = frozenset(t.value for t in Parameter.Type)
# The most entries one request may carry: every entry of a set is applied in the request's
# callback (about 0.25 ms each), every name of a read looked up. The clock runs on its own
# thread meanwhile, but shares the interpreter: a `ros2 param load` of a dump of 12 500
# spheres (8 keys each) still fits, a request of millions is refused at once.
MAX_SET_ENTRIES = 100_000
MAX_READ_NAMES = 1_000_000


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


def guard_services(node, around_set_parameters=None):
    """Every service of `node`, rclpy's parameter services too, answers every request.

    rclpy's set_parameters services raise on a value of an unknown type code and the
    exception ends the node: here such an entry is refused with a reason (and, atomically,
    the whole request). Whatever else a callback raises is logged and refused: a request
    never takes the node down. around_set_parameters(callback) -> callback: the node's own
    handling of a whole set_parameters request, around rclpy's entry by entry, inside the
    guards.
    """
    for service in node.services:
        callback, service_type = service.callback, service.srv_type
        if service_type is SetParameters and service.srv_name.endswith('/set_parameters'):
            callback = _per_entry_with_known_types(callback, node)
            if around_set_parameters is not None:
                callback = around_set_parameters(callback)
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


def _per_entry_with_known_types(callback, node=None):
    def set_parameters(request, response):
        for entry in request.parameters:
            if entry.value.type in KNOWN_PARAMETER_TYPES:
                try:
                    one = callback(SetParameters.Request(parameters=[entry]),
                                   SetParameters.Response())
                except Exception as error:  # this entry's result: those before it stand
                    reason = (f'{shortened(entry.name)}: raised {type(error).__name__}: '
                              f'{shown(str(error))}')
                    if node is not None:
                        node.get_logger().error(reason, throttle_duration_sec=THROTTLE_S)
                    response.results.append(SetParametersResult(successful=False,
                                                                reason=reason))
                    continue
                response.results.extend(one.results)
            else:
                response.results.append(SetParametersResult(
                    successful=False, reason=unknown_type_reason(entry)))
        return response
    return set_parameters


def unknown_type_refusal(entries, nothing='nothing'):
    """The refusal of an all-or-nothing request with an entry of unknown type code, or
    None when every entry's type is known."""
    for entry in entries:
        if entry.value.type not in KNOWN_PARAMETER_TYPES:
            return SetParametersResult(successful=False,
                                       reason=f'{unknown_type_reason(entry)}; {nothing} was set')
    return None


def _atomic_with_known_types(callback):
    def set_parameters_atomically(request, response):
        refused = unknown_type_refusal(request.parameters)
        if refused is not None:
            response.result = refused
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
