"""Autonomous exploration: navigation slam:=true explore:=true maps a world on its own, judged against the world.

    python bench/exploration.py [--worlds lab,office] [--seed 0] [--limit 3000] [--every 100]

Each world runs in lockstep: ``NavigationSession(world, slam=True, explore=True, seed=...)``, the simulator with
drifting encoders, slam (synchronous: every scan, in order), move_base on slam's map and the explore node, which
sends the frontiers of slam's map to move_base as goals. It runs until the explore node reports that no frontier is
left (its ``finished``) or for --limit seconds of sim time. --worlds takes names and world files. Per world:

  done s     sim seconds until the explore node finished ("-": not within the limit; then the time it ran)
  95% s      sim seconds until cover first reached 95 % (measured every 20 s)
  driven m   the distance the robot drove (ground truth)
  goals      frontier goals the explore node sent / given up because move_base failed them / given up otherwise (no
             progress for progress_timeout, or reached with the frontier still there)
  coll       collisions (the simulator's count of the robot driving into something)
  cover %    the share of the reachable free space that slam's map has free. Reachable free space: the free cells
             of the world's exported map (sim/map_export.py, 5 cm) that the robot can reach; the cells its centre
             can reach (at least the inscribed radius from every occupied cell, connected to the start) and the
             cells within sqrt(2) x that radius of them (the room's corners), so that a bay behind a door narrower
             than the robot does not count. Cells are compared in world coordinates (map origins rounded to cells)
  centre %   the same share over the cells the robot's centre can reach only (the walls' neighbours left out)
  prec %     the map's occupied cells within one cell of an occupied cell of the world's map
  wall s     wall-clock seconds of the run

--every N prints the state every N sim seconds while a world runs (time, coverage, goals, the explore node's goal).
The issue's target: cover >= 95 % in the office.
"""

from __future__ import annotations

import argparse
import math
import os
import sys
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from scipy import ndimage

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
os.environ.setdefault("ROS_AUTOMATIC_DISCOVERY_RANGE", "LOCALHOST")

from rclpy.parameter import Parameter  # noqa: E402

from simplebot_navigation.maps.map_io import OccupancyMap  # noqa: E402
from simplebot_navigation.scenarios.session import NavigationSession  # noqa: E402
from simplebot_navigation.sim.map_export import export_map  # noqa: E402
from simplebot_navigation.sim.world import World  # noqa: E402

RESOLUTION = 0.05
#: the issue's mark for the office
TARGET_COVERAGE = 0.95
#: a map cell this many cells from an occupied cell of the world's map is a true wall (slam_drive's tolerance)
TOLERANCE_CELLS = 1
_EIGHT = np.ones((3, 3), bool)
#: coverage is measured this often (sim seconds) while a world runs
CHECK_S = 20.0
#: each world's reference (exported map, reachable free cells, cells the centre reaches), computed once
_REFERENCES: dict[tuple, tuple[OccupancyMap, np.ndarray, np.ndarray]] = {}


@dataclass(frozen=True)
class Coverage:
    swept: float         # share of the reachable free cells that the map has free
    centre: float        # share of the cells the robot's centre can reach that the map has free
    precision: float     # the map's occupied cells near a true obstacle
    reachable_cells: int


@dataclass
class Exploration:
    world: str
    finished: bool
    sim_time: float
    target_at: float | None      # sim time when cover first reached TARGET_COVERAGE (checked every CHECK_S)
    driven: float
    goals_sent: int
    goals_failed: int
    goals_stalled: int
    collisions: int
    coverage: Coverage
    wall: float
    saved: bool = False


def reachable_free(world: World, radius: float, resolution: float = RESOLUTION) -> tuple[OccupancyMap, np.ndarray,
                                                                                          np.ndarray]:
    """(the world's exported map, the free cells the robot can reach, the cells its centre can reach)."""
    truth = export_map(world, resolution)
    free, occupied = truth.data == 0, truth.data == 100
    clear = ndimage.distance_transform_edt(~occupied, sampling=resolution) - resolution / 2
    centre_ok = free & (clear >= radius - 1e-9)
    labels, _ = ndimage.label(centre_ok)
    row = math.floor((world.start.y - truth.origin[1]) / resolution)
    col = math.floor((world.start.x - truth.origin[0]) / resolution)
    if labels[row, col] == 0:
        raise ValueError(f"{world.name}: the start ({world.start.x:g}, {world.start.y:g}) is within {radius} m "
                         "of an obstacle")
    centre = labels == labels[row, col]
    near = ndimage.distance_transform_edt(~centre, sampling=resolution) <= math.sqrt(2.0) * radius + 1e-9
    return truth, free & near, centre


def on_grid(built: OccupancyMap, truth: OccupancyMap) -> np.ndarray:
    """The built map's cells on the truth's grid (same resolution; origins rounded to whole cells), -1 outside it."""
    res = truth.resolution
    if abs(built.resolution - res) > 1e-9:
        raise ValueError(f"resolutions differ: {built.resolution} and {res}")
    dc = round((built.origin[0] - truth.origin[0]) / res)
    dr = round((built.origin[1] - truth.origin[1]) / res)
    out = np.full(truth.data.shape, -1, dtype=np.int8)
    r0, c0 = max(dr, 0), max(dc, 0)
    r1, c1 = min(dr + built.data.shape[0], out.shape[0]), min(dc + built.data.shape[1], out.shape[1])
    if r0 < r1 and c0 < c1:
        out[r0:r1, c0:c1] = built.data[r0 - dr:r1 - dr, c0 - dc:c1 - dc]
    return out


