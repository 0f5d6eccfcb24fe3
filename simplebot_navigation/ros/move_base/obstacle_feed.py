"""move_base's obstacle feed (perception/feed.py, docs/reference.md §6.3): its sources placed in each user's frame
by TF, at the latest transform (the sources already predict their obstacles to the time asked for)."""

from __future__ import annotations

from rclpy.time import Time

from simplebot_navigation.perception.feed import ObstacleFeed, ObstacleSource
from simplebot_navigation.ros.conversions import transform_to_xyyaw
from simplebot_navigation.log_throttle import Throttle
from simplebot_navigation.ros.tf import Buffer, TransformException

WARNING_PERIOD_S = 5.0


def tf_obstacle_feed(node, tf_buffer: Buffer, sources: tuple[ObstacleSource, ...] = ()) -> ObstacleFeed:
    """An ObstacleFeed whose sources are placed by `tf_buffer`; a source that cannot be placed is skipped, with a
    warning every WARNING_PERIOD_S naming both frames."""
    throttle = Throttle()

    def place(target: str, source: str):
        try:
            return transform_to_xyyaw(tf_buffer.lookup_transform(target, source, Time()))
        except TransformException as err:
            if throttle((target, source), WARNING_PERIOD_S):
                node.get_logger().warning(f"moving obstacles in {source} skipped for {target}: {err}")
            return None

    return ObstacleFeed(place, sources)
