"""config/pool_sim.rviz, the RViz2 config the README starts rviz2 with: fixed frame `world`,
one display per state topic the node really publishes (name, message type), each subscribing
with a QoS the node's publisher offers; the scene markers, published once, transient local
(RViz's marker display is volatile by default and never gets them: ros2/rviz#478). That
colcon installs it: test_installed_executable.py."""
from pathlib import Path

import pytest
from rclpy.qos import DurabilityPolicy, HistoryPolicy, ReliabilityPolicy
import yaml

from pool_sim.ros.node_keys import NODE_KEYS
from pool_sim.ros.publishing import STATE_QOS
from ros_harness import Harness

RVIZ_CONFIG = Path(__file__).resolve().parents[1] / 'config' / 'pool_sim.rviz'
# The message type each display class subscribes to.
DISPLAY_TYPES = {'rviz_default_plugins/PoseArray': 'geometry_msgs/msg/PoseArray',
                 'rviz_default_plugins/MarkerArray': 'visualization_msgs/msg/MarkerArray'}
# RViz's words for the QoS policies in a display's Topic mapping.
DURABILITY = {'Volatile': DurabilityPolicy.VOLATILE,
              'Transient Local': DurabilityPolicy.TRANSIENT_LOCAL}
RELIABILITY = {'Reliable': ReliabilityPolicy.RELIABLE,
               'Best Effort': ReliabilityPolicy.BEST_EFFORT}
HISTORY = {'Keep Last': HistoryPolicy.KEEP_LAST, 'Keep All': HistoryPolicy.KEEP_ALL}


@pytest.fixture(scope='module')
def manager():
    return yaml.safe_load(RVIZ_CONFIG.read_text())['Visualization Manager']


def topic_displays(manager) -> dict:
    """Topic name -> (display class, its Topic mapping) of every display that subscribes."""
    return {display['Topic']['Value']: (display['Class'], display['Topic'])
            for display in manager['Displays'] if 'Topic' in display}


def test_the_fixed_frame_is_the_frame_the_node_stamps_by_default(manager):
    assert manager['Global Options']['Fixed Frame'] == NODE_KEYS['frame_id'].default == \
        'world'
    assert {d['Class'] for d in manager['Displays']} == {
        'rviz_default_plugins/Grid', *DISPLAY_TYPES}
    assert manager['Views']['Current']['Class'] == 'rviz_default_plugins/Orbit'


def test_the_scene_markers_display_is_transient_local_so_it_gets_the_one_message(manager):
    display_class, topic = topic_displays(manager)['/pool_sim/scene_markers']
    assert display_class == 'rviz_default_plugins/MarkerArray'
    assert (topic['Durability Policy'], topic['Reliability Policy'],
            topic['History Policy'], topic['Depth']) == \
        ('Transient Local', 'Reliable', 'Keep Last', 1)


def test_every_display_names_a_topic_the_node_publishes_with_a_qos_it_offers(manager):
    displays = topic_displays(manager)
    with Harness({'real_time_factor': 0.0}) as ros:
        name, namespace = ros.sim.get_name(), ros.sim.get_namespace()
        assert name == 'pool_sim'  # the executable's node name: rviz2 finds /pool_sim/...
        wanted = {topic: namespace + topic for topic in displays}
        assert ros.spin_until(lambda: all(
            ros.client.get_publishers_info_by_topic(full) for full in wanted.values()))
        published = dict(ros.client.get_publisher_names_and_types_by_node(name, namespace))
        for topic, full in wanted.items():
            display_class, subscription = displays[topic]
            assert published[full] == [DISPLAY_TYPES[display_class]], topic
            [publisher] = ros.client.get_publishers_info_by_topic(full)
            offered = publisher.qos_profile
            # The node's offer, exactly: RViz joins late and still gets the last message.
            assert offered.durability == DURABILITY[subscription['Durability Policy']], topic
            assert offered.reliability == RELIABILITY[subscription['Reliability Policy']], \
                topic
            # The graph does not carry a publisher's history and depth: the node's own.
            assert HISTORY[subscription['History Policy']] == STATE_QOS.history, topic
            assert subscription['Depth'] == STATE_QOS.depth, topic
        assert set(wanted) == {'/pool_sim/poses', '/pool_sim/markers',
                               '/pool_sim/scene_markers'}
