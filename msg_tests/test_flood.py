"""The node survives a flood of wrenches, a tenth of them NaN: it keeps stepping and
publishing and no NaN reaches the state. (How fast it stays is benchmarks/flood.py's job.)"""
import math

from geometry_msgs.msg import PoseArray, Wrench
import numpy as np

from ros_harness import Harness

SPHERES = ['a', 'b', 'c', 'd']
PARAMS = {'sphere_names': SPHERES, 'real_time_factor': 1.0,
          **{f'{name}.position': [i - 1.5, 0.0, -1.0] for i, name in enumerate(SPHERES)},
          **{f'{name}.mass': 2.0 for name in SPHERES}}


def test_a_flood_with_nan_wrenches_leaves_the_node_publishing_finite_states():
    with Harness(PARAMS) as ros:
        poses = ros.collect(PoseArray, 'poses')
        publishers = [ros.client.create_publisher(Wrench, ros.topic(f'{name}/wrench'), 10)
                      for name in SPHERES]
        assert ros.spin_until(lambda: len(poses) >= 3)
        received_before = len(poses)
        time_before = ros.sim.simulation.time
        message, sent = Wrench(), 0
        while sent < 8000:  # 2 000 a sphere, as fast as this thread can send them
            for publisher in publishers:
                sent += 1
                message.force.x = math.nan if sent % 10 == 0 else 3.0
                publisher.publish(message)
            if sent % 400 == 0:
                ros.executor.spin_once(timeout_sec=0.0)
        assert ros.spin_until(lambda: len(poses) >= received_before + 30, timeout_s=10.0)
        assert ros.sim.simulation.time > time_before + 0.5
        state = ros.sim.simulation.spheres
        assert np.all(np.isfinite(state.position)) and np.all(np.isfinite(state.velocity))
        assert np.all(np.isfinite(state.external_force))
        assert all(math.isfinite(p.position.x) for m in poses for p in m.poses)
