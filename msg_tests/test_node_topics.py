"""The node through real topics: poses, odometry, markers, scene markers, /clock, wrenches."""
import math

from geometry_msgs.msg import PoseArray, Wrench
from nav_msgs.msg import Odometry
import pytest
from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy
from rosgraph_msgs.msg import Clock
from visualization_msgs.msg import Marker, MarkerArray

from ros_harness import Harness, stamp_seconds

FAST = {'real_time_factor': 4.0}


def test_poses_come_in_order_in_the_frame_with_a_stamp_that_follows_simulation_time():
    with Harness({**FAST, 'frame_id': 'pool'}) as ros:
        poses = ros.collect(PoseArray, 'poses')
        assert ros.spin_until(lambda: len(poses) >= 10)
        first = poses[0]
        assert first.header.frame_id == 'pool'
        assert len(first.poses) == 3
        # sphere_names order: cork at x = -2, steel at 0, ice at 2.
        assert [round(p.position.x, 6) for p in first.poses] == [-2.0, 0.0, 2.0]
        stamps = [stamp_seconds(p.header) for p in poses]
        assert all(b > a for a, b in zip(stamps, stamps[1:]))
        # 30 messages per simulated second, whatever the real-time factor.
        gaps = [b - a for a, b in zip(stamps[1:], stamps[2:])]
        assert sum(gaps) / len(gaps) == pytest.approx(1 / 30, abs=0.003)
        assert stamps[-1] <= ros.sim.simulation.time + 1e-9


def test_odometry_matches_the_poses_of_the_same_instant():
    with Harness(FAST) as ros:
        poses = ros.collect(PoseArray, 'poses')
        odometry = ros.collect(Odometry, 'ice/odom')
        assert ros.spin_until(lambda: len(poses) >= 20 and len(odometry) >= 20)
        by_stamp = {stamp_seconds(p.header): p.poses[2].position for p in poses}
        matched = 0
        for message in odometry:
            assert message.child_frame_id == 'ice' and message.header.frame_id == 'world'
            position = by_stamp.get(stamp_seconds(message.header))
            if position is not None:
                matched += 1
                assert message.pose.pose.position == position
        assert matched >= 10
        # The twist is the velocity the positions move with: the mean of two successive
        # velocities times the gap equals the displacement, to the integrator's step error.
        for a, b in zip(odometry, odometry[1:]):
            gap = stamp_seconds(b.header) - stamp_seconds(a.header)
            if 0.0 < gap < 0.05:
                moved = b.pose.pose.position.z - a.pose.pose.position.z
                mean_velocity = 0.5 * (a.twist.twist.linear.z + b.twist.twist.linear.z)
                assert moved == pytest.approx(mean_velocity * gap, abs=0.02 * gap)


def test_markers_are_one_sphere_each_sized_by_diameter_and_the_scene_is_latched():
    with Harness(FAST) as ros:
        markers = ros.collect(MarkerArray, 'markers')
        latched = QoSProfile(depth=1, durability=DurabilityPolicy.TRANSIENT_LOCAL,
                             reliability=ReliabilityPolicy.RELIABLE)
        ros.spin_for(0.3)  # subscribe late: a latched topic still delivers
        scene = ros.collect(MarkerArray, 'scene_markers', latched)
        assert ros.spin_until(lambda: markers and scene)
        spheres = markers[-1].markers
        assert [(m.ns, m.id, m.type) for m in spheres] == [('spheres', i, Marker.SPHERE)
                                                            for i in range(3)]
        assert [m.scale.x for m in spheres] == pytest.approx([0.4, 0.2, 0.3])
        assert len({(m.color.r, m.color.g, m.color.b) for m in spheres}) == 3
        namespaces = {m.ns: m for m in scene[0].markers}
        assert namespaces['pool'].type == Marker.LINE_LIST
        assert len(namespaces['pool'].points) == 24  # 12 edges
        water = namespaces['water']
        assert water.scale.z == pytest.approx(4.0) and 0.0 < water.color.a < 1.0


