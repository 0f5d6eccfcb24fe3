"""How far the localizer's estimate was from the truth: amcl_pose against the simulator's ground truth.

A map exported from a world has the world's coordinates, so amcl's ``map`` frame is the ground truth's world
frame and the two compare directly. Each estimate is compared with the truth at its own stamp (interpolated
between the ground-truth samples, 50 Hz), so the error is the filter's, not the delay of its topic.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from std_srvs.srv import Empty


@dataclass(frozen=True)
class LocalizationError:
    samples: int
    position_rms: float       # m
    position_p95: float       # m
    position_max: float       # m
    yaw_rms: float            # rad

    def text(self) -> str:
        return (f"{self.position_rms * 100:.1f} cm RMS, {self.position_p95 * 100:.1f} cm p95, "
                f"{math.degrees(self.yaw_rms):.2f} deg RMS ({self.samples} poses)")


def errors_against_truth(estimates, truth) -> tuple[np.ndarray, np.ndarray]:
    """(position error m, |yaw error| rad) of every estimate (t, x, y, yaw) inside the truth's time span."""
    estimates, truth = np.asarray(estimates, float).reshape(-1, 4), np.asarray(truth, float).reshape(-1, 4)
    if len(truth) < 2 or not len(estimates):
        return np.empty(0), np.empty(0)
    inside = (estimates[:, 0] >= truth[0, 0]) & (estimates[:, 0] <= truth[-1, 0])
    estimates = estimates[inside]
    x = np.interp(estimates[:, 0], truth[:, 0], truth[:, 1])
    y = np.interp(estimates[:, 0], truth[:, 0], truth[:, 2])
    yaw = np.interp(estimates[:, 0], truth[:, 0], np.unwrap(truth[:, 3]))
    position = np.hypot(estimates[:, 1] - x, estimates[:, 2] - y)
    heading = np.abs(np.remainder(estimates[:, 3] - yaw + math.pi, 2 * math.pi) - math.pi)
    return position, heading


def localization_error(estimates, truth) -> LocalizationError | None:
    """The error statistics over a goal, or None without an estimate while it ran."""
    position, heading = errors_against_truth(estimates, truth)
    if not len(position):
        return None
    return LocalizationError(samples=len(position), position_rms=float(np.sqrt(np.mean(position ** 2))),
                             position_p95=float(np.percentile(position, 95)), position_max=float(position.max()),
                             yaw_rms=float(np.sqrt(np.mean(heading ** 2))))


#: re-localized: within these of the truth, and for this long
LOCALIZED_M, LOCALIZED_RAD, LOCALIZED_FOR_S = 0.2, math.radians(10.0), 2.0
#: how the robot moves while it searches: on the spot, then creeping in a curve, so every lidar sweeps the room
SEARCH_TURN_S, SEARCH_TURN, SEARCH_CREEP = 4.0, (0.0, 0.6), (0.1, -0.3)


def relocalization_time(session, pose, limit_s: float) -> float | None:
    """The kidnapped robot: carry it to ``pose`` (world frame) without telling anyone, call amcl's
    global_localization, and turn and creep on the spot; the sim seconds of driving until amcl holds the truth
    (LOCALIZED_*), or None if not within ``limit_s``. ``session`` is a NavigationSession on a map."""
    session.sim.sim.kidnap(pose)
    client = session.client.create_client(Empty, "global_localization")
    future = client.call_async(Empty.Request())
    session.run_until(session.time + 2.0, future.done)
    start, good_since = session.time, None
    while session.time - start < limit_s:
        turning = int((session.time - start) / SEARCH_TURN_S) % 2 == 0
        session.sim.sim.set_cmd_vel(*(SEARCH_TURN if turning else SEARCH_CREEP))
        session.run_until(session.time + 0.1)
        if not session.client.localized:
            continue
        _, x, y, yaw = session.client.localized[-1]
        truth = session.pose()
        ok = (math.hypot(x - truth.x, y - truth.y) < LOCALIZED_M
              and abs(math.remainder(yaw - truth.yaw, 2 * math.pi)) < LOCALIZED_RAD)
        good_since = (good_since if good_since is not None else session.time) if ok else None
        if good_since is not None and session.time - good_since >= LOCALIZED_FOR_S:
            return good_since - start
    return None
