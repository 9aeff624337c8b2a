"""In-process rclpy for tests: a private Context, the simulator node and a client node."""
import itertools
import time

import rclpy
from rclpy.context import Context
from rclpy.executors import SingleThreadedExecutor
from rclpy.parameter import Parameter

from pool_sim.ros.simulator_node import PoolSimNode

_namespaces = itertools.count()


def overrides(params: dict):
    """{name: value} -> rclpy Parameters; an empty list becomes 'not set', as YAML does."""
    return [Parameter(name, value=(None if value == [] else value))
            for name, value in params.items()]


class Harness:
    """sim: the PoolSimNode.  client: a plain node in the same namespace.  Use as a context
    manager: everything is destroyed and the context shut down, even when a test fails."""

    def __init__(self, params=None, extra_nodes=()):
        self.params = params or {}
        self.extra_nodes = extra_nodes
        self.namespace = f'/test{next(_namespaces)}'

    def __enter__(self):
        self.context = Context()
        rclpy.init(context=self.context)
        try:
            self.executor = SingleThreadedExecutor(context=self.context)
            self.nodes = self.make_nodes()
            for node in self.nodes:
                self.executor.add_node(node)
        except BaseException:
            rclpy.shutdown(context=self.context)
            raise
        return self

    def make_nodes(self):
        """The nodes under test and the client; a subclass may make others."""
        self.sim = PoolSimNode(context=self.context, namespace=self.namespace,
                               parameter_overrides=overrides(self.params))
        self.client = self.make_client()
        return [self.sim, self.client] + [
            make_node(context=self.context, namespace=self.namespace)
            for make_node in self.extra_nodes]

    def make_client(self):
        return rclpy.create_node('test_client', namespace=self.namespace,
                                 context=self.context)

    def __exit__(self, *exc):
        try:
            self.executor.shutdown()
            for node in self.nodes:
                node.destroy_node()
        finally:
            rclpy.shutdown(context=self.context)

    def topic(self, relative):
        return f'{self.namespace}/pool_sim/{relative}'

    def collect(self, message_type, relative, qos=10):
        """Subscribe; returns the list that received messages are appended to."""
        received = []
        self.client.create_subscription(message_type, self.topic(relative), received.append, qos)
        return received

    def spin_until(self, predicate, timeout_s=10.0):
        """Spin until predicate() holds; it is looked at between two ticks of the clock
        thread (under the node's lock), never half-way through a step."""
        deadline = time.monotonic() + timeout_s
        while time.monotonic() < deadline:
            if self.holds(predicate):
                return True
            self.executor.spin_once(timeout_sec=0.01)
        return self.holds(predicate)

    def holds(self, predicate):
        lock = getattr(getattr(self, 'sim', None), 'lock', None)
        if lock is None:
            return predicate()
        with lock:
            return predicate()

    def state(self, sphere):
        """(position, velocity) of a sphere between two ticks."""
        with self.sim.lock:
            return self.sim.simulation.sphere_state(sphere)

    def spin_for(self, seconds):
        self.spin_until(lambda: False, seconds)

    def call(self, service_type, relative, request, timeout_s=5.0):
        client = self.client.create_client(service_type, self.topic(relative))
        assert client.wait_for_service(timeout_sec=timeout_s), relative
        future = client.call_async(request)
        self.executor.spin_until_future_complete(future, timeout_sec=timeout_s)
        assert future.done(), f'{relative} did not answer'
        return future.result()


def stamp_seconds(header):
    return header.stamp.sec + 1e-9 * header.stamp.nanosec
