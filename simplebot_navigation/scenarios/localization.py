"""How far the localizer's estimate was from the truth: amcl_pose against the simulator's ground truth.

A map exported from a world has the world's coordinates, so amcl's ``map`` frame is the ground truth's world
frame and the two compare directly. Each estimate is compared with the truth at its own stamp (interpolated
between the ground-truth samples, 50 Hz), so the error is the filter's, not the delay of its topic.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np


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
