"""Controllers for the lockstep tests and benchmark (nodes a user could write), and the
loop they run in-process and across processes."""
from collections import defaultdict, deque
import hashlib
import os
from pathlib import Path
import subprocess
import sys
import time

import numpy as np
import rclpy
from rclpy.context import Context
from geometry_msgs.msg import PoseArray, WrenchStamped
from rclpy.node import Node
from std_msgs.msg import Float64MultiArray

from pool_sim.ros.depth_keeper import DepthKeeper
from pool_sim.testing import make_executor

REPO = Path(__file__).resolve().parents[1]
# The default pool in lockstep with depth_keeper (ice) and a Recorder (cork), as a params
# file: the loop compared in-process and across processes.
LOCKSTEP_PARAMS = '''/**:
  ros__parameters:
    lockstep: true
    lockstep_inputs: [ice, cork]
    lockstep_timeout: 60.0
    real_time_factor: 0.0
    wrench_timeout: 0.0
'''
UNTIL_NS = 20 * 1_000_000_000


class Recorder(Node):
    """Answers one sphere's lockstep input with a zero force stamped with the instant, once
    it holds that instant's poses and states: so it sees every instant, and keeps
    (stamp ns, the states' bytes) of each in `instants`."""

    def __init__(self, answers='cork', **node_kwargs):
        super().__init__('recorder', **node_kwargs)
        self.answers = answers
        self.instants = []  # (stamp ns, bytes of ~/states' data), one per instant
        # The two topics may arrive in either order; a states message belongs to the
        # PoseArray with its positions (bytes of the (n, 3) positions -> stamps or states
        # waiting, in arrival order: settled spheres repeat their positions exactly).
        self.stamp_of, self.states_of = defaultdict(deque), defaultdict(deque)
        self.create_subscription(PoseArray, 'pool_sim/poses', self._on_poses, 10)
        self.create_subscription(Float64MultiArray, 'pool_sim/states', self._on_states, 10)
        self.publisher = self.create_publisher(WrenchStamped, 'pool_sim/wrench', 10)

    def _on_poses(self, message):
        stamp = message.header.stamp
        key = np.array([(p.position.x, p.position.y, p.position.z) for p in message.poses],
                       dtype=float).tobytes()
        self.stamp_of[key].append(stamp.sec * 1_000_000_000 + stamp.nanosec)
        self._answer(key)

    def _on_states(self, message):
        states = np.array(message.data, dtype=float).reshape(-1, 6)
        key = np.ascontiguousarray(states[:, :3]).tobytes()
        self.states_of[key].append(states.tobytes())
        self._answer(key)

    def _answer(self, key):
        if not self.stamp_of[key] or not self.states_of[key]:
            return
        stamp_ns, states = self.stamp_of[key].popleft(), self.states_of[key].popleft()
        if not self.instants or self.instants[-1][0] < stamp_ns:  # not one sent again
            self.instants.append((stamp_ns, states))
        answer = WrenchStamped()
        answer.header.frame_id = self.answers
        answer.header.stamp.sec, answer.header.stamp.nanosec = divmod(stamp_ns, 1_000_000_000)
        self.publisher.publish(answer)

    def digest(self, until_ns):
        """sha256 of every instant up to until_ns: stamps and states, in order."""
        digest = hashlib.sha256()
        for stamp_ns, states in self.instants:
            if stamp_ns <= until_ns:
                digest.update(stamp_ns.to_bytes(8, 'little') + states)
        return digest.hexdigest()


class ArrayKeeper(Node):
    """Holds every sphere at `target_z` with a PD law on ~/states, answering on ~/forces (an
    unstamped input: it answers the instant published last)."""

    def __init__(self, target_z=-1.0, kp=600.0, kd=150.0, **node_kwargs):
        super().__init__('array_keeper', **node_kwargs)
        self.target_z, self.kp, self.kd = target_z, kp, kd
        self.create_subscription(Float64MultiArray, 'pool_sim/states', self._on_states, 10)
        self.publisher = self.create_publisher(Float64MultiArray, 'pool_sim/forces', 10)

    def _on_states(self, message):
        states = np.array(message.data, dtype=float).reshape(-1, 6)
        forces = np.zeros((len(states), 3))
        forces[:, 2] = self.kp * (self.target_z - states[:, 2]) - self.kd * states[:, 5]
        self.publisher.publish(Float64MultiArray(data=forces.ravel().tolist()))


def first_difference(instants, others) -> str:
    """Where two recordings part: for a failing comparison's message."""
    for k, (one, other) in enumerate(zip(instants, others)):
        if one != other:
            return f'instant {k}: t = {one[0]} ns against {other[0]} ns, states differ'
    return f'{len(instants)} instants against {len(others)}'


def record_in_process(sim, until_ns=UNTIL_NS):
    """(digest, instant count, instants) up to until_ns of the loop in a started PoolSim: a
    Recorder and a DepthKeeper beside the node."""
    recorder = sim.add(Recorder)
    sim.add(DepthKeeper)
    sim.advance(until_ns * 1e-9)
    assert sim.spin(lambda: recorder.instants[-1][0] >= until_ns, 5.0)
    instants = [i for i in recorder.instants if i[0] <= until_ns]
    return recorder.digest(until_ns), len(instants), instants


def record_across_processes(params_file, hogs=0, until_ns=UNTIL_NS):
    """(wall s from t = 0 to until_ns, digest, instant count, instants) of the loop as users start
    it: `python -m pool_sim` with params_file, `python -m pool_sim.ros.depth_keeper`, and a
    Recorder in this process; `hogs` busy processes beside them."""
    env = {**os.environ, 'PYTHONPATH': str(REPO)}
    busy = [subprocess.Popen([sys.executable, '-c', 'while True: pass']) for _ in range(hogs)]
    node = subprocess.Popen([sys.executable, '-m', 'pool_sim', '--ros-args', '--params-file',
                             str(params_file)], env=env, stdout=subprocess.DEVNULL,
                            stderr=subprocess.DEVNULL)
    keeper = subprocess.Popen([sys.executable, '-m', 'pool_sim.ros.depth_keeper'], env=env,
                              stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    try:
        context = Context()
        rclpy.init(context=context)
        try:
            executor = make_executor('events', context)
            recorder = Recorder(context=context)
            executor.add_node(recorder)
            first, deadline = None, time.monotonic() + 60.0
            while time.monotonic() < deadline and (
                    not recorder.instants or recorder.instants[-1][0] < until_ns):
                executor.spin_once(timeout_sec=0.1)
                if first is None and recorder.instants:
                    first = time.perf_counter()
            wall = time.perf_counter() - first if first is not None else None
            executor.shutdown()
            recorder.destroy_node()
        finally:
            rclpy.shutdown(context=context)
        instants = [i for i in recorder.instants if i[0] <= until_ns]
        return wall, recorder.digest(until_ns), len(instants), instants
    finally:
        for process in (keeper, node, *busy):
            process.terminate()
        for process in (keeper, node, *busy):
            process.wait(timeout=10)
