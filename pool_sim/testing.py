"""pool_sim in your own pytest suite: the node in-process, stepped in lockstep with your nodes.

Once pool_sim is installed (colcon, pip), pytest finds this plugin by itself (a `pytest11`
entry point) and every test may ask for the `pool_sim` fixture::

    from rclpy.parameter import Parameter

    from pool_sim.ros.depth_keeper import DepthKeeper

    def test_the_keeper_holds_ice_at_one_metre(pool_sim):
        sim = pool_sim({'lockstep_inputs': ['ice'], 'wrench_timeout': 0.0})
        sim.add(DepthKeeper, parameter_overrides=[Parameter('target_depth', value=1.0)])
        sim.advance(20.0)
        position, velocity = sim.state('ice')
        assert abs(position[2] + 1.0) < 0.05

`pool_sim(scene, params_file)` starts a PoolSimNode in a private rclpy context and a fresh
namespace, with lockstep on and no clock thread of its own; `add` puts your nodes on the same
executor (a class or factory is called with context= and namespace=, so its relative topics
meet the simulator's); `advance(seconds)` runs publish period after publish period, each
once every input in `lockstep_inputs` has answered the instant before, as fast as the nodes
answer. The same test gives bitwise the same numbers every run. Everything is destroyed and
the context shut down when the test ends, passed or failed.

rclpy is imported only when a simulator starts: the plugin costs pytest nothing elsewhere.
"""
import itertools

import pytest

_namespaces = itertools.count()


def overrides(params: dict):
    """{name: value} as rclpy Parameters; an empty list becomes 'not set', as YAML does."""
    from rclpy.parameter import Parameter
    return [Parameter(name, value=(None if isinstance(value, (list, tuple)) and not value
                                   else value))
            for name, value in params.items()]


