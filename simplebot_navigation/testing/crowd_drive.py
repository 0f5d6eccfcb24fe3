"""A local planner driven closed loop through a moving-obstacle world without ROS and without physics: the kinematic
crowd run (bench/crowd_kinematic.py, tests/mppi).

A full campaign run costs a lockstep simulator, lidars, the tracker and move_base: minutes per world. This one
keeps only what decides a crowd run: the diff drive's wheel ramp (sim/diff_drive.py, as sim/robot.py applies it),
the world's true obstacle motion (sim/moving.py), its static walls as a local costmap (lethal cells inflated as the
tight set's inflation layer does) and the simulator's rule for whose collision a contact is (sim/robot.py: the
robot's own if a wheel was driven within the last half second). The planner sees every moving obstacle within the
lidars' range exactly (the campaign's ``true_obstacles``), so a run measures the planner, not its perception.

A walker that meets the robot pushes it out of its way, as in the simulator (the walkers are kinematic). The run
ends at the world's success radius (the campaign's ARRIVED), at the first collision while moving (the run has
failed then; ``stop_at_collision``), or when the time budget is spent.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
from scipy import ndimage

from simplebot_description import robot_description
from simplebot_navigation.costmap.cost_values import INSCRIBED_INFLATED_OBSTACLE, LETHAL_OBSTACLE
from simplebot_navigation.costmap.costmap_2d import Costmap2D
from simplebot_navigation.costmap.footprint import footprint_from_radius
from simplebot_navigation.perception.prediction import MotionPrediction
from simplebot_navigation.sim.cspace import occupancy
from simplebot_navigation.sim.diff_drive import drive_for, ramp, wheel_targets
from simplebot_navigation.sim.moving import MovingTracks
from simplebot_navigation.sim.robot import DRIVING_SPEED, DRIVING_WINDOW_S
from simplebot_navigation.sim.world import World

#: the tight set's local costmap (config/tight): 0.025 m cells, inflation radius 0.6 m, cost_scaling_factor 10
RESOLUTION = 0.025
INFLATION_RADIUS = 0.6
COST_SCALING = 10.0
#: the simulated lidars' range (m): what the planner is told about
SENSOR_RANGE_M = 5.6
#: physics steps per control period
SUBSTEPS = 5
#: the session's warm-up: the goal is sent this long (s) after the world's time 0 (scenarios/session.py)
GOAL_SENT_S = 2.0


@dataclass
class Contact:
    t: float
    kind: str              # "moving" or "standing"
    what: str              # "walker <i>" or "wall"
    speed: float           # the robot's speed (m/s) at the contact
    pose: tuple[float, float, float]


@dataclass
class CrowdDrive:
    """One run's outcome: ``arrived`` within the success radius (s after the goal was sent, or inf), the contacts,
    the planner's decisions counted by kind, and the wall time of its cycles (s)."""
    world: str
    arrived_s: float = math.inf
    contacts: list[Contact] = field(default_factory=list)
    kinds: dict[str, int] = field(default_factory=dict)
    cycle_s: list[float] = field(default_factory=list)
    end_distance: float = math.inf
    end_pose: tuple[float, float, float] = (math.nan, math.nan, math.nan)
    #: with ``trace``: per cycle t (s after the goal), x, y, yaw, v, w, the command's v and w, and the decision
    trace: list[tuple] = field(default_factory=list)

    @property
    def moving_collisions(self) -> int:
        return sum(c.kind == "moving" for c in self.contacts)

    @property
    def struck_standing(self) -> int:
        return sum(c.kind == "standing" for c in self.contacts)

    @property
    def success(self) -> bool:
        return math.isfinite(self.arrived_s) and self.moving_collisions == 0


