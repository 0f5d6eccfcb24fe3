"""Goals, time budgets and what counts as success; the loop that runs a scenario and measures it."""

from __future__ import annotations

import math
import os
import tempfile
import time
from dataclasses import asdict, dataclass, field
from typing import Callable

import numpy as np
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import dijkstra

from simplebot_description import RobotDescription
from simplebot_navigation.sim.moving import MovingTracks
from simplebot_navigation.sim.world import Pose2D, World, write_world
from simplebot_navigation.sim.world_gen import clutter_world
from simplebot_navigation.scenarios.localization import LocalizationError, localization_error
from simplebot_navigation.scenarios.process_session import ProcessSession, RemoteSession
from simplebot_navigation.scenarios.session import NavigationSession

BUDGET_SLACK = 2.0        # budget = BUDGET_FIXED_S + BUDGET_SLACK * shortest path / max_vel_x
BUDGET_FIXED_S = 20.0
CANCEL_WAIT_S = 5.0       # sim seconds a goal over its budget gets to report CANCELED
GRID_RESOLUTION = 0.1     # of the shortest-path estimate
PATH_CLEARANCE = 0.2      # free space for that estimate (less than any body's half width: doors stay open)
FOOTPRINT_SPACING = 0.02  # sampling of the box outline for the clearance
TRAJECTORY_PERIOD_S = 0.1  # sampling of the trajectories kept in the results
#: the BARN challenge's reference speed (m/s): its optimal time is the reference path at this speed
CHALLENGE_SPEED = 2.0


@dataclass
class GoalResult:
    run: int
    goal: str
    x: float
    y: float
    yaw: float
    status: str                  # SUCCEEDED / ARRIVED (within the world's success_radius) / ABORTED / CANCELED / REJECTED / TIMEOUT / HUNG
    success: bool
    failures: list[str]          # why it is not a success
    reason: str                  # move_base's status text
    time_s: float                # sim seconds from sending to the result
    budget_s: float
    path_length: float           # driven, from ground truth
    straight_line: float
    collisions: int              # while the robot moved (drove into something): a failure
    min_clearance: float         # metres between the body and the nearest obstacle
    replans: int | None          # None: move_base ran in another process
    recoveries: int | None
    cycle_p95_ms: float | None
    cycles_missed: int | None
    final: tuple[float, float, float]
    position_error: float
    yaw_error: float
    wall_s: float                # wall-clock seconds the goal took to simulate
    max_vel_x: float             # the local planner's top speed during the goal
    trajectory: list[tuple[float, float, float, float]] = field(repr=False)
    struck_standing: int = 0     # a moving obstacle ran into the standing robot: reported, not a failure
    localization: LocalizationError | None = None   # on a map: amcl's pose against ground truth during the goal
    reference_length: float = math.nan   # the shortest C-space path from the start to the goal (m)
    #: local planner type -> times it took over during the goal (docs/design.md §7.1; None: another process)
    handovers: dict[str, int] | None = None

    @property
    def time_ratio(self) -> float:
        """Time to goal over the time the driven path takes at top speed (1.0: never slower than max_vel_x)."""
        if not self.success or self.path_length <= 1e-6:
            return math.nan
        return self.time_s / (self.path_length / self.max_vel_x)

    @property
    def challenge_score(self) -> float:
        return challenge_score(self.success, self.time_s, self.reference_length)

    def to_dict(self) -> dict:
        return {**asdict(self), "challenge_score": self.challenge_score}


@dataclass(frozen=True)
class ScenarioOptions:
    world: str = "lab"
    robot: str = "box"
    radius: float = 0.3
    goals: str | None = None       # None: the world file's goals; else "x,y,yaw;..." and/or names
    rtf: float = 0.0
    repeat: int = 1
    seed: int = 0
    range_noise: float = 0.0
    tight: bool = False            # the narrow-door parameter set (config/tight/)
    time_budget: float | None = None  # sim s per goal; None: from the shortest path and max_vel_x
    processes: bool = False        # the launcher's processes (rtf > 0) instead of nodes in this process
    wall_timeout_s: float | None = None  # per goal, a guard against hangs
    overrides: tuple[str, ...] = ()      # --set NAME=VALUE for move_base
    foxglove_port: int | None = None     # serve the run to the Foxglove app on this port (0: a free one)
    collision_monitor: bool = True       # False: move_base drives the base directly
    map_name: str = ""             # navigate on this map (a map YAML; "world": the run's world's), amcl localizing
    max_speed: float | None = None  # the one speed setting (docs/reference.md §10); None: the parameter files'
    moving_obstacles: bool = True   # False: nothing tracked or predicted, every obstacle a costmap mark
    true_obstacles: bool = False    # the simulator's moving obstacles instead of the tracker's (true_obstacles.py)


