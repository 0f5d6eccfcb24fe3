"""What a Costmap2DROS publishes: /<name>/costmap, /<name>/costmap_updates and the footprint.

As costmap_2d's Costmap2DPublisher, a full grid goes out when the geometry changed (or always, or
for a new subscriber), otherwise only the cells changed since the last publish.
"""

from __future__ import annotations

from geometry_msgs.msg import PolygonStamped
from map_msgs.msg import OccupancyGridUpdate
from nav_msgs.msg import OccupancyGrid

from simplebot_navigation.costmap.cost_values import OCCUPANCY_GRID_TABLE
from simplebot_navigation.ros.conversions import occupancy_grid_msg, polygon_msg
from simplebot_navigation.ros.costmap.costmap_input import LATCHED, UPDATES_QOS
from simplebot_navigation.ros.publishers import create_publisher


class CostmapPublisher:
    """The publishers of one Costmap2DROS (`owner`) and the window of cells not yet sent."""

    def __init__(self, owner, footprint_topic: str):
        self.owner = owner
        node = owner.node
        self._pending_window: tuple[int, int, int, int] | None = None
        self._sent_geometry = None
        self._new_subscriber = False
        self.costmap_pub = create_publisher(node, OccupancyGrid, f"{owner.name}/costmap", LATCHED,
                                            matched=self._on_costmap_matched, callback_group=owner.callback_group)
        self.updates_pub = create_publisher(node, OccupancyGridUpdate, f"{owner.name}/costmap_updates",
                                            UPDATES_QOS)
        self.footprint_pub = create_publisher(node, PolygonStamped, footprint_topic, 1)

    def destroy(self) -> None:
        for pub in (self.costmap_pub, self.updates_pub, self.footprint_pub):
            self.owner.node.destroy_publisher(pub)

    def touch(self, x0: int, y0: int, xn: int, yn: int) -> None:
        """Cells [x0, xn) x [y0, yn) changed and go out with the next update."""
        if self._pending_window is None:
            self._pending_window = (x0, y0, xn, yn)
        else:
            a = self._pending_window
            self._pending_window = (min(a[0], x0), min(a[1], y0), max(a[2], xn), max(a[3], yn))

    def touch_all(self) -> None:
        master = self.owner.costmap
        self.touch(0, 0, master.size_x, master.size_y)

    def _on_costmap_matched(self, info) -> None:
        """A new subscriber got the latched grid, which may be old: send it a current one."""
        if info.total_count_change > 0:
            self._new_subscriber = True

    def publish_footprint(self, footprint) -> None:
        owner = self.owner
        self.footprint_pub.publish(polygon_msg(footprint, owner.global_frame, owner.node.get_clock().now().to_msg()))

    def publish_costmap(self) -> None:
        """The full grid or the changed cells; nothing without subscribers (changes keep accumulating)."""
        if self.costmap_pub.get_subscription_count() == 0 and self.updates_pub.get_subscription_count() == 0:
            return
        owner = self.owner
        stamp = owner.node.get_clock().now().to_msg()
        with owner.lock:
            master = owner.costmap
            geometry = (master.size_x, master.size_y, master.resolution, master.origin_x, master.origin_y)
            if owner.config.always_send_full_costmap or self._new_subscriber or geometry != self._sent_geometry:
                msg = occupancy_grid_msg(master.costmap, master.resolution, master.origin_x, master.origin_y,
                                         owner.global_frame, stamp)
                self._sent_geometry = geometry
                self._new_subscriber = False
                self._pending_window = None
                self.costmap_pub.publish(msg)
                return
            window, self._pending_window = self._pending_window, None
            if window is None or window[2] <= window[0] or window[3] <= window[1]:
                return
            x0, y0, xn, yn = window
            update = OccupancyGridUpdate()
            update.header.frame_id = owner.global_frame
            update.header.stamp = stamp
            update.x, update.y, update.width, update.height = x0, y0, xn - x0, yn - y0
            update.data = OCCUPANCY_GRID_TABLE[master.costmap[y0:yn, x0:xn]].ravel().tobytes()
        self.updates_pub.publish(update)
