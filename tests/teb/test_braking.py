"""Braking from top speed in the planner alone: the command is the speed of the band's first segment, and a band
that must brake has to brake at acc_lim_x from one control cycle to the next (tests/e2e/test_stopping_at_speed.py
has the same with the whole stack)."""

import math

import numpy as np

from simplebot_navigation.move_base.speed_profile import speed_parameters
from simplebot_navigation.teb.config import TebConfig
from simplebot_navigation.teb.planner import TebLocalPlanner
from tests.teb.scenes import box_cells, rolling_costmap

#: the round body r = 0.25 with max_speed 2.0 (move_base/speed_profile.py) and the narrow-passage set
RADIUS = 0.25
PERIOD = 0.05
PREFIX = "TebLocalPlannerROS."
PARAMS = {"footprint_model": {"type": "circular", "radius": RADIUS}, "allow_init_with_backwards_motion": True,
          "min_obstacle_dist": 0.03, "inflation_dist": 0.15, "global_plan_viapoint_sep": -0.1,
          **{name.removeprefix(PREFIX): value for name, value in speed_parameters(2.0, viapoints_on=False).items()
             if name.startswith(PREFIX)}}
#: the Jackal drive's acceleration (sim/diff_drive.py): the robot reaches a command within a control period
DRIVE_ACCEL = 2.5


def brake_in_front_of_a_wall(gap: float):
    """The robot at 2 m/s heading +x, a wall across a 2.8 m corridor `gap` ahead of its front, and the global plan
    turned back (what move_base's replan round the blocked corridor gives). Returns per cycle (command, odometry
    speed, distance left to the wall) until the robot stands, and whether it did within 3 s."""
    angles = np.linspace(0.0, 2 * math.pi, 16, endpoint=False)
    outline = RADIUS * np.column_stack([np.cos(angles), np.sin(angles)])
    planner = TebLocalPlanner(TebConfig.from_params(PARAMS), outline, PERIOD)
    face = RADIUS + gap
    walls = np.vstack([box_cells(5.0, 1.5, 10.0, 0.1), box_cells(5.0, -1.5, 10.0, 0.1),
                       box_cells(face + 0.1, 0.0, 0.1, 1.4)])
    xs = np.arange(0.0, -6.0, -0.05)
    planner.set_plan(np.column_stack([xs, np.zeros_like(xs), np.full_like(xs, math.pi)]))
    x, v = 0.0, 2.0
    rows = []
    for _ in range(60):
        result = planner.compute_velocity_commands((x, 0.0, 0.0), (v, 0.0),
                                                   rolling_costmap(x, 0.0, walls, size_m=6.0))
        rows.append((result.v, v, face - (x + RADIUS)))
        for _ in range(10):                      # the drive ramps towards the command
            h = PERIOD / 10
            step = v + max(-DRIVE_ACCEL * h, min(DRIVE_ACCEL * h, result.v - v))
            x += 0.5 * (v + step) * h
            v = step
        if v <= 0.0:
            return np.array(rows), True
    return np.array(rows), False


def test_a_band_that_must_brake_brakes_at_acc_lim_x_every_cycle():
    rows, stood = brake_in_front_of_a_wall(2.0)
    command, speed, left = rows.T
    assert stood, "still moving forward after 3 s"
    assert left.min() > 0.3
    # standing within 10 % of 2 m/s / acc_lim_x (1 s), braking at the limit
    assert len(rows) * PERIOD <= 1.1 * 2.0 / PARAMS["acc_lim_x"]
    # the commands fall from one cycle to the next; before the warm start kept the first segment's speed they
    # alternated between braking and speeding up (11 rises in 31 cycles, and the robot hit the wall at 0.94 m/s)
    rises = np.flatnonzero(np.diff(command) > 1e-3)
    assert len(rises) <= 1, f"the command rose in cycles {rises.tolist()}: {np.round(command, 3).tolist()}"