# -- goals -----------------------------------------------------------------------------------------
def parse_goals(text: str | None, world: World) -> list[Pose2D]:
    """--goals: items separated by ';', each "x,y[,yaw]" (world frame) or goal names separated by ','."""
    if text is None:
        if not world.goals:
            raise ValueError(f"world {world.name!r} ({world.source}) has no goals; give --goals")
        return [g if g.name else Pose2D(g.x, g.y, g.yaw, f"goal_{i}") for i, g in enumerate(world.goals)]
    goals: list[Pose2D] = []
    for item in (part.strip() for part in text.split(";")):
        if not item:
            raise ValueError(f"--goals {text!r}: empty item (use 'x,y,yaw;x,y,yaw' or goal names)")
        fields = [f.strip() for f in item.split(",")]
        numbers = []
        for value in fields:
            try:
                numbers.append(float(value))
            except ValueError:
                break
        if len(numbers) == len(fields):
            if len(numbers) not in (2, 3) or not all(math.isfinite(v) for v in numbers):
                raise ValueError(f"--goals: {item!r} must be 'x,y' or 'x,y,yaw' with finite numbers")
            x, y, yaw = (*numbers, 0.0)[:3]
            goals.append(Pose2D(x, y, yaw, f"({x:g}, {y:g})"))
        elif numbers:
            raise ValueError(f"--goals: {item!r} mixes numbers and names")
        else:
            goals += [world.goal(name) for name in fields]
    return goals


def map_for_run(map_name: str, world: str) -> str:
    """--map: "world" is the map of the run's world (exported by map_server), anything else a map YAML."""
    return world if map_name == "world" else map_name


def world_for_run(world: str, seed: int, folder: str) -> str:
    """The world argument of one run: 'clutter' is regenerated with the run's seed, 'forest', 'crowd'
    and 'people' are that family's world <seed>, others as given."""
    if world in ("forest", "crowd", "people"):
        return f"{world}:{seed}"
    if world != "clutter":
        return world
    path = os.path.join(folder, f"clutter_{seed}.yaml")
    write_world(clutter_world(seed), path, header=f"clutter_world(seed={seed})")
    return path


# -- budget ----------------------------------------------------------------------------------------
def shortest_path_length(world: World, start: Pose2D, goal: Pose2D) -> float:
    """Length of the shortest 8-connected path on a grid of the world, or the straight line if none."""
    straight = math.hypot(goal.x - start.x, goal.y - start.y)
    xmin, ymin, xmax, ymax = world.bounds()
    xmin, ymin = min(xmin, start.x, goal.x) - 1.0, min(ymin, start.y, goal.y) - 1.0
    xmax, ymax = max(xmax, start.x, goal.x) + 1.0, max(ymax, start.y, goal.y) + 1.0
    xs = np.arange(xmin, xmax + GRID_RESOLUTION, GRID_RESOLUTION)
    ys = np.arange(ymin, ymax + GRID_RESOLUTION, GRID_RESOLUTION)
    gx, gy = np.meshgrid(xs, ys)
    free = (world.distance(np.column_stack((gx.ravel(), gy.ravel()))) > PATH_CLEARANCE).reshape(gx.shape)
    index = np.arange(free.size).reshape(free.shape)
    rows, cols, weights = [], [], []
    for di, dj in ((0, 1), (1, 0), (1, 1), (1, -1)):
        a = free[max(0, -di):free.shape[0] - max(0, di), max(0, -dj):free.shape[1] - max(0, dj)]
        b = free[max(0, di):, max(0, dj):][:a.shape[0], :a.shape[1]]
        both = a & b
        ia = index[max(0, -di):free.shape[0] - max(0, di), max(0, -dj):free.shape[1] - max(0, dj)][both]
        ib = index[max(0, di):, max(0, dj):][:a.shape[0], :a.shape[1]][both]
        rows += [ia, ib]
        cols += [ib, ia]
        weights += [np.full(2 * len(ia), math.hypot(di, dj) * GRID_RESOLUTION)]
    graph = coo_matrix((np.concatenate(weights), (np.concatenate(rows), np.concatenate(cols))),
                       shape=(free.size, free.size)).tocsr()

    def cell(p: Pose2D) -> int:
        i = int(np.clip(round((p.y - ymin) / GRID_RESOLUTION), 0, len(ys) - 1))
        j = int(np.clip(round((p.x - xmin) / GRID_RESOLUTION), 0, len(xs) - 1))
        return int(index[i, j])

    length = float(dijkstra(graph, indices=cell(start))[cell(goal)])
    return length if math.isfinite(length) else straight