def coverage(built: OccupancyMap, world: World, radius: float) -> Coverage:
    """slam's map against the world (module docstring: cover, centre, prec)."""
    key = (world.source, world.name, radius, built.resolution)
    if key not in _REFERENCES:
        _REFERENCES[key] = reachable_free(world, radius, built.resolution)
    truth, swept, centre = _REFERENCES[key]
    placed = on_grid(built, truth)
    mapped = placed == 0
    near_truth = ndimage.binary_dilation(truth.data == 100, structure=_EIGHT, iterations=TOLERANCE_CELLS)
    occupied = int((built.data == 100).sum())
    return Coverage(float((mapped & swept).sum() / swept.sum()), float((mapped & centre).sum() / centre.sum()),
                    float(((placed == 100) & near_truth).sum() / max(occupied, 1)), int(swept.sum()))


def node_named(session: NavigationSession, name: str):
    return next(n for n in session.nodes if n.get_name() == name)


def driven(truth: list[tuple[float, float, float, float]]) -> float:
    xy = np.asarray([s[1:3] for s in truth]) if truth else np.zeros((0, 2))
    return float(np.hypot(*np.diff(xy, axis=0).T).sum()) if len(xy) > 1 else 0.0


def explore(world: str, seed: int = 0, limit_s: float = 3000.0, save_map: str = "", every_s: float = 0.0,
            wall_timeout_s: float | None = None, **session_kwargs) -> Exploration:
    """Explore ``world`` (a name or a world file) in lockstep until the explore node finishes or ``limit_s`` of sim
    time; with save_map (a path without extension) the explore node saves the map there when it finishes, and the run
    waits for it (without, it saves none)."""
    began = time.monotonic()
    with NavigationSession(world, seed=seed, slam=True, explore=True, **session_kwargs) as session:
        explorer, slam = node_named(session, "explore"), node_named(session, "slam")
        explorer.set_parameters([Parameter("save_map", value=save_map)])      # empty: not saved
        session.wait_ready(wall_timeout_s=120.0)
        finished, target_at, shown = False, None, 0.0
        while not finished and session.time < limit_s:
            finished = session.run_until(min(limit_s, session.time + CHECK_S), lambda: explorer.finished,
                                         wall_timeout_s)
            score = coverage(slam.mapper.occupancy_map(), session.world, session.description.inscribed_radius)
            if target_at is None and score.swept >= TARGET_COVERAGE:
                target_at = session.time
            if every_s > 0 and (session.time >= shown + every_s or finished):
                shown = session.time
                print(f"  {world} t={session.time:7.1f} s  " + _state(session, explorer, score), flush=True)
        done_at = session.time
        saved = False
        if finished and save_map:
            saved = session.run_for(10.0, lambda: Path(save_map + ".yaml").exists() and Path(save_map + ".pgm")
                                    .exists(), wall_timeout_s)
        score = coverage(slam.mapper.occupancy_map(), session.world, session.description.inscribed_radius)
        sent, failed = explorer.goals_sent, explorer.goals_failed
        name = Path(world).stem if world.endswith(".yaml") else world
        return Exploration(name, finished, done_at, target_at, driven(session.client.truth), sent, failed,
                           explorer.goals_given_up - failed, session.client.collisions, score,
                           time.monotonic() - began, saved)


def _state(session: NavigationSession, explorer, score: Coverage) -> str:
    goal = "none" if explorer.goal is None else f"({explorer.goal[0]:.1f}, {explorer.goal[1]:.1f})"
    pose = session.pose()
    return (f"cover {100 * score.swept:5.1f} %  centre {100 * score.centre:5.1f} %  robot ({pose.x:.1f}, "
            f"{pose.y:.1f})  goals {explorer.goals_sent} sent, {explorer.goals_failed} failed, "
            f"{explorer.goals_given_up} given up  goal {goal}  collisions {session.client.collisions}")


def table(rows: list[Exploration]) -> str:
    header = (f"{'world':8} {'done s':>7} {'95% s':>6} {'driven m':>8} {'goals':>9} {'coll':>4} {'cover %':>7} "
              f"{'centre %':>8} {'prec %':>6} {'wall s':>6}")
    lines = [header, "-" * len(header)]
    for r in rows:
        done = f"{r.sim_time:7.0f}" if r.finished else f"-{r.sim_time:6.0f}"
        goals = f"{r.goals_sent}/{r.goals_failed}/{r.goals_stalled}"
        c = r.coverage
        target = "-" if r.target_at is None else f"{r.target_at:.0f}"
        lines.append(f"{r.world:8} {done:>7} {target:>6} {r.driven:8.0f} {goals:>9} {r.collisions:4d} "
                     f"{100 * c.swept:7.1f} {100 * c.centre:8.1f} {100 * c.precision:6.1f} {r.wall:6.0f}")
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> list[Exploration]:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--worlds", default="lab,office", help="worlds, comma-separated (default: lab,office)")
    parser.add_argument("--seed", type=int, default=0, help="simulation seed (default: 0)")
    parser.add_argument("--limit", type=float, default=3000.0, help="sim seconds per world at most (default: 3000)")
    parser.add_argument("--every", type=float, default=0.0, help="print the state every this many sim seconds")
    args = parser.parse_args(argv)
    os.environ.setdefault("ROS_DOMAIN_ID", "42")
    rows = []
    for world in args.worlds.split(","):
        rows.append(explore(world, args.seed, args.limit, every_s=args.every))
        print(f"{world}: {'done' if rows[-1].finished else 'not done'} in {rows[-1].wall:.0f} s wall", flush=True)
    print("\n" + table(rows))
    print(f"goals: sent / failed by move_base / given up otherwise; target: cover >= "
          f"{100 * TARGET_COVERAGE:.0f} % (office); load average (1 min) at the end: {os.getloadavg()[0]:.2f}")
    return rows


if __name__ == "__main__":
    main()
