"""The node's published instants without a node: for `python -m pool_sim.headless`, whose
recorder and live view hear what a node named `pool_sim` would publish, under the same
topic names, in the same messages (the same SphereMessages fill them), with no DDS."""
from geometry_msgs.msg import PoseArray
from std_msgs.msg import Float64MultiArray
from visualization_msgs.msg import MarkerArray

from pool_sim.ros.clock import next_instant, steps_to_instant
from pool_sim.ros.messages import SphereMessages, stamp_nanoseconds
from pool_sim.ros.publishing import clock_instant, Published, scene_markers_instant


def node_topic(node_name: str, topic: str, namespace: str = '/') -> str:
    """The fully qualified name of a node's private topic `~/topic`, as rclpy expands it."""
    namespace = namespace.rstrip('/')
    return f'{namespace}/{node_name}/{topic}'


class HeadlessTopics:
    """Each publish instant of a Simulation told to listeners, as StatePublishing tells them:
    the state topics with the spheres, /clock while publish_clock is on, and the scene
    markers once."""

    def __init__(self, scene, node_name='pool_sim', namespace='/'):
        self.scene = scene
        self.messages = SphereMessages(scene.sphere_names, scene['frame_id'], odometry=False)
        self.topic = lambda name: node_topic(node_name, name, namespace)
        self.listeners = []

    def listen(self, listener):
        """Call listener(Published) after each instant, as StatePublishing.listen."""
        self.listeners.append(listener)

    def _tell(self, published):
        for listener in self.listeners:
            listener(published)

    def publish_scene_markers(self, simulation):
        self._tell(scene_markers_instant(self.topic('scene_markers'), simulation, self.scene))

    def publish_clock(self, simulation):
        if self.scene['publish_clock']:
            self._tell(clock_instant('/clock', simulation.time))

    def publish_state(self, simulation):
        """The present instant's state topics. As the node's, the Published carries the
        spheres, from which a listener makes what it wants more (each sphere's odometry)."""
        spheres = simulation.spheres
        self.messages.fill(simulation.time, spheres.position, spheres.velocity,
                           spheres.radius)
        sent = ((self.topic('poses'), PoseArray, self.messages.poses.to_bytes()),
                (self.topic('markers'), MarkerArray, self.messages.markers.to_bytes()),
                (self.topic('states'), Float64MultiArray, self.messages.states_bytes()))
        self._tell(Published(simulation.time, stamp_nanoseconds(simulation.time), sent,
                             spheres))

    def run(self, simulation, seconds, on_instant=None):
        """Step `simulation` for `seconds` of simulated time and tell each publish instant
        as the node's clock does: the scene markers and the state at the start, then after
        the steps to each instant (every 1/publish_rate_hz s, by the clock's own rule) its
        state, then /clock. on_instant(simulation) after each."""
        period = 1.0 / self.scene['publish_rate_hz']
        dt = simulation.max_step
        end = simulation.time + seconds
        self.publish_scene_markers(simulation)
        self.publish_state(simulation)
        if on_instant is not None:
            on_instant(simulation)
        next_publish = simulation.time + period
        while next_publish <= end + 1e-9:
            simulation.run(steps_to_instant(next_publish, simulation.time, dt), dt)
            next_publish = next_instant(next_publish, period, simulation.time)
            self.publish_state(simulation)
            self.publish_clock(simulation)
            if on_instant is not None:
                on_instant(simulation)