def reference_length(world: World, start: Pose2D, goal: Pose2D) -> float:
    """The shortest C-space path from start to goal: a generated world's own (sim/cspace.py, on the grid of
    its robot's radius and margin) for its start and goal, else shortest_path_length."""
    cspace = world.extra.get("cspace")
    if cspace and world.goals and math.hypot(start.x - world.start.x, start.y - world.start.y) < 0.05 \
            and math.hypot(goal.x - world.goals[0].x, goal.y - world.goals[0].y) < 0.05:
        return float(cspace["path_length"])
    return shortest_path_length(world, start, goal)


def challenge_score(success: bool, time_s: float, reference: float) -> float:
    """The BARN challenge's score of one run (2024 on): success x OT / clip(AT, 2 OT, 8 OT), OT the reference
    path at CHALLENGE_SPEED; at most 0.5, reached at half that speed along the reference path. Success is this
    project's (within the goal tolerance, no collision, within the time budget), which is stricter than the
    challenge's 1 m of the goal."""
    if not success or not (math.isfinite(reference) and reference > 0 and math.isfinite(time_s)):
        return 0.0
    optimal = reference / CHALLENGE_SPEED
    return optimal / min(max(time_s, 2.0 * optimal), 8.0 * optimal)


def time_budget(world: World, start: Pose2D, goal: Pose2D, max_vel_x: float) -> float:
    """The world's own time_budget, else from the shortest path and the top speed."""
    if "time_budget" in world.extra:
        return float(world.extra["time_budget"])
    return BUDGET_FIXED_S + BUDGET_SLACK * shortest_path_length(world, start, goal) / max_vel_x


# -- measures --------------------------------------------------------------------------------------
def body_outline(description: RobotDescription) -> np.ndarray | None:
    """Points along the box outline in base_link (None for the round body, measured by its radius)."""
    if description.radius is not None:
        return None
    corners = np.asarray(description.footprint, float)
    points = []
    for a, b in zip(corners, np.roll(corners, -1, axis=0)):
        n = max(1, math.ceil(np.linalg.norm(b - a) / FOOTPRINT_SPACING))
        points.append(a + (b - a) * np.arange(n)[:, None] / n)
    return np.concatenate(points)


def min_clearance(world: World, description: RobotDescription, truth: np.ndarray) -> float:
    """Smallest distance between the robot body and any obstacle over (N, 4) ground-truth samples
    (t, x, y, yaw) in the world frame (0: touching); moving obstacles are taken where they were at each
    sample's time, as circles of their bounding radius (a box's clearance is underestimated)."""
    if len(truth) == 0:
        return math.nan
    outline = body_outline(description)
    if outline is None:
        points = truth[:, None, 1:3]
        static = float(max(0.0, np.min(world.distance(truth[:, 1:3])) - description.radius))
        inflate = description.radius
    else:
        c, s = np.cos(truth[:, 3])[:, None], np.sin(truth[:, 3])[:, None]
        points = np.stack([truth[:, 1:2] + c * outline[:, 0] - s * outline[:, 1],
                           truth[:, 2:3] + s * outline[:, 0] + c * outline[:, 1]], axis=2)
        static = float(np.min(world.distance(points.reshape(-1, 2))))
        inflate = 0.0
    if not world.moving:
        return static
    tracks = MovingTracks(world.moving)
    moving = math.inf
    for t, body in zip(truth[:, 0], points):
        centres = tracks.states(float(t))[:, :2]
        gaps = np.hypot(body[:, None, 0] - centres[:, 0], body[:, None, 1] - centres[:, 1]) - tracks.reach
        moving = min(moving, float(gaps.min()) - inflate)
    return min(static, max(0.0, moving))


