"""Evasion of predicted collisions with moving obstacles (docs/reference.md §4.9, a departure from
teb_local_planner).

TEB's answer to a band that would meet a moving obstacle is to stop and plan again. Against people who
do not look where they walk, standing still is often where they hit the robot. So when the followed band,
or a standstill, would meet an obstacle's predicted position within the horizon, a fan of constant
velocity targets is rolled out (each reached at the acceleration limits) and the one that meets nothing
for longest wins, then the one that keeps most clear, then the one that gets furthest towards the local
goal. Walls count as a contact too (the costmap footprint check of §4.5 step 9).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from simplebot_navigation.costmap.cost_values import INSCRIBED_INFLATED_OBSTACLE, LETHAL_OBSTACLE
from simplebot_navigation.costmap.footprint import footprint_costs
from simplebot_navigation.perception.prediction import MotionPrediction, full_rows
from simplebot_navigation.teb import evasion_kernels

#: Rollout step (s).
STEP_S = 0.1
#: Distance (m) from an obstacle's predicted circle that counts as a contact: the tracker's position error
#: and the band's 3 cm of min_obstacle_dist are no margin against a body moving at 1-2 m/s.
CONTACT_MARGIN_M = 0.1
#: An obstacle already within the margin is met when it comes this much closer (m): a robot that has
#: been cut close can still tell the ways that let it come closer from those that take it away.
CLOSING_M = 0.05
#: Targets sampled: forward speeds as fractions of max_vel_x, reverse ones of max_vel_x_backwards,
#: turn rates as fractions of max_vel_theta.
FORWARD_FRACTIONS = (0.0, 0.25, 0.5, 0.75, 1.0)
BACKWARD_FRACTIONS = (0.5, 1.0)
TURN_FRACTIONS = (-1.0, -0.6, -0.3, 0.0, 0.3, 0.6, 1.0)
#: Score per second of contact-free driving within the horizon, against metres of progress and of
#: clearance: a second without contact outweighs any progress.
SCORE_PER_SECOND = 10.0
#: The rollouts run on for as long again, held at their target, scored at this per second: running
#: straight ahead of a faster obstacle only postpones the contact, stepping out of its way does not.
SCORE_PER_SECOND_BEYOND = 3.0
#: Clearance beyond this (m) earns nothing more.
CLEARANCE_CAP_M = 0.5
#: An evasion replaces the band only when it meets the first obstacle at least this much later (s).
MIN_GAIN_S = 0.2


@dataclass(frozen=True)
class Evasion:
    """The best target (v, omega), when it first meets an obstacle or a wall (inf: not within twice the
    horizon, as far as the rollouts run), and the standstill's contact time for comparison."""
    v: float
    omega: float
    contact_time: float
    standstill_contact_time: float


def velocity_targets(max_vel_x: float, max_vel_x_backwards: float, max_vel_theta: float) -> np.ndarray:
    """(S, 2) targets; the first is the standstill (0, 0)."""
    speeds = [max_vel_x * f for f in FORWARD_FRACTIONS] + [-max_vel_x_backwards * f for f in BACKWARD_FRACTIONS
                                                           if max_vel_x_backwards > 0]
    turns = [max_vel_theta * f for f in TURN_FRACTIONS]
    targets = [(0.0, 0.0)] + [(v, w) for v in speeds for w in turns if (v, w) != (0.0, 0.0)]
    return np.array(targets, dtype=float)


def rollouts(pose, velocity, targets: np.ndarray, acc_lim_x: float, acc_lim_theta: float,
             horizon: float) -> tuple[np.ndarray, np.ndarray]:
    """Poses (S, N+1, 3) at times (N+1,) from 0 to the horizon: each target reached from the current
    velocity at the acceleration limits, then held."""
    n = max(1, int(np.ceil(horizon / STEP_S - 1e-9)))
    poses = evasion_kernels.rollouts(float(pose[0]), float(pose[1]), float(pose[2]), float(velocity[0]),
                                     float(velocity[1]), np.ascontiguousarray(targets, dtype=float), float(acc_lim_x),
                                     float(acc_lim_theta), STEP_S, n)
    return poses, np.arange(n + 1) * STEP_S


def contact_times(model, poses: np.ndarray, times: np.ndarray, obstacles: np.ndarray,
                  margin: float = CONTACT_MARGIN_M, clearance_cap: float = np.inf,
                  prediction: MotionPrediction = MotionPrediction()) -> tuple[np.ndarray, np.ndarray]:
    """For trajectories (S, N, 3) from one pose, timed (N,): the time of the first pose within ``margin``
    of an obstacle's keep-out circle where ``prediction`` puts it, or CLOSING_M nearer than the first pose
    is if that is less (inf if none), and the smallest distance up to that pose, at most clearance_cap.
    obstacles: prediction rows, or (K, 5) x, y, vx, vy, radius. The reference of
    evasion_kernels.rollout_contacts."""
    s, n = poses.shape[:2]
    if len(obstacles) == 0:
        return np.full(s, np.inf), np.full(s, clearance_cap)
    k = len(obstacles)
    centres = prediction.centres(obstacles, times)                                # K, N, 2
    flat_poses = np.broadcast_to(poses[None], (k, s, n, 3)).reshape(-1, 3)
    flat_centres = np.broadcast_to(centres[:, None], (k, s, n, 2)).reshape(-1, 2)
    d = model.pair_distances(flat_poses, flat_centres).reshape(k, s, n) - prediction.radii(obstacles, times)[:, None]
    limit = np.minimum(margin, d[:, 0, 0] - CLOSING_M)                            # K
    hit = (d < limit[:, None, None]).any(axis=0)                                  # S, N
    nearest = d.min(axis=0)
    reached = hit.any(axis=1)
    last = np.where(reached, np.argmax(hit, axis=1), n - 1)
    upto = np.arange(n)[None, :] <= last[:, None]
    return (np.where(reached, times[last], np.inf),
            np.minimum(np.where(upto, nearest, np.inf).min(axis=1), clearance_cap))


