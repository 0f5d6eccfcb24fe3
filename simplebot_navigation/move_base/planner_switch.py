"""Who drives when (docs/design.md §7.1): move_base's base local planner, or its crowd planner while moving
obstacles are near.

TEB (the base) excels in static narrow passages: its band bends through a door a sampling controller's rollouts do
not find. Among moving people it cannot choose a gap and a time; MPPI with its space-time guide and passive safety
can (docs/reference.md §4.10). So the crowd planner drives while a moving obstacle is, or at its current velocity
will be within ``crowd_lookahead``, nearer than ``crowd_distance`` to the robot's body, and the base planner takes
back once none has been for ``crowd_release_time``. The planner that takes over starts afresh from where the robot
is: it is reset and given the current global plan (a band or a control sequence kept from minutes ago means nothing
now). Without moving obstacles nothing changes: the base planner drives every cycle, as it did alone.

Pure: the node hands in the two planners (move_base/plugins.py's LocalPlannerPlugin) and a function that says
whether moving obstacles are near this cycle's pose.
"""

from __future__ import annotations

import math
from typing import Callable

import numpy as np

from simplebot_navigation.move_base.config import MoveBaseConfig
from simplebot_navigation.move_base.plugins import ControlResult

#: the predicted paths are looked at this often (s) up to crowd_lookahead
LOOKAHEAD_STEP_S = 0.25


def moving_obstacle_near(rows: np.ndarray, xy, reach: float, lookahead: float, distance: float) -> bool:
    """Whether any moving obstacle (rows (K, >= 5): x, y, vx, vy, radius) is, or at its current velocity will be
    within ``lookahead`` s, less than ``distance`` from a robot standing at ``xy`` whose body reaches ``reach``
    from its centre."""
    rows = np.asarray(rows, dtype=float)
    if rows.size == 0:
        return False
    times = np.linspace(0.0, lookahead, max(1, math.ceil(lookahead / LOOKAHEAD_STEP_S)) + 1)
    dx = rows[:, None, 0] + times[None] * rows[:, None, 2] - xy[0]
    dy = rows[:, None, 1] + times[None] * rows[:, None, 3] - xy[1]
    gap = np.hypot(dx, dy) - rows[:, None, 4] - reach
    return bool((gap < distance).any())


def feed_near(feed, frame: str, footprint: Callable[[], np.ndarray], cfg: MoveBaseConfig,
              clock: Callable[[], float]) -> Callable[[tuple], bool]:
    """The switch's ``near`` for move_base: the obstacle feed's moving obstacles (perception/feed.py) in the local
    costmap's ``frame`` now, against the body the local costmap's ``footprint()`` reaches."""
    def near(pose) -> bool:
        rows = feed.moving_obstacles(clock(), frame).rows
        reach = float(np.hypot(*np.asarray(footprint(), dtype=float).T).max())
        return moving_obstacle_near(rows, pose[:2], reach, cfg.crowd_lookahead, cfg.crowd_distance)
    return near


class LocalPlannerSwitch:
    """The Controller MoveBaseCore drives (move_base/plugins.py): ``base``, or ``crowd`` (None: base only) while
    ``near(pose)`` says moving obstacles are near. ``cfg`` is move_base's running configuration (its crowd_*
    parameters change live), ``clock`` the node's time in seconds; ``handed_over(planner, why)`` hears of each
    handover (the type name of the planner that drives from now on)."""

    def __init__(self, base, crowd, near: Callable[[tuple], bool], cfg: MoveBaseConfig, clock: Callable[[], float],
                 handed_over: Callable[[str, str], None], names: tuple[str, str] = ("base", "crowd")):
        self.base, self.crowd, self.near, self.cfg, self.clock = base, crowd, near, cfg, clock
        self.handed_over, self.names = handed_over, names
        self.active = base
        self._plan: np.ndarray | None = None
        self._near_at = -math.inf

    @property
    def driving(self) -> str:
        """The type name of the planner that drives now."""
        return self.names[self.active is self.crowd]

    # -- the Controller interface ------------------------------------------------------------------
    def begin_cycle(self, pose) -> None:
        if self.crowd is not None and pose is not None:
            now = self.clock()
            if self.near(pose):
                self._near_at = now
            wanted = self.crowd if now - self._near_at <= self.cfg.crowd_release_time else self.base
            if wanted is not self.active:
                self._hand_over(wanted)
        self.active.begin_cycle(pose)

    def _hand_over(self, planner) -> None:
        self.active = planner
        planner.reset()
        if self._plan is not None:
            planner.set_plan(self._plan)
        why = "moving obstacles near" if planner is self.crowd else \
            f"no moving obstacle near for {self.cfg.crowd_release_time:g} s"
        self.handed_over(self.driving, why)

    def set_plan(self, plan: np.ndarray) -> bool:
        self._plan = plan
        return self.active.set_plan(plan)

    def compute(self) -> ControlResult:
        return self.active.compute()

    def is_goal_reached(self) -> bool:
        return self.active.is_goal_reached()

    def reset(self) -> None:
        """The goal ended: both forget it, and the base planner drives the next one until moving obstacles come."""
        self._plan = None
        self._near_at = -math.inf
        for planner in self._planners():
            planner.reset()
        self.active = self.base

    # -- what live changes call --------------------------------------------------------------------
    def reconfigure(self, config) -> None:
        """The base planner's namespace changed."""
        self.base.reconfigure(config)

    def reconfigure_crowd(self, config) -> None:
        if self.crowd is not None:
            self.crowd.reconfigure(config)

    def set_controller_frequency(self, controller_frequency: float) -> None:
        for planner in self._planners():
            planner.set_controller_frequency(controller_frequency)

    def set_costmap_footprint(self, footprint) -> None:
        for planner in self._planners():
            planner.set_costmap_footprint(footprint)

    def _planners(self) -> tuple:
        return (self.base,) if self.crowd is None else (self.base, self.crowd)