# -- the loop --------------------------------------------------------------------------------------
def run_goal(session: NavigationSession | RemoteSession, goal: Pose2D, budget_s: float, run_index: int = 0,
             wall_timeout_s: float | None = None) -> GoalResult:
    """Send one goal, advance until its result or its budget (then cancel), and measure it."""
    start = session.pose()
    collisions0, struck0, stats0 = session.client.collisions, session.client.struck_standing, session.stats()
    wall_start = time.monotonic()
    run = session.send_goal(goal)
    hung, timed_out, arrived = "", False, False
    success_radius = session.world.extra.get("success_radius")

    def within_success_radius() -> bool:
        truth = session.client.truth
        return bool(success_radius and truth and math.hypot(truth[-1][1] - goal.x, truth[-1][2] - goal.y)
                    <= success_radius)

    try:
        session.run_until(run.sent_at + budget_s, lambda: run.done or within_success_radius(), wall_timeout_s)
        arrived = within_success_radius()
        timed_out = not run.done and not arrived
        if not run.done:
            session.cancel(run)
            session.run_until(session.time + CANCEL_WAIT_S, lambda: run.done, wall_timeout_s)
    except TimeoutError as err:  # the wall-clock guard: the session is not fit for more goals
        hung = str(err)
    end = run.finished_at if run.done and not arrived else session.time
    truth = np.array(session.truth_since(run.sent_at, end) or [(session.time, start.x, start.y, start.yaw)])
    final = (float(truth[-1, 1]), float(truth[-1, 2]), float(truth[-1, 3]))
    position_error = math.hypot(final[0] - goal.x, final[1] - goal.y)
    yaw_error = abs(math.remainder(final[2] - goal.yaw, 2 * math.pi))
    xy_tol = session.controller_param("xy_goal_tolerance", 0.2)
    yaw_tol = session.controller_param("yaw_goal_tolerance", 0.1)
    collisions = session.client.collisions - collisions0
    struck_standing = session.client.struck_standing - struck0
    stats = session.stats()
    cycles = stats.cycles.since(stats0.cycles) if stats else None
    status = "HUNG" if hung else "TIMEOUT" if timed_out else run.status
    time_s = end - run.sent_at
    failures = []
    if hung:
        failures.append(f"hung: {hung}")
    elif timed_out:
        failures.append(f"timeout: no result within the {budget_s:.0f} s budget")
    elif arrived:
        status = "ARRIVED"
    elif status != "SUCCEEDED":
        failures.append(status.lower() + (f": {run.reason}" if run.reason else ""))
    if not arrived:
        failures += _pose_failures(position_error, yaw_error, success_radius, xy_tol, yaw_tol)
    if collisions:
        failures.append(f"{collisions} collision(s) while moving")
    return GoalResult(
        run=run_index, goal=goal.name or f"({goal.x:g}, {goal.y:g})", x=goal.x, y=goal.y, yaw=goal.yaw,
        status=status, success=not failures, failures=failures, reason=run.reason, time_s=time_s,
        budget_s=budget_s, path_length=float(np.sum(np.hypot(*np.diff(truth[:, 1:3], axis=0).T))),
        straight_line=math.hypot(goal.x - start.x, goal.y - start.y), collisions=collisions,
        min_clearance=min_clearance(session.world, session.description, truth),
        replans=stats.navigation.replans - stats0.navigation.replans if stats else None,
        recoveries=stats.navigation.recoveries - stats0.navigation.recoveries if stats else None,
        cycle_p95_ms=cycles.percentile_s(95) * 1e3 if cycles and cycles.cycles else None,
        cycles_missed=cycles.missed if cycles else None,
        final=final, position_error=position_error, yaw_error=yaw_error,
        wall_s=time.monotonic() - wall_start, max_vel_x=session.controller_param("max_vel_x", 0.4),
        trajectory=_thinned(truth), struck_standing=struck_standing,
        localization=localization_error(session.client.localized, truth) if session.map_name else None,
        reference_length=reference_length(session.world, start, goal),
        handovers=stats.navigation.handovers_since(stats0.navigation) if stats else None)


