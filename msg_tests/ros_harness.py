"""In-process rclpy for the node tests: pool_sim.testing's PoolSim with the node's own clock
thread running (as `ros2 run` runs it) and a client node beside it."""
import gc

import rclpy

from pool_sim.testing import overrides, PoolSim  # noqa: F401 (overrides: for the tests)


class Harness(PoolSim):
    """sim: the PoolSimNode, on its clock thread.  client: a plain node in the same
    namespace.  extra_nodes: factories called with context= and namespace=.  Use as a
    context manager: everything is destroyed and the context shut down, even when a test
    fails."""

    def __init__(self, params=None, extra_nodes=()):
        super().__init__(params, lockstep=False, run_clock=True, executor='single')
        self.extra_nodes = extra_nodes

    def make_nodes(self):
        """The nodes under test and the client; a subclass may make others."""
        # As the node's own process does once started (executables.run_node): what lives
        # now stays out of the collector's full passes, which in a long test session walk a
        # heap big enough to hold the clock thread past its 0.1 s catch-up bound.
        gc.collect()
        gc.freeze()
        self.sim = self.node = self.make_simulator()
        self.client = self.make_client()
        return [self.sim, self.client] + [
            make_node(context=self.context, namespace=self.namespace)
            for make_node in self.extra_nodes]

    def make_client(self):
        return rclpy.create_node('test_client', namespace=self.namespace,
                                 context=self.context)

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
        return self.spin(predicate, timeout_s)

    def spin_for(self, seconds):
        self.spin(lambda: False, seconds)

    def call(self, service_type, relative, request, timeout_s=5.0):
        client = self.client.create_client(service_type, self.topic(relative))
        assert client.wait_for_service(timeout_sec=timeout_s), relative
        future = client.call_async(request)
        self.executor.spin_until_future_complete(future, timeout_sec=timeout_s)
        assert future.done(), f'{relative} did not answer'
        return future.result()


def stamp_seconds(header):
    return header.stamp.sec + 1e-9 * header.stamp.nanosec
