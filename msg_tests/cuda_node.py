"""The node on either backend, in lockstep, driven through its topics and services: the
depth keeper's forces hold ice at 1 m while set_mass and set_radius change the cork and
a reset starts over; for test_cuda_backend.

    python -m cuda_node OUT.npz   # backend cuda (in numba's CUDA simulator, for the tests)
"""
import sys

import numpy as np
from rcl_interfaces.msg import Parameter as ParameterMessage, ParameterType, ParameterValue
from rcl_interfaces.srv import SetParameters
from rclpy.parameter import Parameter
from std_srvs.srv import Trigger

from pool_sim.ros.depth_keeper import DepthKeeper
from pool_sim.testing import PoolSim


def number(name, value):
    return ParameterMessage(name=name, value=ParameterValue(
        type=ParameterType.PARAMETER_DOUBLE, double_value=value))


def drive(backend):
    """{label: (n, 6) states, or a service's answers}: after each stage of a closed loop
    on this backend."""
    kept = {}
    with PoolSim({'backend': backend, 'lockstep_inputs': ['ice'],
                  'wrench_timeout': 0.0}) as sim:
        sim.add(DepthKeeper, parameter_overrides=[Parameter('target_depth', value=1.0)])
        sim.advance(1.0)
        kept['kept'] = sim.states()
        answers = [sim.call(SetParameters, service, SetParameters.Request(
            parameters=[number('cork', value)])).results[0].successful
            for service, value in (('set_mass', 0.5), ('set_radius', 0.2))]
        kept['answers'] = np.array(answers)
        sim.advance(1.0)
        kept['changed'] = sim.states()
        sim.call(Trigger, 'reset', Trigger.Request())
        sim.advance(0.5)
        kept['reset'] = sim.states()
    return kept


if __name__ == '__main__':
    np.savez(sys.argv[1], **drive('cuda'))
