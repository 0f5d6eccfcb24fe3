"""The slam node's messages: scans of one moment merged across lidars, and the pose graph as markers."""

from __future__ import annotations

from collections import OrderedDict

import numpy as np
from geometry_msgs.msg import Point
from visualization_msgs.msg import Marker, MarkerArray

from simplebot_navigation.slam.scan_points import MAX_BEAMS, ScanPoints

#: scans of one moment differ in stamp by at most this (the simulator stamps both lidars alike; real drivers jitter)
SAME_MOMENT_NS = 20_000_000
#: moments held while waiting for the other lidars' scans
MAX_MOMENTS = 8


class ScanMerger:
    """Collects each lidar's scan of a moment; a moment is ready once every topic gave one, or once a later moment
    is complete (a lidar that stopped does not hold the others up)."""

    def __init__(self, topics):
        self.topics = tuple(topics)
        self._moments: OrderedDict[int, dict[str, ScanPoints]] = OrderedDict()

    def add(self, topic: str, stamp_ns: int, points: ScanPoints) -> list[tuple[int, ScanPoints]]:
        """The moments now ready, oldest first, each as (stamp, merged scan); ValueError, before anything changes,
        when the scan and the other lidars' of its moment hold more than MAX_BEAMS beams together."""
        key = next((k for k in self._moments if abs(k - stamp_ns) <= SAME_MOMENT_NS), stamp_ns)
        others = sum(len(p) for t, p in self._moments.get(key, {}).items() if t != topic)
        if others + len(points) > MAX_BEAMS:
            raise ValueError(f"{len(points)} beams and the other lidars' {others} of its moment: more than the "
                             f"{MAX_BEAMS} a merged scan may hold")
        self._moments.setdefault(key, {})[topic] = points
        complete = [k for k, parts in self._moments.items() if len(parts) == len(self.topics)]
        ready = []
        if complete:
            newest = max(complete)
            ready = [k for k in self._moments if k <= newest]
        while len(self._moments) - len(ready) > MAX_MOMENTS:
            ready.append(min(k for k in self._moments if k not in ready))
        return [(k, ScanPoints.merged(list(self._moments.pop(k).values()))) for k in sorted(ready)]

    def clear(self) -> None:
        self._moments.clear()


def graph_markers(poses: np.ndarray, edges, frame_id: str, stamp) -> MarkerArray:
    """The nodes as spheres, odometry and scan edges as thin grey lines, loop closures as thick green ones."""
    nodes = _marker(0, Marker.SPHERE_LIST, frame_id, stamp, 0.08, (0.1, 0.4, 1.0))
    nodes.points = [Point(x=float(x), y=float(y)) for x, y, _ in poses]
    links = _marker(1, Marker.LINE_LIST, frame_id, stamp, 0.02, (0.5, 0.5, 0.5))
    loops = _marker(2, Marker.LINE_LIST, frame_id, stamp, 0.05, (0.1, 0.8, 0.2))
    for edge in edges:
        target = loops if edge.kind == "loop" else links
        for k in (edge.i, edge.j):
            target.points.append(Point(x=float(poses[k, 0]), y=float(poses[k, 1])))
    return MarkerArray(markers=[nodes, links, loops])


def _marker(marker_id: int, kind: int, frame_id: str, stamp, size: float, rgb) -> Marker:
    marker = Marker(id=marker_id, type=kind, action=Marker.ADD, ns="slam_pose_graph")
    marker.header.frame_id, marker.header.stamp = frame_id, stamp
    marker.pose.orientation.w = 1.0
    marker.scale.x = marker.scale.y = marker.scale.z = size
    marker.color.r, marker.color.g, marker.color.b, marker.color.a = (*rgb, 1.0)
    return marker
