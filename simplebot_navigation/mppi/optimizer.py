"""Model predictive path integral control: sample control sequences around the current one, roll them out through
the diff drive's motion model, score them with the critics, and move the sequence to the exponentially weighted
average of the samples (Williams et al.; the scheme of Nav2's MPPI controller).

Besides the random samples, every batch holds the sequence itself, braking at the limits, and a fan of constant
velocity targets reached at the acceleration limits: the samples of an unlucky draw all lie near a sequence that
drives into an obstacle, and the passive safety (safety.py) picks its escapes among these.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from simplebot_navigation.mppi import kernels
from simplebot_navigation.mppi.config import MppiConfig
from simplebot_navigation.perception.prediction import MotionPrediction

#: the fan: forward speeds as fractions of vx_max, turn rates as fractions of wz_max (reverse: vx_min, straight
#: and at the largest turn rates)
FAN_SPEEDS = (0.0, 0.25, 0.5, 0.75, 1.0)
FAN_TURNS = (-1.0, -0.5, -0.2, 0.0, 0.2, 0.5, 1.0)
#: the first rows of every batch: the sequence itself and braking; the fan follows
FIXED_ROWS = 2
#: an obstacle that is already within the contact margin is met when it comes this much nearer (m)
CLOSING_M = 0.05


def limits_vector(cfg: MppiConfig) -> np.ndarray:
    """The motion model's limits in the kernels' order (kernels.VX_MIN ...)."""
    lim = cfg.limits
    return np.array([lim.vx_min, lim.vx_max, lim.wz_max, lim.ax_max, lim.ax_min, lim.az_max, lim.wheel_speed_max,
                     0.5 * lim.wheel_separation, lim.wheel_accel_max])


def fan_targets(cfg: MppiConfig) -> np.ndarray:
    """(S, 2) constant (v, w) targets; the first is the standstill."""
    lim = cfg.limits
    targets = [(lim.vx_max * v, lim.wz_max * w) for v in FAN_SPEEDS for w in FAN_TURNS]
    if lim.vx_min < 0:
        targets += [(lim.vx_min, lim.wz_max * w) for w in (-0.5, 0.0, 0.5)]
    return np.array(targets)


@dataclass
class Scene:
    """What the critics of one cycle look at, in the local costmap's frame."""
    state: np.ndarray           # x, y, yaw, v, w
    path: np.ndarray            # (M, 2) the plan ahead, resampled
    target: np.ndarray          # (2,) the plan point the rollouts should reach
    goal: np.ndarray            # (3,) the plan's last pose
    near_goal: bool             # within threshold_to_consider: the goal critic replaces the path critics
    grid: np.ndarray            # the local costmap's cells (uint8, [my, mx])
    distance: np.ndarray        # each cell's distance (m) to the nearest lethal cell
    origin: tuple[float, float, float]   # origin_x, origin_y, resolution
    outline: np.ndarray         # (P, 2) body outline points (none for a round body)
    circles: np.ndarray         # (C, 3) covering circles of the body
    obstacles: np.ndarray       # (K, 7) prediction rows of the moving obstacles
    prediction: MotionPrediction
    keep_out: tuple[np.ndarray, np.ndarray]   # the prediction's table over the horizon: centres, radii
    guide: np.ndarray           # (G, 3) t, x, y: the space-time guide from this cycle's time (G = 0: none)


@dataclass
class Rollouts:
    """Scored rollouts: controls (B, T, 2), poses (B, T, 3), total cost (B,), and the step index of the first
    static and the first moving contact ((B,), T: none)."""
    controls: np.ndarray
    poses: np.ndarray
    costs: np.ndarray
    static_first: np.ndarray
    moving_first: np.ndarray


