"""A state goes out only at a publish instant, again only as the same instant: a republish
for late subscribers never sends the state between two instants, and lockstep never waits
on one that is not on the grid (found in review: a first republish rule did both at 0.5 Hz
publishing, where a period takes two wall seconds)."""
import rclpy
from geometry_msgs.msg import PoseArray
from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy
from std_msgs.msg import Float64MultiArray

from pool_sim.testing import PoolSim
from ros_harness import stamp_seconds

QOS = QoSProfile(depth=10, durability=DurabilityPolicy.TRANSIENT_LOCAL,
                 reliability=ReliabilityPolicy.RELIABLE)
PERIOD_S = 2.0  # 0.5 Hz publishing at real_time_factor 1: a period is two wall seconds


def off_grid(stamps):
    return [t for t in stamps if abs(t / PERIOD_S - round(t / PERIOD_S)) > 1e-6]


def run(scene, lockstep, answer_off_grid):
    """Stamps of ~/poses over 4.6 wall s, a client answering on ~/forces (every state, or
    only those on the grid), and the lockstep misses."""
    with PoolSim({'publish_rate_hz': 1.0 / PERIOD_S, 'wrench_timeout': 0.0, **scene},
                 lockstep=lockstep, run_clock=True, executor='single') as sim:
        client = sim.add(rclpy.create_node('client', namespace=sim.namespace,
                                           context=sim.context))
        answer = client.create_publisher(Float64MultiArray, f'{sim.namespace}/pool_sim/forces',
                                         10)
        stamps = []

        def on_pose(message):
            stamps.append(stamp_seconds(message.header))
            if answer_off_grid or not off_grid(stamps[-1:]):
                answer.publish(Float64MultiArray(data=[0.0] * 9))
        client.create_subscription(PoseArray, f'{sim.namespace}/pool_sim/poses', on_pose, QOS)
        sim.spin(lambda: False, 4.6)
        return stamps, sim.node.lockstep.misses


def test_without_lockstep_states_go_out_only_at_publish_instants():
    stamps, _ = run({}, False, True)
    assert len(stamps) >= 2 and off_grid(stamps) == []


def test_lockstep_waits_only_on_publish_instants():
    stamps, misses = run({'lockstep_inputs': ['forces'], 'lockstep_timeout': 0.5}, True, False)
    assert len(stamps) >= 2 and off_grid(stamps) == []
    assert misses == 0
