"""Online SLAM: scans become pose-graph nodes, matched to the recent ones, closed into loops, rendered into a map.

A scan becomes a node once the robot has moved ``minimum_travel_distance`` or turned ``minimum_travel_heading``
since the last one (slam_toolbox's rule). Its pose is first odometry's guess from the last node, then the scan
matcher's against the running buffer (the last ``scan_buffer_size`` nodes within
``scan_buffer_maximum_scan_distance``). One edge ties it to the last node: the match's, with the matcher's covariance
and a robust kernel, or, where the match is not trusted, odometry's, with a spread growing with the travel.

Loop closure: nodes within ``loop_search_maximum_distance`` that the robot passed long enough ago (further along
the trajectory than the running buffer reaches) form a chain of at least ``loop_match_minimum_chain_size``; the
new scan is matched to the chain's scans over ``loop_search_space_dimension`` (the coarse response must reach
``loop_match_minimum_response_coarse``), then in a narrow window against sharper walls
(``loop_match_minimum_response_fine``). A closure adds a "loop" edge, the graph is optimised, and the map is
rendered again from the moved poses.

In localization mode the graph of a loaded session stays as it is: scans are matched to the loaded map near the
robot, and only map -> odom moves.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from simplebot_navigation.geometry import compose2, inverse2, transform_points
from simplebot_navigation.maps.map_io import OccupancyMap
from simplebot_navigation.slam.occupancy import LogOddsGrid, render
from simplebot_navigation.slam.params import SlamParams
from simplebot_navigation.slam.pose_graph import PoseGraph
from simplebot_navigation.slam.scan_matcher import CorrelationGrid, Match, ScanMatcher
from simplebot_navigation.slam.scan_points import ScanPoints

#: the most nodes one session holds (a node keeps its scan: about 55 kB for the simplebot's two lidars)
MAX_NODES = 20_000
#: odometry's spread per node: a floor and a share of the travel (m, m/m); a floor, per metre of travel and per
#: radian of turn (rad, rad/m, rad/rad). Loose: encoders with 1 % scale errors turn the heading by about 0.03 rad
#: per metre, and a loop closure must be able to bend odometry's chain, not the matched one.
ODOM_SIGMA_XY = (0.02, 0.1)
ODOM_SIGMA_YAW = (0.01, 0.02, 0.1)
#: the spread of a node placed without odometry or a match (after a restart): a metre and a radian
UNLINKED = np.diag([1.0, 1.0, 1.0])
#: the matcher's covariance is floored here: a perfect response is not a perfect pose
MATCH_FLOOR = np.diag([0.01 ** 2, 0.01 ** 2, 0.005 ** 2])
#: occupancy probability of a cell a beam ends in, and of one it crosses: a cell needs two returns more than
#: misses to be occupied (above 0.65), so that one stray return of a badly placed node does not draw a wall
BEAM_MODEL = (0.6, 0.4)
#: neighbouring returns at most this far apart (m) are one surface, filled in for matching (ScanPoints.surfaces)
SURFACE_GAP = 0.25
#: nodes between two loop searches that found nothing, and after a closure
LOOP_RETRY_NODES = 3
#: half-width of the fine loop window, around the coarse result (m, rad)
FINE_WINDOW = (0.1, 0.05)


@dataclass(frozen=True)
class Update:
    """What one scan did: ``node`` is its index, or None when it did not become a node; ``closed`` is True when
    it closed a loop (the whole map moved)."""
    node: int | None
    response: float = 0.0
    closed: bool = False


class Mapper:
    def __init__(self, params: SlamParams):
        self.params = params
        self.graph = PoseGraph()
        self.scans: list[ScanPoints] = []
        self._buffer_surfaces: dict[ScanPoints, np.ndarray] = {}
        self.odometry: list[tuple[float, float, float]] = []   # each node's odometry pose
        self.travel: list[float] = []                          # the trajectory's length up to each node
        self.grid = LogOddsGrid(params.resolution, *BEAM_MODEL)
        self._map_to_odom = (0.0, 0.0, 0.0)
        self._last_odom: tuple[float, float, float] | None = None
        self._next_loop_search = 0
        self._localization_grid: CorrelationGrid | None = None

    # -- what the node publishes ------------------------------------------------------------
    @property
    def map_to_odom(self) -> tuple[float, float, float]:
        return self._map_to_odom

    def occupancy_map(self, frame_id: str = "map") -> OccupancyMap:
        p = self.params
        return self.grid.occupancy_map(p.occupied_threshold, p.free_threshold, frame_id)

    def rendered(self) -> LogOddsGrid:
        """The map drawn afresh from every node's scan at its pose (after a loop closure moved them)."""
        return render(self.graph.poses, self.scans, self.params.resolution, hit_probability=BEAM_MODEL[0],
                      miss_probability=BEAM_MODEL[1])

    def pose(self, odom_pose) -> tuple[float, float, float]:
        """Where the robot is in the map, given its odometry pose now."""
        return compose2(self._map_to_odom, odom_pose)

    # -- input --------------------------------------------------------------------------------
    def add_scan(self, odom_pose, scan: ScanPoints) -> Update:
        """Use one (merged) scan taken at odometry pose ``odom_pose``; ValueError for a pose that is not finite."""
        if len(odom_pose) != 3 or not all(math.isfinite(v) for v in odom_pose):
            raise ValueError(f"odometry pose: expected finite (x, y, yaw), got {odom_pose!r}")
        odom_pose = tuple(float(v) for v in odom_pose)
        if len(scan.returns) < 3:
            raise ValueError(f"scan: {len(scan.returns)} returns, at least 3 are needed to match it")
        if self.params.mode == "localization":
            return self._localize(odom_pose, scan)
        if self._last_odom is not None and not self._moved_enough(odom_pose):
            return Update(None)
        if len(self.scans) >= MAX_NODES:
            raise ValueError(f"the session holds {MAX_NODES} nodes, the most it may: save it and start another")
        return self._add_node(odom_pose, scan)

    def restart_odometry(self) -> None:
        """Odometry restarted (time went back, or a loaded session goes on): the next scan is placed where map -> odom
        says and matched there, without an odometry edge to the last node."""
        self._last_odom = None

    def _moved_enough(self, odom_pose) -> bool:
        dx, dy, dyaw = compose2(inverse2(self._last_odom), odom_pose)
        return (math.hypot(dx, dy) >= self.params.minimum_travel_distance
                or abs(dyaw) >= self.params.minimum_travel_heading)

    def _add_node(self, odom_pose, scan: ScanPoints) -> Update:
        n = len(self.scans)
        if n == 0 or self._last_odom is None:      # unlinked: where map -> odom says
            prior = compose2(self._map_to_odom, odom_pose)
        else:
            prior = compose2(tuple(self.graph.poses[-1]), compose2(inverse2(self._last_odom), odom_pose))
        pose, match = prior, None
        if n and self.params.use_scan_matching:
            match = self._match_buffer(scan, prior)
            if match.response >= self.params.link_match_minimum_response_fine:
                pose = match.pose
        index = self.graph.add_node(pose)
        if n:
            self._link(index, odom_pose, pose, match)
        self.travel.append(self.travel[-1] + math.dist(pose[:2], self.graph.poses[-2][:2]) if n else 0.0)
        self.scans.append(scan)
        self.odometry.append(odom_pose)
        self._last_odom = odom_pose
        closed = self.params.do_loop_closing and self._close_loop(index, scan)
        if closed:
            self.grid = self.rendered()
        else:
            self.grid.integrate(*scan.in_frame(pose), scan.hits)
        self._map_to_odom = compose2(tuple(self.graph.poses[-1]), inverse2(odom_pose))
        return Update(index, match.response if match is not None else 0.0, closed)

    def _odometry_covariance(self, odom_pose) -> np.ndarray:
        """The spread of odometry's step from the last node to ``odom_pose`` (isotropic in x and y)."""
        dx, dy, dyaw = compose2(inverse2(self._last_odom), odom_pose)
        d = math.hypot(dx, dy)
        s_xy = ODOM_SIGMA_XY[0] + ODOM_SIGMA_XY[1] * d
        s_yaw = ODOM_SIGMA_YAW[0] + ODOM_SIGMA_YAW[1] * d + ODOM_SIGMA_YAW[2] * abs(dyaw)
        return np.diag([s_xy ** 2, s_xy ** 2, s_yaw ** 2])

    def _link(self, index: int, odom_pose, pose, match: Match | None) -> None:
        """The match's edge to the last node, or odometry's where there is no trusted match. Not both: odometry's
        heading drifts by a bias (a wheel's scale error), not by noise, and beside a chain of matched edges it would
        make the robust kernel take the matches for the outliers."""
        previous = tuple(self.graph.poses[index - 1])
        if match is not None and match.response >= self.params.link_match_minimum_response_fine:
            self.graph.add_edge(index - 1, index, compose2(inverse2(previous), pose),
                                self._edge_covariance(match, previous[2]), "scan")
        elif self._last_odom is not None:
            relative = compose2(inverse2(self._last_odom), odom_pose)
            self.graph.add_edge(index - 1, index, relative, self._odometry_covariance(odom_pose), "odometry")
        else:       # odometry restarted and no match: where map -> odom put it, loosely
            self.graph.add_edge(index - 1, index, compose2(inverse2(previous), pose), UNLINKED, "odometry")

    @staticmethod
    def _edge_covariance(match: Match, frame_yaw: float) -> np.ndarray:
        """The matcher's covariance (map frame) in the frame of the edge's first node, floored."""
        c, s = math.cos(frame_yaw), math.sin(frame_yaw)
        rotation = np.array([[c, s, 0.0], [-s, c, 0.0], [0.0, 0.0, 1.0]])
        return rotation @ np.asarray(match.covariance) @ rotation.T + MATCH_FLOOR

    def _buffer(self) -> list[int]:
        p, here = self.params, self.graph.poses[-1][:2]
        recent = range(max(0, len(self.scans) - p.scan_buffer_size), len(self.scans))
        return [i for i in recent if math.dist(self.graph.poses[i][:2], here) <= p.scan_buffer_maximum_scan_distance]

    def _points(self, nodes) -> np.ndarray:
        poses = self.graph.poses
        return np.concatenate([self.scans[i].in_frame(tuple(poses[i]))[1][self.scans[i].hits] for i in nodes])

    def _surfaces(self, nodes) -> np.ndarray:
        """The nodes' surfaces (ScanPoints.surfaces) in the map frame. Those of the buffer's scans are kept from one
        node to the next (by scan: a loaded session brings other scans), and only theirs."""
        res, kept = self.params.correlation_search_space_resolution, self._buffer_surfaces
        self._buffer_surfaces = {scan: kept[scan] if scan in kept else scan.surfaces(SURFACE_GAP, res)
                                 for scan in (self.scans[i] for i in nodes)}
        return np.concatenate([transform_points(tuple(self.graph.poses[i]), self._buffer_surfaces[self.scans[i]])
                               for i in nodes])

    def _match_buffer(self, scan: ScanPoints, prior) -> Match:
        p = self.params
        nodes = self._buffer() or [len(self.scans) - 1]
        grid = CorrelationGrid.from_points(self._surfaces(nodes), p.correlation_search_space_resolution,
                                           p.correlation_search_space_smear_deviation)
        return self._matcher().match(grid, self._seen_before(scan, prior, nodes), prior)

    def _seen_before(self, scan: ScanPoints, prior, nodes) -> np.ndarray:
        """The scan's returns that the buffered scans could have seen too: within their sensors' reach of one of
        them (less the search window), placed at the prior. A wall ahead runs on past the end of the wall the buffer
        drew; its points beyond that end match nothing, and a match moved back along the wall makes more of them
        land on it, so along a corridor every node came out short of the truth (0.25 % of the travel in the office).
        Fewer than half the returns left (a turn into new space): all of them."""
        p, returns = self.params, scan.returns
        reach = (p.max_laser_range - p.correlation_search_space_dimension / 2
                 - 2.0 * p.correlation_search_space_smear_deviation)
        sensors = np.concatenate([transform_points(tuple(self.graph.poses[i]), self.scans[i].sensors) for i in nodes])
        placed = transform_points(prior, returns)
        nearest = np.min(np.hypot(placed[:, None, 0] - sensors[None, :, 0], placed[:, None, 1] - sensors[None, :, 1]),
                         axis=1)
        seen = nearest <= reach
        return returns[seen] if 2 * seen.sum() >= len(returns) else returns

    def _matcher(self) -> ScanMatcher:
        """The matcher of a new scan to what came before: a narrow window, odometry's guess favoured."""
        p = self.params
        return ScanMatcher(p.correlation_search_space_dimension / 2, p.coarse_search_angle_offset, 0.0, True,
                           p.distance_variance_penalty, p.angle_variance_penalty, p.minimum_distance_penalty,
                           p.minimum_angle_penalty)

    # -- loop closure ---------------------------------------------------------------------------
    def _loop_chain(self, index: int) -> list[int]:
        """The nodes to match a loop against: close to node ``index`` and far back along the trajectory."""
        p = self.params
        poses, travel = self.graph.poses, np.asarray(self.travel)
        old = np.flatnonzero(travel[index] - travel[:index] > p.scan_buffer_maximum_scan_distance)
        if not len(old):
            return []
        near = old[np.hypot(*(poses[old, :2] - poses[index, :2]).T) <= p.loop_search_maximum_distance]
        if not len(near):
            return []
        low, high = int(near.min()), int(near.max())
        while high - low + 1 < p.loop_match_minimum_chain_size and (low > 0 or high < old.max()):
            low, high = max(low - 1, 0), min(high + 1, int(old.max()))
        return list(range(low, high + 1)) if high - low + 1 >= p.loop_match_minimum_chain_size else []

    def _close_loop(self, index: int, scan: ScanPoints) -> bool:
        if index < self._next_loop_search:
            return False
        chain = self._loop_chain(index)
        if not chain:
            return False
        self._next_loop_search = index + LOOP_RETRY_NODES
        p, pose = self.params, tuple(self.graph.poses[index])
        points = self._points(chain)
        coarse = ScanMatcher(p.loop_search_space_dimension / 2, p.coarse_search_angle_offset).match(
            CorrelationGrid.from_points(points, p.loop_search_space_resolution,
                                        p.correlation_search_space_smear_deviation),
            scan.returns, pose)
        if coarse.response < p.loop_match_minimum_response_coarse:
            return False
        fine = ScanMatcher(*FINE_WINDOW).match(
            CorrelationGrid.from_points(points, p.correlation_search_space_resolution,
                                        p.loop_search_space_smear_deviation),
            scan.returns, coarse.pose)
        if fine.response < p.loop_match_minimum_response_fine:
            return False
        anchor = min(chain, key=lambda i: math.dist(self.graph.poses[i][:2], fine.pose[:2]))
        anchor_pose = tuple(self.graph.poses[anchor])
        self.graph.add_edge(anchor, index, compose2(inverse2(anchor_pose), fine.pose),
                            self._edge_covariance(fine, anchor_pose[2]), "loop")
        self.graph.optimize()
        return True

    # -- localization on a loaded session -------------------------------------------------------
    def _localize(self, odom_pose, scan: ScanPoints) -> Update:
        if not self.scans:
            raise ValueError("localization: no map to localize on (load a session: map_file_name, deserialize_map)")
        if self._localization_grid is None:
            occupancy = self.occupancy_map()
            self._localization_grid = CorrelationGrid.from_occupancy(
                occupancy.data, occupancy.resolution, occupancy.origin,
                self.params.correlation_search_space_smear_deviation)
        if self._last_odom is not None and not self._moved_enough(odom_pose):
            return Update(None)
        prior = compose2(self._map_to_odom, odom_pose)
        p = self.params
        match = self._matcher().match(self._localization_grid, scan.returns, prior)
        self._last_odom = odom_pose
        if match.response >= p.link_match_minimum_response_fine:
            self._map_to_odom = compose2(match.pose, inverse2(odom_pose))
        return Update(None, match.response)

    def set_pose(self, map_pose, odom_pose) -> None:
        """The robot is at ``map_pose`` now (an initial pose, or a relocalization): map -> odom follows."""
        if not all(math.isfinite(v) for v in (*map_pose, *odom_pose)):
            raise ValueError(f"pose: expected finite values, got {map_pose!r} at odometry {odom_pose!r}")
        self._map_to_odom = compose2(tuple(map_pose), inverse2(tuple(odom_pose)))
