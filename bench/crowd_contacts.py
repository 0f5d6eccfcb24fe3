"""What happens at each contact in the moving-obstacle worlds: the evidence behind a failed crowd run.

    python bench/crowd_contacts.py --worlds crowd:1,people:4 [--max-speed 1.0] [--teb] [--true-obstacles]

Runs each world as the crowd campaign does (lockstep, the round body r = 0.25, the narrow-passage set, the larger
global costmap, MPPI unless --teb; --true-obstacles: scenarios/true_obstacles.py) and prints one row per new
contact: sim time, the simulator's verdict (moving: the robot drove within the last 0.5 s; standing: it was
struck), what it touched, the robot's true speed and turn rate then and 0.5 s before, where the obstacle was in
the robot's frame (ahead x, left y) and its velocity there, how fast the two closed in and how much of that was the
robot's, whether the tracker had a moving track within 0.6 m of the obstacle, and the local planner's last
decision (MPPI's passive safety). Each world ends with its result, its distance to the goal and how far the robot
was pushed off its odometry (true pose against odometry, both from the start). The table ends with the load.
"""

from __future__ import annotations

import argparse
import math
import os
import sys
import tempfile
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from simplebot_navigation.scenarios.runner import parse_goals, run_goal, time_budget, world_for_run  # noqa: E402
from simplebot_navigation.scenarios.session import NavigationSession  # noqa: E402

CAMPAIGN = ("global_costmap.width=50.0", "global_costmap.height=50.0", "global_costmap.origin_x=-25.0",
            "global_costmap.origin_y=-25.0")
MPPI = "base_local_planner=mppi_local_planner/MPPILocalPlannerROS"
#: a moving track this close to an obstacle's centre is the tracker's view of it (m), as bench/tracking_truth.py
TRACK_GATE_M = 0.6
#: the robot's speed this long before a contact is also shown (s): the simulator's DRIVING_WINDOW_S
BEFORE_S = 0.5


class ContactLog:
    """Observes every lockstep step: the robot's recent true speeds, and a row at each new contact."""

    def __init__(self, session: NavigationSession):
        self.session = session
        self.sim = session.sim.sim
        self.rows: list[str] = []
        self.count = 0
        self.speeds: list[tuple[float, float, float]] = []      # (t, v, w)
        session.driver.on_step(self._step)

    def _tracks_near(self, obstacle_xy: np.ndarray) -> bool:
        """Whether a moving track lies within TRACK_GATE_M of the obstacle (tracks are in odometry)."""
        truth, odom = self.sim.ground_truth(), self.sim.odometry()
        turn = odom.yaw - truth.yaw
        c, s = math.cos(turn), math.sin(turn)
        dx, dy = obstacle_xy[0] - truth.x, obstacle_xy[1] - truth.y
        in_odom = (odom.x + c * dx - s * dy, odom.y + s * dx + c * dy)
        tracker = self.session.move_base.obstacle_tracking.tracker
        return any(track.moving and math.dist(track.position, in_odom) <= TRACK_GATE_M for track in tracker.tracks())

    def _step(self) -> None:
        t = self.sim.sim_time
        truth = self.sim.ground_truth()
        self.speeds.append((t, truth.vx, truth.wz))
        del self.speeds[:-200]
        report = self.sim.collisions()
        if report.count <= self.count:
            return
        self.count = report.count
        states = self.sim.moving_obstacle_states()
        label = report.last_obstacle or "?"
        hit = next((st for st in states if st.label == label), None)
        before = next((v for tt, v, _ in reversed(self.speeds) if tt <= t - BEFORE_S), float("nan"))
        kind = getattr(getattr(self.session.move_base.controller, "planner", None), "last_kind", "")
        if hit is None:          # a wall or another static obstacle
            self.rows.append(f"  {t:6.2f} {report.last_kind:8s} {label[:22]:22s} v {truth.vx:5.2f} w {truth.wz:5.2f} "
                             f"(v {before:5.2f} 0.5 s before)  {kind}")
            return
        c, s = math.cos(truth.yaw), math.sin(truth.yaw)
        dx, dy = hit.x - truth.x, hit.y - truth.y
        rel = (c * dx + s * dy, -s * dx + c * dy)
        vel = (c * hit.vx + s * hit.vy, -s * hit.vx + c * hit.vy)
        distance = math.hypot(*rel)
        closing_obstacle = -(rel[0] * vel[0] + rel[1] * vel[1]) / distance
        closing_robot = truth.vx * rel[0] / distance
        tracked = "tracked" if self._tracks_near(np.array([hit.x, hit.y])) else "UNTRACKED"
        self.rows.append(f"  {t:6.2f} {report.last_kind:8s} {label[:22]:22s} v {truth.vx:5.2f} w {truth.wz:5.2f} "
                         f"(v {before:5.2f} 0.5 s before)  at ({rel[0]:5.2f}, {rel[1]:5.2f}) moving "
                         f"({vel[0]:5.2f}, {vel[1]:5.2f})  closing {closing_obstacle + closing_robot:5.2f} m/s, robot "
                         f"{closing_robot:5.2f}  {tracked:9s} {kind}")


def odometry_drift(sim, start) -> float:
    """How far the true pose is from where odometry (which starts at the start pose) puts it (m)."""
    truth, odom = sim.ground_truth(), sim.odometry()
    c, s = math.cos(start.yaw), math.sin(start.yaw)
    dx, dy = truth.x - start.x, truth.y - start.y
    return math.hypot(c * dx + s * dy - odom.x, -s * dx + c * dy - odom.y)


def run_world(world: str, speed: float, teb: bool, true_obstacles: bool) -> list[str]:
    overrides = CAMPAIGN + (() if teb else (MPPI,))
    with tempfile.TemporaryDirectory(prefix="crowd_contacts_") as folder, \
            NavigationSession(world_for_run(world, 0, folder), "round", 0.25, rtf=0.0, seed=0, tight=True,
                              overrides=overrides, max_speed=speed, true_obstacles=true_obstacles) as session:
        (goal,) = parse_goals(None, session.world)[:1]
        session.wait_ready(wall_timeout_s=300.0)
        start = session.pose()
        log = ContactLog(session)
        budget = time_budget(session.world, start, goal, session.controller_param("max_vel_x", 0.4))
        result = run_goal(session, goal, budget)
        drift = odometry_drift(session.sim.sim, start)
    verdict = "ok" if result.success else "FAIL"
    return [f"{world}: {verdict} in {result.time_s:.1f} s, {result.collisions} moving / {result.struck_standing} "
            f"struck, {result.position_error:.2f} m from the goal, pushed {drift:.2f} m off odometry", *log.rows]


def main() -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--worlds", required=True, help="comma-separated worlds, e.g. crowd:1,people:4")
    p.add_argument("--max-speed", type=float, default=1.0)
    p.add_argument("--teb", action="store_true", help="the default local planner (TEB) instead of MPPI")
    p.add_argument("--true-obstacles", action="store_true", help="the simulator's obstacles instead of the tracker's")
    args = p.parse_args()
    load = os.getloadavg()[0]
    for world in args.worlds.split(","):
        print("\n".join(run_world(world.strip(), args.max_speed, args.teb, args.true_obstacles)), flush=True)
    print(f"load1 {load:.2f} before, {os.getloadavg()[0]:.2f} after; {'TEB' if args.teb else 'MPPI'}, "
          f"max_speed {args.max_speed:g}{', true obstacles' if args.true_obstacles else ''}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