def wall_contact_times(costmap, footprint: np.ndarray, poses: np.ndarray, times: np.ndarray,
                       outline: bool) -> np.ndarray:
    """Time of the first pose (S, N, 3) whose centre cell is inscribed or lethal, and with ``outline``
    also whose footprint outline meets a lethal cell (the feasibility check's footprint cost); inf if
    none. Beyond the rolling local costmap nothing is known, as for the feasibility check."""
    s, n = poses.shape[:2]
    flat = poses.reshape(-1, 3)
    mx, my, on_map = costmap.world_to_map_array(flat[:, 0], flat[:, 1])
    cost = costmap.costmap[np.where(on_map, my, 0), np.where(on_map, mx, 0)]
    hit = on_map & ((cost == LETHAL_OBSTACLE) | (cost == INSCRIBED_INFLATED_OBSTACLE))
    if outline:
        hit |= footprint_costs(costmap, footprint, flat) == -1.0
    hit = hit.reshape(s, n)
    return np.where(hit.any(axis=1), times[np.argmax(hit, axis=1)], np.inf)


def band_contact_time(model, band_poses: np.ndarray, band_times: np.ndarray, obstacles: np.ndarray,
                      horizon: float, prediction: MotionPrediction = MotionPrediction()) -> float:
    """When the band, timed as planned, first comes within the contact margin of a moving obstacle's
    keep-out circle (inf if not within the horizon); past its last pose the band stands there."""
    if len(obstacles) == 0 or len(band_poses) == 0:
        return np.inf
    times = np.append(band_times[band_times <= horizon], horizon)
    poses = np.vstack([band_poses[: len(times) - 1], band_poses[min(len(times) - 1, len(band_poses) - 1)]])
    return float(contact_times(model, poses[None], times, obstacles, prediction=prediction)[0][0])


def choose_evasion(pose, velocity, local_goal, obstacles: np.ndarray, costmap, footprint: np.ndarray, model,
                   limits: tuple[float, float, float, float, float], horizon: float,
                   prediction: MotionPrediction = MotionPrediction()) -> Evasion:
    """The best of the sampled targets; its contact_time counts to twice the horizon (inf: none).
    obstacles: prediction rows (or (K, 5)), met where ``prediction`` puts them.
    limits: max_vel_x, max_vel_x_backwards, max_vel_theta, acc_lim_x, acc_lim_theta. The footprint
    outline is checked against the walls only for the best rollouts, best first: the centre-cell check
    every rollout gets can only find a wall later, so an outline check can only lower a score."""
    max_vel_x, max_vel_x_backwards, max_vel_theta, acc_lim_x, acc_lim_theta = limits
    pose = np.asarray(pose, dtype=float)
    targets = velocity_targets(max_vel_x, max_vel_x_backwards, max_vel_theta)
    poses, times = rollouts(pose, velocity, targets, acc_lim_x, acc_lim_theta, 2.0 * horizon)
    moving, clearance = evasion_kernels.rollout_contacts(poses, times, np.ascontiguousarray(full_rows(obstacles)),
                                                         model.kernel_model, model.bounding_radius,
                                                         CONTACT_MARGIN_M, CLOSING_M, CLEARANCE_CAP_M,
                                                         *prediction.kernel_arguments)
    goal = np.asarray(local_goal[:2], dtype=float)
    end = poses[:, np.count_nonzero(times <= horizon + 1e-9) - 1, :2]
    progress = np.hypot(*(goal - pose[:2])) - np.hypot(*(goal - end).T)

    def score(contact):
        return (SCORE_PER_SECOND * np.minimum(contact, horizon)
                + SCORE_PER_SECOND_BEYOND * np.clip(contact - horizon, 0.0, horizon) + clearance + progress)

    contact = np.minimum(moving, wall_contact_times(costmap, footprint, poses, times, False))
    outline = len(footprint) >= 3
    scores = score(contact)
    best, best_score = 0, -np.inf
    for i in [0] + [int(j) for j in np.argsort(-scores, kind="stable") if j != 0]:
        if i != 0 and scores[i] <= best_score:
            break
        if outline:
            contact[i] = min(contact[i], wall_contact_times(costmap, footprint, poses[i:i + 1], times, True)[0])
            scores[i] = score(contact[i:i + 1])[0]
        if scores[i] > best_score:
            best, best_score = i, scores[i]
    return Evasion(float(targets[best, 0]), float(targets[best, 1]), float(contact[best]), float(contact[0]))