@pytest.mark.parametrize('publish_clock', [True, False])
def test_clock_is_published_only_when_asked(publish_clock):
    with Harness({**FAST, 'publish_clock': publish_clock}) as ros:
        clock = []
        ros.client.create_subscription(Clock, '/clock', clock.append, 10)
        poses = ros.collect(PoseArray, 'poses')
        # 30 poses = 1 simulated second, 200 physics ticks that could each have sent /clock.
        assert ros.spin_until(lambda: len(poses) >= 30)
        if publish_clock:
            assert ros.spin_until(lambda: len(clock) >= 5)
            times = [c.clock.sec + 1e-9 * c.clock.nanosec for c in clock]
            assert all(b > a for a, b in zip(times, times[1:]))
            assert times[-1] <= ros.sim.simulation.time + 1e-9
        else:
            assert clock == []


NEUTRAL_BALL = {
    'sphere_names': ['ball'], 'ball.radius': 0.1,
    'ball.mass': 1000.0 * 4.0 / 3.0 * math.pi * 0.1**3,  # neutral: rests anywhere in water
    'ball.position': [0.0, 0.0, -2.0], 'effects': ['gravity', 'buoyancy', 'contact'],
    'physics_rate_hz': 1000.0, 'publish_rate_hz': 50.0, 'wrench_timeout': 0.5,
    'real_time_factor': 2.0,
}


def test_a_constant_wrench_moves_a_sphere_as_newton_says_then_times_out():
    force = 2.0
    acceleration = force / NEUTRAL_BALL['ball.mass']
    with Harness(NEUTRAL_BALL) as ros:
        odometry = ros.collect(Odometry, 'ball/odom')
        wrench = ros.client.create_publisher(Wrench, ros.topic('ball/wrench'), 10)
        assert ros.spin_until(lambda: len(odometry) >= 3)
        message = Wrench()
        message.force.x = force
        wrench.publish(message)
        sent_at = ros.sim.simulation.time
        assert ros.spin_until(lambda: stamp_seconds(odometry[-1].header) > sent_at + 1.5)

    def state(m):
        return stamp_seconds(m.header), m.pose.pose.position.x, m.twist.twist.linear.x
    samples = [state(m) for m in odometry]
    pushed = [s for s in samples if s[2] > 0.0]
    start = pushed[0][0]
    during = [s for s in pushed if s[0] < start + 0.45]
    (t1, x1, v1), (t2, x2, v2) = during[0], during[-1]
    assert t2 - t1 > 0.3
    assert (v2 - v1) / (t2 - t1) == pytest.approx(acceleration, rel=0.02)
    assert x2 - x1 == pytest.approx(v1 * (t2 - t1) + 0.5 * acceleration * (t2 - t1)**2,
                                    rel=0.02)
    # After wrench_timeout of simulated time with no message, the force is gone.
    after = [s for s in samples if s[0] > start + 0.55]
    assert len(after) >= 10
    assert after[-1][2] == pytest.approx(after[0][2], rel=1e-9)
    assert after[-1][2] == pytest.approx(acceleration * 0.5, rel=0.05)


def test_a_nan_or_infinite_wrench_is_refused_and_the_node_keeps_publishing():
    with Harness(NEUTRAL_BALL) as ros:
        poses = ros.collect(PoseArray, 'poses')
        wrench = ros.client.create_publisher(Wrench, ros.topic('ball/wrench'), 10)
        assert ros.spin_until(lambda: len(poses) >= 2)
        for bad in (math.nan, math.inf, -math.inf):
            message = Wrench()
            message.force.x, message.force.z = 1.0, bad
            wrench.publish(message)
        count = len(poses)
        assert ros.spin_until(lambda: len(poses) >= count + 20)
        assert all(math.isfinite(v) for v in ros.sim.simulation.spheres.position.ravel())
        assert (ros.sim.simulation.spheres.external_force == 0.0).all()
        position = poses[-1].poses[0].position
        assert (position.x, position.y, position.z) == pytest.approx((0.0, 0.0, -2.0), abs=1e-9)
