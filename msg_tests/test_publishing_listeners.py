"""A listener on the node's publishing hears every published instant, with the same
messages the subscribers get: what a recorder or a live viewer hangs on."""
from geometry_msgs.msg import PoseArray
from nav_msgs.msg import Odometry
from rclpy.serialization import deserialize_message
from rosgraph_msgs.msg import Clock
from std_msgs.msg import Float64MultiArray

from ros_harness import stamp_seconds


def test_a_listener_hears_every_instant_the_subscribers_get(pool_sim):
    sim = pool_sim({'lockstep_inputs': [], 'publish_clock': True, 'publish_rate_hz': 50.0})
    heard = []
    sim.node.publishing.listen(heard.append)
    received = []
    client = sim.add(lambda **kwargs: __import__('rclpy').create_node('client', **kwargs))
    client.create_subscription(Odometry, f'{sim.namespace}/pool_sim/cork/odom',
                               received.append, 100)
    sim.node.republish_state()  # the odometry subscriber is looked for anew
    for _ in range(10):
        sim.advance(0.02)
        sim.executor.spin_once(timeout_sec=0.05)
    states = [p for p in heard if p.messages[0][1] is PoseArray]
    clocks = [p for p in heard if p.messages[0][1] is Clock]
    assert len(states) == sim.node.publishing.publishes - 1  # all but the first, before
    assert len(clocks) == 10
    times = [p.time_s for p in states]
    assert times == sorted(times) and abs(times[-1] - sim.time) < 1e-12
    for published in states:
        topics = {topic: (kind, data) for topic, kind, data in published.messages}
        kind, data = topics[f'{sim.namespace}/pool_sim/poses']
        poses = deserialize_message(data, kind)
        assert stamp_seconds(poses.header) == published.stamp_ns * 1e-9
        states_message = deserialize_message(topics[f'{sim.namespace}/pool_sim/states'][1],
                                             Float64MultiArray)
        assert len(states_message.data) == 6 * len(poses.poses)
        assert topics[f'{sim.namespace}/pool_sim/cork/odom'][0] is Odometry
    last = deserialize_message(
        dict((t, d) for t, _, d in states[-1].messages)[f'{sim.namespace}/pool_sim/cork/odom'],
        Odometry)
    position, _ = sim.state('cork')
    assert last.pose.pose.position.z == position[2]
    assert received and received[-1].pose.pose.position.z == position[2]
    clock = deserialize_message(clocks[-1].messages[0][2], Clock)
    assert clock.clock.sec + 1e-9 * clock.clock.nanosec == clocks[-1].stamp_ns * 1e-9
