"""Passive safety: the command of a cycle is sent if the robot can still stop after it without touching a wall,
and without meeting a moving obstacle while it moves, or if it escapes a contact that braking would meet
(docs/reference.md §4.10).

Every candidate is judged by its manoeuvre: its first control period, then braking at the deceleration limits
(ax_min, az_max) to rest, and standing until the horizon. A manoeuvre is **free** when nothing meets it within the
horizon, **passive** when nothing meets it while the robot still moves (a moving obstacle may walk into it at rest).
Lethal cells of the costmap count as walls, and also as obstacles the tracker may not have picked up: while it
moves, the robot keeps as far from them as one could walk towards it since the cycle began (unknown_obstacle_speed).
In order, the cycle takes: the optimised sequence if its manoeuvre is free; the cheapest sample whose manoeuvre
is free (an escape: the samples' costs weigh progress, so one of them usually beats standing); braking now if that
is free; the sample that, driven on, meets anything latest, if that is at least MIN_GAIN_S later than the braking
robot is met (running from an obstacle that would strike it standing: the escape is judged by its own rollout, and
checked again next cycle); braking now if that is passive; the optimised sequence if its manoeuvre is passive; else
braking now. A command whose manoeuvre is passive has that manoeuvre's continuation as the next cycle's braking,
so a contact the prediction foresaw, and that no escape avoids, finds the robot at rest.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from simplebot_navigation.mppi import kernels
from simplebot_navigation.mppi.optimizer import CLOSING_M, FIXED_ROWS, MppiOptimizer, Rollouts, Scene, fan_targets

#: samples whose manoeuvres are checked for an escape, cheapest first (and the fan's)
ESCAPE_CANDIDATES = 24
#: when nothing is free, a sample is driven instead of braking only if it meets the obstacle this much later (s)
MIN_GAIN_S = 0.5
#: a velocity below this (m/s, rad/s) is at rest
AT_REST = 1e-6
#: a passive manoeuvre is at rest this long (s) before a moving obstacle meets it: a robot that has only just
#: stopped was still driving for anyone watching (the simulator counts a contact within half a second of driving
#: as the robot's own, sim/robot.py DRIVING_WINDOW_S), and the drive follows a command a control period late
REST_MARGIN_S = 0.6


@dataclass(frozen=True)
class Decision:
    """What a cycle does: ``kind`` plan, brake, escape or brake (no safe way); the trajectory it starts (controls
    (T, 2) and poses (T, 3): the optimised sequence's, or the manoeuvre's); the sequence kept for the next cycle."""
    kind: str
    controls: np.ndarray
    poses: np.ndarray
    sequence: np.ndarray

    @property
    def command(self) -> tuple[float, float]:
        return float(self.controls[0, 0]), float(self.controls[0, 1])


def manoeuvres(heads: np.ndarray, steps: int) -> np.ndarray:
    """(N, steps, 2) sequences: each head (N, H, 2), then commands of zero (braking at the limits, then rest)."""
    out = np.zeros((len(heads), steps, 2))
    out[:, :heads.shape[1]] = heads
    return out


def judge(scored: Rollouts, unseen: np.ndarray, dt: float) -> tuple[np.ndarray, np.ndarray]:
    """(free, passive) per manoeuvre; ``unseen``: unseen_first's index per manoeuvre, counted as a wall. Passive
    needs the robot at rest REST_MARGIN_S before a moving obstacle meets it."""
    steps = scored.controls.shape[1]
    before = np.maximum(np.minimum(scored.moving_first, steps - 1) - round(REST_MARGIN_S / dt), 0)
    still_moving = (np.abs(scored.controls[np.arange(len(before)), before]) > AT_REST).any(axis=1)
    clear_of_walls = (scored.static_first == steps) & (unseen == steps)
    met = scored.moving_first < steps
    return clear_of_walls & ~met, clear_of_walls & ~(met & still_moving)


def unseen(optimizer: MppiOptimizer, scene: Scene, controls: np.ndarray, poses: np.ndarray) -> np.ndarray:
    """kernels.unseen_first for manoeuvres of this scene (none with unknown_obstacle_speed 0)."""
    speed = optimizer.cfg.moving_obstacles.unknown_obstacle_speed
    if speed <= 0:
        return np.full(len(controls), controls.shape[1])
    return kernels.unseen_first(poses, controls, optimizer.cfg.sampling.model_dt, scene.distance, *scene.origin,
                                scene.circles, speed, CLOSING_M)


def decide(optimizer: MppiOptimizer, scene: Scene, samples: Rollouts, hold: int) -> Decision:
    """The passive-safety choice among the optimised sequence, braking and the samples (module doc); ``hold``
    steps make one control period."""
    steps = optimizer.sequence.shape[0]
    hold = min(max(hold, 1), steps)
    fan = np.arange(FIXED_ROWS, min(FIXED_ROWS + len(fan_targets(optimizer.cfg)), len(samples.costs)))
    ranked = np.argsort(samples.costs, kind="stable")[:ESCAPE_CANDIDATES]
    ranked = np.concatenate([ranked, np.setdiff1d(fan, ranked)])
    heads = np.concatenate([optimizer.sequence[None, :hold], np.zeros((1, hold, 2)), samples.controls[ranked, :hold]])
    controls, poses = optimizer.rollout(scene.state, manoeuvres(heads, steps))
    scored = optimizer.evaluate(scene, controls, poses)
    free, passive = judge(scored, unseen(optimizer, scene, controls, poses), optimizer.cfg.sampling.model_dt)

    def taken(kind: str, row: int, sequence: np.ndarray) -> Decision:
        return Decision(kind, controls[row], poses[row], sequence)

    plan_controls, plan_poses = optimizer.rollout(scene.state, optimizer.sequence[None])
    plan = Decision("plan", plan_controls[0], plan_poses[0], plan_controls[0])
    if free[0]:
        return plan
    escapes = np.nonzero(free[2:])[0]
    if len(escapes):
        sample = ranked[escapes[0]]
        return taken("escape", 2 + escapes[0], samples.controls[sample])
    if free[1]:
        return taken("brake", 1, controls[1])
    # nothing is free and braking would be met: the sample that, driven on, meets nothing for longest, if that is
    # clearly longer than the braking robot has (an escape that keeps moving; the next cycle checks it again)
    met = np.minimum(samples.static_first, samples.moving_first)[ranked]
    best = int(np.argmax(met))
    gain = round(MIN_GAIN_S / optimizer.cfg.sampling.model_dt)
    if met[best] - min(scored.moving_first[1], scored.static_first[1]) >= gain:
        return taken("escape", 2 + best, samples.controls[ranked[best]])
    if passive[1]:
        return taken("brake", 1, controls[1])
    if passive[0]:
        return plan
    return taken("brake (no safe way)", 1, controls[1])