class StaticCostmap:
    """The world's static obstacles as lethal cells with the tight set's inflation, cut to a rolling window."""

    def __init__(self, world: World, inscribed_radius: float, window_m: float):
        occupied, origin = occupancy(world, RESOLUTION)
        pad = int(math.ceil(window_m / RESOLUTION))
        occupied = np.pad(occupied, pad)
        self.origin = (origin[0] - pad * RESOLUTION, origin[1] - pad * RESOLUTION)
        cells = ndimage.distance_transform_edt(~occupied)
        metres = cells * RESOLUTION
        cost = (INSCRIBED_INFLATED_OBSTACLE - 1) * np.exp(-COST_SCALING * (metres - inscribed_radius))
        cost = np.where(metres <= INFLATION_RADIUS, cost, 0.0).astype(np.uint8)
        cost[metres <= inscribed_radius] = INSCRIBED_INFLATED_OBSTACLE
        cost[occupied] = LETHAL_OBSTACLE
        self.grid = cost
        #: distance (m) from each cell centre to the nearest occupied centre, for contacts with walls
        self.clearance = metres - 0.5 * RESOLUTION
        self.size = int(round(window_m / RESOLUTION))

    def window(self, x: float, y: float) -> Costmap2D:
        """The rolling window centred on (x, y), its origin on the grid's cells as costmap_2d's rolling window."""
        col = int(math.floor((x - self.origin[0]) / RESOLUTION)) - self.size // 2
        row = int(math.floor((y - self.origin[1]) / RESOLUTION)) - self.size // 2
        out = Costmap2D(self.size, self.size, RESOLUTION, self.origin[0] + col * RESOLUTION,
                        self.origin[1] + row * RESOLUTION)
        r0, c0 = max(row, 0), max(col, 0)
        r1, c1 = min(row + self.size, self.grid.shape[0]), min(col + self.size, self.grid.shape[1])
        if r1 > r0 and c1 > c0:
            out.costmap[r0 - row:r1 - row, c0 - col:c1 - col] = self.grid[r0:r1, c0:c1]
        return out

    def wall_clearance(self, x: float, y: float) -> float:
        row = int((y - self.origin[1]) / RESOLUTION)
        col = int((x - self.origin[0]) / RESOLUTION)
        if 0 <= row < self.clearance.shape[0] and 0 <= col < self.clearance.shape[1]:
            return float(self.clearance[row, col])
        return math.inf


class TrueFuture(MotionPrediction):
    """A prediction that knows where each obstacle will truly be (the world's tracks from time ``now``), with the
    keep-out radii of the ``settings`` it stands in for: the limit of any predictor. A row is the obstacle whose
    true position it holds; a row that is no obstacle's (a lost track kept moving) is predicted at constant
    velocity."""

    def __init__(self, settings: MotionPrediction, tracks: MovingTracks, now: float):
        super().__init__(settings.horizon, settings.max_uncertainty, settings.radius_growth)
        object.__setattr__(self, "_tracks", tracks)
        object.__setattr__(self, "_now", now)
        object.__setattr__(self, "_states", {})        # the tracks' states by time ahead: the guide asks often

    def _at(self, t: float) -> np.ndarray:
        if t not in self._states:
            self._states[t] = self._tracks.states(self._now + t)
        return self._states[t]

    def centres(self, rows: np.ndarray, times) -> np.ndarray:
        out = super().centres(rows, times)
        if not len(rows):
            return out
        states = self._at(0.0)
        gap = np.hypot(rows[:, None, 0] - states[None, :, 0], rows[:, None, 1] - states[None, :, 1])
        match = gap.argmin(axis=1)
        known = gap[np.arange(len(rows)), match] < 1e-6
        for j, t in enumerate(np.asarray(times, dtype=float)):
            out[known, j] = self._at(float(t))[match[known], :2]
        return out


def straight_plan(start, goal, spacing: float = 0.05) -> np.ndarray:
    """(N, 3) x, y, yaw from ``start`` to ``goal`` (x, y) every ``spacing`` m: a crowd arena and the lab's corridor
    are open along the straight line, which is the global plan there."""
    (x0, y0), (x1, y1) = start, goal
    n = max(2, int(math.ceil(math.hypot(x1 - x0, y1 - y0) / spacing)) + 1)
    yaw = math.atan2(y1 - y0, x1 - x0)
    return np.column_stack([np.linspace(x0, x1, n), np.linspace(y0, y1, n), np.full(n, yaw)])