def _pose_failures(position_error, yaw_error, success_radius, xy_tol, yaw_tol) -> list[str]:
    """Where the robot ended against the goal: within the world's success_radius when it has one
    (the benchmark's arrival, yaw free), else within move_base's goal tolerances."""
    if success_radius:
        return [f"{position_error:.2f} m from the goal (success radius {success_radius:g})"] \
            if position_error > success_radius else []
    failures = []
    if position_error > xy_tol:
        failures.append(f"{position_error:.2f} m from the goal (xy_goal_tolerance {xy_tol:g})")
    if yaw_error > yaw_tol:
        failures.append(f"yaw off by {yaw_error:.2f} rad (yaw_goal_tolerance {yaw_tol:g})")
    return failures


def _thinned(truth: np.ndarray) -> list[tuple[float, ...]]:
    """Ground-truth samples every TRAJECTORY_PERIOD_S (and the last one), for the results and the plot."""
    keep, last = [], -math.inf
    for row in truth[:-1]:
        if row[0] >= last + TRAJECTORY_PERIOD_S - 1e-9:
            keep.append(row)
            last = row[0]
    keep.append(truth[-1])
    return [tuple(float(v) for v in row) for row in keep]


def run_scenarios(options: ScenarioOptions, progress: Callable[[str], None] = print
                  ) -> tuple[list[GoalResult], list[World]]:
    """Every goal of the scenario, in order, options.repeat times (run i uses seed options.seed + i).

    Returns the results and the world of each run (``clutter`` and ``forest`` differ from seed to seed).
    """
    if options.repeat < 1:
        raise ValueError(f"--repeat must be >= 1, got {options.repeat}")
    if options.time_budget is not None and not (math.isfinite(options.time_budget) and options.time_budget > 0):
        raise ValueError(f"--time-budget must be a positive number of sim seconds, got {options.time_budget}")
    results: list[GoalResult] = []
    worlds: list[World] = []
    for index in range(options.repeat):
        seed = options.seed + index
        session_class = ProcessSession if options.processes else NavigationSession
        truth = {"true_obstacles": True} if options.true_obstacles else {}    # ProcessSession refuses it
        with tempfile.TemporaryDirectory(prefix="simplebot_scenarios_") as folder:
            world = world_for_run(options.world, seed, folder)
            with session_class(world, options.robot, options.radius, options.rtf, seed, options.range_noise,
                               tight=options.tight, overrides=options.overrides, foxglove_port=options.foxglove_port,
                               collision_monitor=options.collision_monitor,
                               map_name=map_for_run(options.map_name, world), max_speed=options.max_speed,
                               moving_obstacles=options.moving_obstacles, **truth) as session:
                worlds.append(session.world)
                results += _run_goals(session, options, index, seed, progress)
    return results, worlds


def _run_goals(session, options: ScenarioOptions, index: int, seed: int, progress) -> list[GoalResult]:
    goals = parse_goals(options.goals, session.world)
    session.wait_ready(wall_timeout_s=options.wall_timeout_s or 120.0)
    max_vel_x = session.controller_param("max_vel_x", 0.4)
    results = []
    for number, goal in enumerate(goals, 1):
        budget = options.time_budget or time_budget(session.world, session.pose(), goal, max_vel_x)
        result = run_goal(session, goal, budget, index, options.wall_timeout_s)
        results.append(result)
        verdict = "ok  " if result.success else "FAIL"
        why = "" if result.success else "  (" + "; ".join(result.failures) + ")"
        located = f", amcl {result.localization.text()}" if result.localization else ""
        progress(f"[run {index + 1}/{options.repeat} seed {seed}] goal {number}/{len(goals)} "
                 f"{result.goal}: {verdict} {result.status} in {result.time_s:.1f} s sim "
                 f"(budget {budget:.0f} s), path {result.path_length:.1f} m, "
                 f"clearance {result.min_clearance:.2f} m{located}, {result.wall_s:.0f} s wall{why}")
        if result.status == "HUNG":
            progress(f"[run {index + 1}/{options.repeat}] the nodes hung: "
                     f"{len(goals) - number} goal(s) of this run skipped")
            break
    return results
