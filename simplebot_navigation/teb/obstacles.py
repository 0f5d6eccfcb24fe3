"""Point obstacles from the local costmap and their association with band poses (docs/reference.md §4.1, §4.4)."""

from __future__ import annotations

import math

import numpy as np

from simplebot_navigation.costmap.cost_values import LETHAL_OBSTACLE
from simplebot_navigation.perception.prediction import POSITION_SPREAD, VX, VY, MotionPrediction, prediction_rows
from simplebot_navigation.teb import footprint_kernels


def costmap_point_obstacles(costmap, robot_pose, behind_robot_dist: float) -> np.ndarray:
    """Centres (M,2) of lethal cells, as updateObstacleContainerWithCostmap takes them: the last
    row and column are not scanned, and cells behind the robot farther than behind_robot_dist
    are skipped. Inflated (253) cells are not obstacles for the optimiser."""
    grid = costmap.costmap[:-1, :-1]
    my, mx = np.nonzero(grid == LETHAL_OBSTACLE)
    res = costmap.resolution
    pts = np.stack([costmap.origin_x + (mx + 0.5) * res, costmap.origin_y + (my + 0.5) * res], axis=1)
    return pts[behind_robot_filter(pts, robot_pose, behind_robot_dist)]


def behind_robot_filter(points: np.ndarray, robot_pose, behind_robot_dist: float) -> np.ndarray:
    """Mask of the points TEB keeps: not (behind the robot and farther than behind_robot_dist)."""
    x, y, th = robot_pose
    rel = points - (x, y)
    behind = rel @ np.array([math.cos(th), math.sin(th)]) < 0
    far = np.einsum("ij,ij->i", rel, rel) > behind_robot_dist ** 2
    return ~(behind & far)


#: Force-included obstacles of one pose are kept per direction sector, the closest in each: the
#: cells of one wall push the same way, and a pose in a door sees dozens of them within reach.
FORCE_INCLUSION_SECTORS = 8
#: The closest obstacles left and right of a pose bound a gap when nothing else lies nearer to
#: their midpoint than this fraction of their half distance (a wall ahead has cells there).
GAP_FREE_FRACTION = 0.8


def associate_obstacles(model, poses: np.ndarray, obstacles: np.ndarray, min_obstacle_dist: float,
                        force_inclusion_factor: float, cutoff_factor: float):
    """Pairs (pose index, obstacle index) for the interior poses 1..n-1 and, per pair, the
    clearance of the gap the pose is passing (inf when it is not passing one).

    Kept: the obstacles closer than min_obstacle_dist*force_inclusion_factor (the closest one per
    direction sector), plus the closest obstacle on the left and on the right of the heading within
    min_obstacle_dist*cutoff_factor. The gap clearance is the footprint distance a pose would keep
    from both sides on the centre line between the closest obstacles left and right of it: in a
    door narrower than the distances ask for, no pose can keep min_obstacle_dist, and the
    optimiser then asks for the centre line instead of pushing the poses out of the door (which
    stalls the band, and the robot, in front of it). Compiled (teb/footprint_kernels.py): every pose meets
    every nearby costmap cell, once per outer iteration and band."""
    return footprint_kernels.associate_obstacles(np.ascontiguousarray(poses, dtype=float),
                                       np.ascontiguousarray(obstacles, dtype=float), model.kernel_model,
                                       min_obstacle_dist, force_inclusion_factor, cutoff_factor,
                                       model.bounding_radius, model.inscribed_radius, FORCE_INCLUSION_SECTORS,
                                       GAP_FREE_FRACTION)


def motion_prediction(cfg) -> MotionPrediction:
    """The prediction the configuration asks for: with include_dynamic_obstacles false the obstacles stand
    where they are, as static circles of their tracked radius (planned_motion), and nothing grows."""
    if not cfg.obstacles.include_dynamic_obstacles:
        return MotionPrediction()
    moving = cfg.moving_obstacles
    return MotionPrediction(moving.dynamic_obstacle_prediction_horizon or math.inf,
                            moving.dynamic_obstacle_max_uncertainty, moving.dynamic_obstacle_radius_growth)


def planned_motion(obstacles: np.ndarray, predict: bool, covariance: np.ndarray | None = None,
                   n_sigma: float = 0.0) -> np.ndarray:
    """The moving obstacles as the planner predicts them, rows of perception/prediction.py (x, y, vx, vy,
    radius, position and velocity spreads): with include_dynamic_obstacles false (predict) they stand where they
    are, as static circles without spreads, so every use below sees one rule."""
    rows = prediction_rows(obstacles, covariance, n_sigma)
    if not predict:
        rows[:, VX:VY + 1] = 0.0
        rows[:, POSITION_SPREAD:] = 0.0
    return rows


def dynamic_obstacle_edges(model, poses: np.ndarray, times: np.ndarray, obstacles: np.ndarray, reach: float,
                           prediction: MotionPrediction = MotionPrediction()):
    """AddEdgesDynamicObstacles: one edge per interior pose and dynamic obstacle (prediction rows), the obstacle
    taken where it is predicted at the pose's time; returns (pose indices, (m, 3) predicted x, y and radius),
    obstacle after obstacle. **Here** the radius is the keep-out radius at that time (perception/prediction.py:
    it grows with the track's uncertainty and with dynamic_obstacle_radius_growth), and a pair whose predicted
    centre lies farther than reach from every point of the model (its centre distance less the bounding radius
    and the obstacle's radius) gets no edge: its errors are zero and stay so unless the pose moves by about
    reach within one outer iteration, and a crowd would otherwise put hundreds of idle edges into every
    evaluation."""
    inner = np.arange(1, len(poses) - 1)
    centres = prediction.centres(obstacles, times[inner])                             # K, n-1, 2
    radii = prediction.radii(obstacles, times[inner])                                 # K, n-1
    gap = np.hypot(*(centres - poses[None, inner, :2]).transpose(2, 0, 1)) - model.bounding_radius - radii
    k, i = np.nonzero(gap <= reach)
    return inner[i], np.column_stack([centres[k, i], radii[k, i]])