def drive(world: World, setup: PlannerSetup, speed: float, radius: float = 0.25, stop_at_collision: bool = True,
          clock=None, trace: bool = False, true_future: bool = False) -> CrowdDrive:
    """Drive the planner of ``setup`` (its plan set here) from the world's start to its first goal on the drive the
    simulator gives ``speed``. ``clock``: a zero-argument wall clock for the cycle times (None: not timed);
    ``true_future``: the planner predicts the obstacles with TrueFuture instead of its own prediction."""
    controller = setup.controller
    description = robot_description("round", radius)
    params = drive_for(description, speed)
    separation, wheel_radius = description.wheel_separation, description.wheel_radius
    budget = float(world.extra.get("time_budget", 100.0))
    success_radius = float(world.extra.get("success_radius", 1.0))
    goal = world.goals[0]
    costmap = StaticCostmap(world, radius, setup.window_m)
    tracks = MovingTracks(world.moving)
    radii = tracks.reach
    controller.set_plan(straight_plan((world.start.x, world.start.y), (goal.x, goal.y)))
    out = CrowdDrive(world.source)
    period = 1.0 / setup.controller_frequency
    dt = period / SUBSTEPS
    x, y, yaw = world.start.x, world.start.y, world.start.yaw
    wheels = np.zeros(2)
    driven_at = -math.inf
    touching: set[str] = set()
    t = GOAL_SENT_S
    for _ in range(int(math.ceil(budget / period))):
        v = wheel_radius * (wheels[0] + wheels[1]) / 2
        w = wheel_radius * (wheels[1] - wheels[0]) / separation
        states = tracks.states(t)
        near = np.hypot(states[:, 0] - x, states[:, 1] - y) - radii <= SENSOR_RANGE_M
        controller.set_dynamic_obstacles(np.column_stack([states[near], radii[near]]))
        if true_future:
            controller.prediction_for = lambda settings, now=t: TrueFuture(settings, tracks, now)
        started = clock() if clock else 0.0
        result = controller.compute_velocity_commands((x, y, yaw), (v, w), costmap.window(x, y))
        if clock:
            out.cycle_s.append(clock() - started)
        kind = result.kind if result.ok else "failed"
        out.kinds[kind] = out.kinds.get(kind, 0) + 1
        command = (result.v, result.omega) if result.ok else (0.0, 0.0)
        if trace:
            out.trace.append((round(t - GOAL_SENT_S, 3), x, y, yaw, v, w, *command, kind))
        target = wheel_targets(*command, separation, wheel_radius, params.max_wheel_speed, params.max_yaw_rate)
        for _ in range(SUBSTEPS):
            turn = None if params.max_yaw_accel is None else params.max_yaw_accel * separation / wheel_radius * dt
            wheels = ramp(wheels, target, params.max_wheel_accel * dt, turn)
            if wheel_radius * max(np.abs(target).max(), np.abs(wheels).max()) > DRIVING_SPEED:
                driven_at = t
            v = wheel_radius * (wheels[0] + wheels[1]) / 2
            w = wheel_radius * (wheels[1] - wheels[0]) / separation
            mid = yaw + 0.5 * w * dt
            x, y, yaw = x + v * dt * math.cos(mid), y + v * dt * math.sin(mid), math.remainder(yaw + w * dt, math.tau)
            t += dt
            x, y, now = _contacts(x, y, tracks.states(t), radii, radius, costmap)
            new = now - touching
            for what in sorted(new):
                out.contacts.append(Contact(round(t - GOAL_SENT_S, 3),
                                            "moving" if t - driven_at <= DRIVING_WINDOW_S + 1e-9 else "standing",
                                            what, abs(v), (x, y, yaw)))
            touching = now
        out.end_distance, out.end_pose = math.hypot(goal.x - x, goal.y - y), (x, y, yaw)
        if out.end_distance <= success_radius:
            out.arrived_s = round(t - GOAL_SENT_S, 3)
            break
        if stop_at_collision and out.moving_collisions:
            break
    return out


def _contacts(x: float, y: float, states: np.ndarray, radii: np.ndarray, radius: float, costmap: StaticCostmap
              ) -> tuple[float, float, set[str]]:
    """The robot's position after the walkers that overlap it pushed it out of their way, and what it touches."""
    touching = set()
    for i in np.nonzero(np.hypot(states[:, 0] - x, states[:, 1] - y) < radii + radius)[0]:
        dx, dy = x - states[i, 0], y - states[i, 1]
        d = math.hypot(dx, dy)
        if d > 1e-9:
            push = radii[i] + radius - d
            x, y = x + push * dx / d, y + push * dy / d
        touching.add(f"walker {i}")
    if costmap.wall_clearance(x, y) < radius:
        touching.add("wall")
    return x, y, touching


@dataclass(frozen=True)
class PlannerSetup:
    """A local planner with what move_base's speed setting gives it: the control rate and the local costmap's side."""
    controller: object
    controller_frequency: float
    window_m: float


def mppi_setup(speed: float, radius: float = 0.25, overrides: dict | None = None, seed: int = 0) -> PlannerSetup:
    """The MppiController of a campaign's ``tight max_speed=V base_local_planner=mppi_local_planner/...`` line for
    the round body of ``radius``, with ``overrides`` of its parameters (flat names)."""
    from simplebot_navigation.move_base.speed_profile import speed_parameters
    from simplebot_navigation.mppi import MppiConfig, MppiController
    from simplebot_navigation.mppi.plugin import MPPI_LOCAL_PLANNER

    separation = robot_description("round", radius).wheel_separation
    profile = speed_parameters(speed, False, MPPI_LOCAL_PLANNER, separation)
    prefix = "MPPILocalPlannerROS."
    params = {key[len(prefix):]: value for key, value in profile.items() if key.startswith(prefix)}
    config = MppiConfig.from_params({**params, **(overrides or {})})
    frequency = float(profile["controller_frequency"])
    controller = MppiController(config, footprint_from_radius(radius), 1.0 / frequency, seed=seed)
    return PlannerSetup(controller, frequency, float(profile["local_costmap.width"]))
