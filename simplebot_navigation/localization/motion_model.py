"""amcl's odometry motion models for a differential drive, sampled for all particles at once.

The odometry change since the last filter update is split as in Probabilistic Robotics' sample_motion_model_odometry
into a first rotation, a translation and a second rotation; each particle moves by them with Gaussian noise whose
size grows with the motion (alpha1: rotation from rotation, alpha2: rotation from translation, alpha3: translation
from translation, alpha4: translation from rotation). As amcl does, a translation under 1 cm has no first rotation
(turning on the spot), and the rotations' noise uses their distance to 0 or to pi, whichever is nearer, so that
driving backwards is no noisier than forwards.

The two models differ only in how the alphas enter, and both are reproduced as amcl has them:

- ``diff`` takes ``alpha1 * rot^2 + alpha2 * trans^2`` (and so on) as the noise's *standard deviation*: the book's
  variance used as a sigma, so the noise grows with the square of the motion and the alphas are not variances;
- ``diff-corrected`` takes the square root of it, the book's model: the alphas are variance factors and the noise
  grows linearly with the motion. amcl's wiki notes that its alphas then need to be much smaller.
"""

from __future__ import annotations

import math

import numpy as np

MODELS = ("diff", "diff-corrected")
#: below this much translation (m) the robot turned on the spot and has no heading of travel
SPOT_TURN = 0.01


def wrap(angles):
    """Angles to [-pi, pi)."""
    return (np.asarray(angles) + math.pi) % (2 * math.pi) - math.pi


def angle_diff(a, b):
    """a - b, wrapped to [-pi, pi)."""
    return wrap(np.asarray(a) - np.asarray(b))


def odometry_steps(delta, old_yaw: float) -> tuple[float, float, float]:
    """(rot1, trans, rot2) of an odometry change ``delta`` (dx, dy in the odom frame, dyaw) from heading
    ``old_yaw``."""
    dx, dy, dyaw = delta
    trans = math.hypot(dx, dy)
    rot1 = 0.0 if trans < SPOT_TURN else float(angle_diff(math.atan2(dy, dx), old_yaw))
    return rot1, trans, float(angle_diff(dyaw, rot1))


def noise_sigmas(rot1: float, trans: float, rot2: float, alphas, model: str) -> tuple[float, float, float]:
    """Standard deviations of the noise on (rot1, trans, rot2) under ``model``."""
    if model not in MODELS:
        raise ValueError(f"odom_model_type: must be one of {', '.join(MODELS)}, got {model!r}")
    a1, a2, a3, a4 = alphas
    r1 = min(abs(float(angle_diff(rot1, 0.0))), abs(float(angle_diff(rot1, math.pi))))
    r2 = min(abs(float(angle_diff(rot2, 0.0))), abs(float(angle_diff(rot2, math.pi))))
    spreads = (a1 * r1 * r1 + a2 * trans * trans,
               a3 * trans * trans + a4 * r1 * r1 + a4 * r2 * r2,
               a1 * r2 * r2 + a2 * trans * trans)
    if model == "diff-corrected":
        return tuple(math.sqrt(s) for s in spreads)
    return spreads


def sample_motion(poses: np.ndarray, delta, old_yaw: float, alphas, model: str,
                  rng: np.random.Generator) -> np.ndarray:
    """New (N, 3) particle poses after the odometry change ``delta`` = (dx, dy, dyaw) in the odom frame, which
    started at odom heading ``old_yaw``; ``alphas`` = (odom_alpha1..4). Yaws come back wrapped to [-pi, pi)."""
    rot1, trans, rot2 = odometry_steps(delta, old_yaw)
    sigma_rot1, sigma_trans, sigma_rot2 = noise_sigmas(rot1, trans, rot2, alphas, model)
    n = len(poses)
    rot1_hat = angle_diff(rot1, rng.normal(0.0, sigma_rot1, n))
    trans_hat = trans - rng.normal(0.0, sigma_trans, n)
    rot2_hat = angle_diff(rot2, rng.normal(0.0, sigma_rot2, n))
    heading = poses[:, 2] + rot1_hat
    out = np.empty_like(poses)
    out[:, 0] = poses[:, 0] + trans_hat * np.cos(heading)
    out[:, 1] = poses[:, 1] + trans_hat * np.sin(heading)
    out[:, 2] = wrap(poses[:, 2] + rot1_hat + rot2_hat)
    return out