class MppiOptimizer:
    """The control sequence (T, 2) of commanded (v, w), kept from cycle to cycle."""

    def __init__(self, cfg: MppiConfig, seed: int = 0):
        self.cfg = cfg
        self.rng = np.random.default_rng(seed)
        self.sequence = np.zeros((cfg.sampling.time_steps, 2))

    def reset(self, velocity=(0.0, 0.0)) -> None:
        """Start again from holding ``velocity``."""
        self.sequence = np.tile(np.asarray(velocity, dtype=float), (self.cfg.sampling.time_steps, 1))

    def shift(self, steps: int) -> None:
        """One control period later: drop the steps driven, repeat the last one."""
        steps = min(max(steps, 0), len(self.sequence) - 1)
        if steps:
            self.sequence = np.vstack([self.sequence[steps:], np.repeat(self.sequence[-1:], steps, axis=0)])

    def rollout(self, state: np.ndarray, sequences: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Controls and poses of given sequences (B, T, 2), no noise."""
        return kernels.rollout(state, np.zeros_like(sequences[0]), sequences, limits_vector(self.cfg),
                               self.cfg.sampling.model_dt)

    def evaluate(self, scene: Scene, controls: np.ndarray, poses: np.ndarray) -> Rollouts:
        """The critics' total per rollout (without the control cost of the noise, which only the sampling knows)."""
        cfg, crit, mov = self.cfg, self.cfg.critics, self.cfg.moving_obstacles
        dt, steps = cfg.sampling.model_dt, controls.shape[1]
        static_first, mean_cost = kernels.costmap_terms(poses, scene.grid, *scene.origin, scene.outline)
        moving_first, shortfall = kernels.moving_terms(scene.state[:3], poses, *scene.keep_out, scene.circles,
                                                       mov.contact_margin, CLOSING_M, mov.moving_obstacle_clearance)
        terms = kernels.path_terms(poses, controls, scene.state[3:5], dt, scene.path, scene.target, scene.goal)
        if scene.near_goal:
            costs = crit.goal_weight * terms[:, kernels.GOAL]
        else:
            costs = (crit.path_align_weight * terms[:, kernels.ALIGN]
                     + crit.path_follow_weight * terms[:, kernels.FOLLOW]
                     + crit.path_angle_weight * terms[:, kernels.ANGLE])
        if len(scene.guide):
            costs += cfg.space_time.guide_weight * kernels.guide_terms(poses, dt, scene.guide)
        costs += (crit.prefer_forward_weight * terms[:, kernels.REVERSE]
                  + crit.smoothness_weight * terms[:, kernels.SMOOTH]
                  + crit.cost_weight * mean_cost + mov.clearance_weight * shortfall)
        costs += crit.collision_cost * np.where(static_first < steps, 1.0 - static_first / steps, 0.0)
        contact = moving_first < steps
        index = np.minimum(moving_first, steps - 1)
        speed_at_contact = np.abs(controls[np.arange(len(controls)), index, 0])
        costs += np.where(contact, crit.collision_cost * mov.moving_obstacle_weight * (1.0 - moving_first / steps)
                          + mov.contact_speed_weight * speed_at_contact, 0.0)
        return Rollouts(controls, poses, costs, static_first, moving_first)

    def noise(self) -> np.ndarray:
        """(B, T, 2): the first rows turn the sequence into itself, braking and the fan; the rest are normal."""
        sampling = self.cfg.sampling
        steps = sampling.time_steps
        eps = self.rng.standard_normal((sampling.batch_size, steps, 2), dtype=np.float32) * np.array([sampling.vx_std,
                                                                                                       sampling.wz_std])
        fan = fan_targets(self.cfg)
        fixed = np.concatenate([self.sequence[None], np.zeros((1, steps, 2)),
                                np.broadcast_to(fan[:, None, :], (len(fan), steps, 2))])
        count = min(len(fixed), len(eps))
        eps[:count] = fixed[:count] - self.sequence[None]
        return eps

    def optimize(self, scene: Scene) -> Rollouts:
        """iteration_count rounds of sampling and averaging; the last round's rollouts (for the passive safety)."""
        sampling = self.cfg.sampling
        limits, dt = limits_vector(self.cfg), sampling.model_dt
        sigma2 = np.array([sampling.vx_std, sampling.wz_std]) ** 2
        inverse = np.divide(1.0, sigma2, out=np.zeros(2), where=sigma2 > 0)
        lim = self.cfg.limits
        low, high = np.array([lim.vx_min, -lim.wz_max]), np.array([lim.vx_max, lim.wz_max])
        for _ in range(sampling.iteration_count):
            eps = self.noise()
            controls, poses = kernels.rollout(scene.state, self.sequence, eps, limits, dt)
            scored = self.evaluate(scene, controls, poses)
            control_cost = sampling.gamma / len(self.sequence) * np.einsum("btc,tc,c->b", eps, self.sequence, inverse)
            total = scored.costs + control_cost
            weights = np.exp(-(total - total.min()) / sampling.temperature)
            weights /= weights.sum()
            # the noise is averaged as drawn: averaging the controls the limits left would drift, since a draw
            # below the sequence can be followed faster (braking) than one above it (accelerating)
            self.sequence = np.clip(self.sequence + np.einsum("b,btc->tc", weights, eps), low, high)
        return scored
