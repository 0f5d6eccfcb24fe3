"""What Nav2's navigation actions add to a move_base goal (docs/reference.md §9): the bounds on a request, the
passing of intermediate poses, the progress feedback and the error codes of a failure."""

from __future__ import annotations

import math
from collections import deque

#: NavigateThroughPoses and FollowWaypoints take at most this many poses
MAX_POSES = 1000
#: an intermediate pose of NavigateThroughPoses counts as passed within this distance (Nav2's RemovePassedGoals)
PASS_RADIUS_M = 0.5
#: the recent speed behind estimated_time_remaining is averaged over this long
SPEED_WINDOW_S = 2.0
#: below this recent speed (m/s) the estimate uses the fastest the robot has driven during the goal, at least
#: DEFAULT_SPEED (TEB's default max_vel_x) instead: a robot waiting at a door is not going to take forever
MIN_ESTIMATE_SPEED = 0.05
DEFAULT_SPEED = 0.4

#: the (Nav2 interface, error code) of a goal that ended for this cause; NavigateToPose's result defines only
#: NONE, and Nav2's navigator reports the code of the server that failed, the planner's or the controller's
ERROR_CODES = {
    "PLANNING_R": ("ComputePathToPose", "NO_VALID_PATH"),
    "CONTROLLING_R": ("FollowPath", "NO_VALID_CONTROL"),
    "OSCILLATION_R": ("FollowPath", "FAILED_TO_MAKE_PROGRESS"),
    "PROGRESS_R": ("FollowPath", "FAILED_TO_MAKE_PROGRESS"),
    "goal_outside_map": ("ComputePathToPose", "GOAL_OUTSIDE_MAP"),
    "transform": ("ComputePathToPose", "TF_ERROR"),
    "invalid_goal": ("ComputePathToPose", "UNKNOWN"),
    "controller": ("FollowPath", "UNKNOWN"),
}

#: ComputePathToPose's error code for each way the global planner fails (planning/global_planner.py PlanFailure)
PLAN_FAILURE_CODES = {
    "START_OFF_MAP": "START_OUTSIDE_MAP",
    "GOAL_OFF_MAP": "GOAL_OUTSIDE_MAP",
    "GOAL_IN_LETHAL": "GOAL_OCCUPIED",
    "NO_PATH": "NO_VALID_PATH",
    "PATH_EXTRACTION": "NO_VALID_PATH",
}
#: FollowWaypoints repeats its list at most this many more times (number_of_loops)
MAX_LOOPS = 100


def check_pose_count(count: int, field: str = "poses") -> str | None:
    if count == 0:
        return f"{field} is empty"
    if count > MAX_POSES:
        return f"{field} has {count} poses, at most {MAX_POSES} are taken"
    return None


class ProgressEstimate:
    """The robot's recent speed from its poses, and the time left to drive a distance at it."""

    def __init__(self):
        self.top_speed = DEFAULT_SPEED
        self._samples: deque[tuple[float, float, float]] = deque()

    def add(self, now: float, x: float, y: float) -> None:
        if self._samples and now < self._samples[-1][0]:    # time went back: the old samples mean nothing now
            self._samples.clear()
        self._samples.append((now, x, y))
        while len(self._samples) > 2 and now - self._samples[1][0] >= SPEED_WINDOW_S:
            self._samples.popleft()

    def speed(self) -> float:
        if len(self._samples) < 2:
            return 0.0
        path = sum(math.hypot(b[1] - a[1], b[2] - a[2]) for a, b in zip(self._samples, list(self._samples)[1:]))
        elapsed = self._samples[-1][0] - self._samples[0][0]
        return path / elapsed if elapsed > 0 else 0.0

    def time_remaining(self, distance: float) -> float:
        """Seconds to drive ``distance`` at the recent speed (the top speed while the robot stands)."""
        speed = self.speed()
        self.top_speed = max(self.top_speed, speed)
        return distance / (speed if speed >= MIN_ESTIMATE_SPEED else self.top_speed)


def remaining_distance(plan_left: float | None, pose, target, later: list[tuple[float, float]]) -> float:
    """Distance still to drive: along the plan when there is one (``plan_left``), else straight to the target;
    then straight through the ``later`` poses of a NavigateThroughPoses."""
    distance = plan_left if plan_left is not None else math.hypot(target[0] - pose[0], target[1] - pose[1])
    previous = target
    for point in later:
        distance += math.hypot(point[0] - previous[0], point[1] - previous[1])
        previous = point
    return distance