class PoolSim:
    """One simulator and the nodes beside it, on one executor in a private context.

    scene: parameters as a dict, flat ('ice.mass') or nested ({'ice': {'mass': 1.0}}), laid
    over params_file (a ROS params file, read as `--params-file` is), laid over the default
    pool. lockstep: the `lockstep` parameter unless the scene gives it. run_clock: False
    (the default) leaves time to advance(); True runs the node's own clock thread, as
    `ros2 run` does (real_time_factor then paces it). executor: 'events' (rclpy's
    EventsExecutor, written in C++: a closed loop runs twice as fast as on) 'single'
    (rclpy's SingleThreadedExecutor).
    """

    def __init__(self, scene=None, params_file=None, *, lockstep=True, run_clock=False,
                 node_name='pool_sim', executor='events'):
        from pool_sim.physics.schema import flatten
        self.params = flatten(dict(scene or {}))
        self.params.setdefault('lockstep', lockstep)
        self.params_file, self.run_clock, self.node_name = params_file, run_clock, node_name
        self.executor_kind = executor
        self.namespace = f'/pool_sim_test{next(_namespaces)}'
        self.context = self.executor = self.node = None
        self.nodes = []
        self._joined = False

    # -- life --------------------------------------------------------------------------------

    def start(self):
        import rclpy
        from rclpy.context import Context
        self.context = Context()
        args = ['--ros-args', '--params-file', str(self.params_file)] if self.params_file else []
        rclpy.init(context=self.context, args=args)
        try:
            self.executor = make_executor(self.executor_kind, self.context)
            for node in self.make_nodes():
                self.add(node)
        except BaseException:
            self.close()
            raise
        return self

    def make_nodes(self):
        """The nodes to start with: the simulator."""
        self.node = self.make_simulator()
        return [self.node]

    def make_simulator(self, **node_kwargs):
        from pool_sim.ros.simulator_node import PoolSimNode
        return PoolSimNode(self.node_name, run_clock=self.run_clock, context=self.context,
                           namespace=self.namespace,
                           parameter_overrides=overrides(self.params), **node_kwargs)

    def close(self):
        """Destroy every node and shut the context down; safe to call twice."""
        import rclpy
        if self.context is None:
            return
        errors = []
        if self.executor is not None:
            # Nodes off the executor first: EventsExecutor's callbacks must not be called
            # from DDS's threads while a node goes.
            for node in reversed(self.nodes):
                step_or_error(lambda node=node: self.executor.remove_node(node), errors)
            step_or_error(self.executor.shutdown, errors)
        for node in reversed(self.nodes):  # each one, whatever another raised
            step_or_error(node.destroy_node, errors)
        self.nodes = []
        if self.context.ok():
            step_or_error(lambda: rclpy.shutdown(context=self.context), errors)
        self.context = None
        if errors:
            raise errors[0]

    def __enter__(self):
        return self.start()

    def __exit__(self, *exc):
        self.close()

    def add(self, node, answers=(), **node_kwargs):
        """Put a node on the executor and return it. node: a Node made in this context, or a
        class or factory called with context=, namespace= and node_kwargs. answers: inputs
        it answers (sphere names, or 'forces'), added to lockstep_inputs."""
        from rclpy.node import Node
        from rclpy.parameter import Parameter
        if not isinstance(node, Node):
            node = node(**{'context': self.context, 'namespace': self.namespace,
                           **node_kwargs})
        self.nodes.append(node)
        self.executor.add_node(node)
        if self.node is not None and node is not self.node:
            self._joined = True  # the instant out is sent again before the next advance
        if answers:
            listed = list(self.node.scene['lockstep_inputs'])
            listed += [name for name in answers if name not in listed]
            result = self.node.set_parameters([Parameter('lockstep_inputs', value=listed)])[0]
            if not result.successful:
                raise ValueError(result.reason)
        return node

    # -- time --------------------------------------------------------------------------------

    @property
    def time(self) -> float:
        """Simulated seconds."""
        with self.node.lock():
            return self.node.simulation.time

    def advance(self, seconds: float) -> float:
        """Run until `seconds` more simulated time has passed (to the first publish instant
        at or after it), each publish period once every lockstep input answered the instant
        before it (or lockstep_timeout passed); returns the simulated time reached. The
        last instant is published: your nodes get it as the executor next runs (the next
        advance, or spin)."""
        node = self.node
        if node.runs_clock:
            raise RuntimeError('advance() drives a node without a clock thread '
                               '(run_clock=False); this one runs its own')
        with node.lock():
            target = node.simulation.time + seconds
            half_step = 0.5 * node.simulation.max_step
        while self.time < target - half_step:
            self.spin_until_answered()
            if not node.advance():
                raise RuntimeError('simulated time reached the last a ROS stamp can carry')
        return self.time

    def spin_until_answered(self):
        """Run callbacks until the instant published last is answered (or timed out)."""
        node = self.node
        if self._joined:  # nodes added since it was published: once, to them all at once
            self._joined = False
            node.republish_state()
        self.executor.spin_once(timeout_sec=0.0)  # what was just published, to every node
        while not node.ready():
            self.executor.spin_once(timeout_sec=min(node.wait_left_s(), 0.1))

    def spin(self, predicate, timeout_s=10.0):
        """Run callbacks (time goes on only with the clock thread) until predicate() holds,
        looked at under the node's lock; returns whether it did."""
        import time
        deadline = time.monotonic() + timeout_s
        while time.monotonic() < deadline:
            if self.holds(predicate):
                return True
            self.executor.spin_once(timeout_sec=0.01)
        return self.holds(predicate)

    def holds(self, predicate):
        if self.node is None:
            return predicate()
        with self.node.lock():
            return predicate()

    # -- the state and the forces -----------------------------------------------------------

    def state(self, sphere):
        """(position (3,), velocity (3,)) of a sphere, m and m/s: copies."""
        with self.node.lock():
            return self.node.simulation.sphere_state(sphere)

    def states(self):
        """(n, 6) array: every sphere's [x, y, z, vx, vy, vz], in sphere_names order, as
        ~/states carries it."""
        import numpy as np
        with self.node.lock():
            spheres = self.node.simulation.spheres
            return np.vstack([spheres.position, spheres.velocity]).T.copy()

    def force(self, sphere):
        """The external force (3,) N acting on a sphere now."""
        with self.node.lock():
            spheres = self.node.simulation.spheres
            return spheres.external_force[:, spheres.lookup(sphere)].copy()

    def set_force(self, sphere, force):
        """Push a sphere (N, world axes) as a wrench message does; it holds until replaced
        or until wrench_timeout."""
        self.node.set_external_force(sphere, force)

    def call(self, service_type, name, request, timeout_s=5.0):
        """Call one of the simulator's services ('reset', 'pause', 'step', 'set_mass',
        ...) and return the response."""
        client = self.node.create_client(service_type, f'{self.node.get_name()}/{name}')
        try:
            if not client.wait_for_service(timeout_sec=timeout_s):
                raise TimeoutError(f'~/{name} is not offered')
            future = client.call_async(request)
            self.executor.spin_until_future_complete(future, timeout_sec=timeout_s)
            if not future.done():
                raise TimeoutError(f'~/{name} did not answer within {timeout_s} s')
            return future.result()
        finally:
            self.node.destroy_client(client)


def step_or_error(step, errors):
    """Run a clean-up step; an exception goes to errors (to be raised once all ran)."""
    try:
        step()
    except Exception as error:  # every step runs; the first error is raised after
        errors.append(error)


def make_executor(kind, context):
    if kind == 'events':
        from rclpy.experimental import EventsExecutor
        return EventsExecutor(context=context)
    if kind == 'single':
        from rclpy.executors import SingleThreadedExecutor
        return SingleThreadedExecutor(context=context)
    raise ValueError(f"executor: 'events' or 'single', got {kind!r}")


@pytest.fixture
def pool_sim():
    """Start simulators: pool_sim(scene=None, params_file=None, **options) -> PoolSim (see
    PoolSim for the options). Each is torn down when the test ends, passed or failed."""
    started = []

    def start(scene=None, params_file=None, **options):
        sim = PoolSim(scene, params_file, **options)
        started.append(sim)
        return sim.start()

    yield start
    errors = []
    for sim in reversed(started):
        step_or_error(sim.close, errors)
    if errors:
        raise errors[0]
