"""The collision monitor's judgement: how much of a velocity command may reach the wheels, given the lidars.

It stands between the local planner and the base (docs/reference.md §5), sees only the raw scans in the
robot frame and the command, and trusts neither the planner nor the costmaps. Three checks, each with the
body's own outline (the footprint, or a circle of robot_radius):

- stop: the body, driven along the command's arc (forward or reversing), would touch a point within
  ``stop_distance`` of travel: the speed becomes zero (turning on the spot stays, as the approach check
  allows it);
- slowdown: the same within ``slowdown_distance``: the command is scaled by ``slowdown_ratio``;
- approach: the body driven along the command's arc for ``time_before_collision`` in steps of
  ``simulation_time_step``; a contact after t seconds scales the command by t / time_before_collision,
  so the robot slows as it nears and stops short of what it would hit.

The zones are swept along the commanded motion, not fixed around the body, so a robot nose to a wall may
back off and turn away, and one that turns past a door post a centimetre off is not stopped by it: only
motion into a point is.
Each check needs ``min_points`` points, so one speck of noise does not stop the robot. Returns of a person the
tracker follows move with the person (``track_velocities``), and count against a command only where it meets them
sooner than standing still would. No rclpy here.
"""

from __future__ import annotations

import enum
import math
from dataclasses import dataclass

import numpy as np

from simplebot_navigation.costmap.footprint import footprint_radii, parse_footprint
from simplebot_navigation.laser_scan import scan_problem
from simplebot_navigation.geometry import inverse_transform_points
from simplebot_navigation.parameters.spec import ParameterError, fields_of, param
from simplebot_navigation.safety import collision_kernels as kernels

#: below these a command is standing still: no zone applies to it
STANDING_SPEED = 1e-3
STANDING_TURN_RATE = 1e-3
#: the approach check places the body at most this many times per command
MAX_APPROACH_STEPS = 200
#: a return too close to measure is placed this far outside the body
TOUCH_MARGIN = 0.005
#: the stop and slowdown zones are walked along the arc in steps of this length (m)
ZONE_STEP = 0.01
#: the stop zone covers at least a zone step and a centimetre of lidar noise and creep (m)
MIN_STOP_DISTANCE = 0.02
#: a 3 cm table leg 1 m away gives about 5 returns of the simulated lidars (0.35 degrees apart)
MAX_MIN_POINTS = 5
#: the approach check places the body at most this far apart (m): closer than the thinnest post it must see
MAX_APPROACH_STRIDE = 0.1
#: the planner's command period (20 Hz): a command acts this long before the next can brake
COMMAND_PERIOD = 0.05
#: (top speed m/s, acceleration m/s^2) of the simulator's drives (docs/reference.md §11; not imported from
#: sim/diff_drive.py, which would load pybullet into this process; tests/safety checks they agree)
LAB_DRIVE = (1.05, 1.75)
JACKAL_DRIVE = (2.0, 2.5)
#: a live body may leave this much of the body the monitor started with uncovered (m): rounding
BODY_TOLERANCE = 0.001
#: the body's outline is checked at points this far apart (m)
OUTLINE_STEP = 0.005
#: an acceleration limit below this is not a drive's (m/s^2)
MIN_ACCEL = 0.5
#: a lidar return this far outside a track's circle still belongs to it (m): the tracker's error in centre and
#: radius
TRACK_MARGIN = 0.1
#: a track wider than this is not a person or a robot, and its returns stand still for the monitor (m)
MAX_TRACK_RADIUS = 1.0
#: a track slower than this stands still for the monitor (m/s): the tracker's noise on a standing obstacle
MIN_TRACK_SPEED = 0.1


@dataclass(frozen=True)
class CollisionMonitorConfig:
    footprint: list = param([], "m", "outline of the body in base_frame, [[x, y], ...] or its string form "
                            "(empty: robot_radius); live, it must hold the body the node started with",
                            kind=(list, str))
    robot_radius: float = param(0.0, "m", "radius of a round body, used when footprint is empty", ge=0.0, le=5.0)
    stop_distance: float = param(0.02, "m", "contact within this much travel along the commanded arc stops the "
                                 "robot", ge=MIN_STOP_DISTANCE, le=2.0)
    slowdown_distance: float = param(0.1, "m", "contact within this much travel slows the robot", ge=0.0, le=5.0)
    slowdown_ratio: float = param(0.5, "", "factor on the command while a point is in the slowdown zone",
                                  gt=0.0, le=1.0)
    time_before_collision: float = param(0.5, "s", "how far ahead the approach check drives the body along "
                                         "the command; at least the time to stop from max_linear_speed",
                                         ge=0.0, le=10.0)
    simulation_time_step: float = param(0.05, "s", "time step of the approach check", gt=0.0, le=1.0)
    min_points: int = param(3, "", "points a zone or the approach check needs to act", ge=1, le=MAX_MIN_POINTS)
    source_timeout: float = param(0.3, "s", "a command or scan older than this stops the robot", ge=0.1, le=1.0)
    stop_pub_timeout: float = param(2.0, "s", "how long zero is published after the commands stop", ge=0.2,
                                    le=60.0)
    teleop_timeout: float = param(0.5, "s", "the teleop input holds the output while its last command is "
                                  "newer than this", ge=0.1, le=5.0)
    max_output_rate: float = param(50.0, "Hz", "commands published per second of scan time at most (braking "
                                   "always passes)", ge=20.0, le=200.0)
    max_linear_speed: float = param(LAB_DRIVE[0], "m/s", "the drive's top speed: faster commands are scaled "
                                    "down along their curvature", gt=0.0, le=2.0, restart=True)
    max_linear_accel: float = param(0.0, "m/s^2", "the drive's acceleration: the output speeds up no faster "
                                    f"(0: the simulated drive's, {LAB_DRIVE[1]:g} up to {LAB_DRIVE[0]:g} m/s, "
                                    f"{JACKAL_DRIVE[1]:g} above)", ge=0.0, le=10.0, restart=True)
    max_angular_speed: float = param(4.0, "rad/s", "the drive's top yaw rate", gt=0.0, le=10.0, restart=True)
    max_angular_accel: float = param(8.0, "rad/s^2", "the drive's yaw acceleration", gt=0.0, le=50.0,
                                     restart=True)
    enabled: bool = param(True, "", "false: commands pass unchanged (the timeouts and the drive's limits "
                          "still apply)", restart=True)

    def __post_init__(self):
        if self.slowdown_distance < self.stop_distance:
            raise ParameterError(f"slowdown_distance ({self.slowdown_distance:g} m) must be >= stop_distance "
                                 f"({self.stop_distance:g} m): the slowdown zone holds the stop zone")
        if 0.0 < self.max_linear_accel < MIN_ACCEL:
            raise ParameterError(f"max_linear_accel must be 0 (the simulated drive's) or >= {MIN_ACCEL:g} "
                                 f"m/s^2, got {self.max_linear_accel:g}")
        floor = self.stopping_time() + COMMAND_PERIOD
        if self.time_before_collision < floor - 1e-9:
            raise ParameterError(
                f"time_before_collision ({self.time_before_collision:g} s) must be >= {floor:.3g} s: stopping "
                f"from {self.max_linear_speed:g} m/s at {self.linear_accel():g} m/s^2 and a command period")
        stride = self.simulation_time_step * self.max_linear_speed
        if stride > MAX_APPROACH_STRIDE + 1e-9:
            raise ParameterError(f"simulation_time_step ({self.simulation_time_step:g} s) must be <= "
                                 f"{MAX_APPROACH_STRIDE / self.max_linear_speed:.3g} s: at {self.max_linear_speed:g} "
                                 f"m/s the approach check would step {stride:.2f} m, past thin obstacles")
        steps = math.ceil(self.time_before_collision / self.simulation_time_step - 1e-9)
        if steps > MAX_APPROACH_STEPS:
            raise ParameterError(f"time_before_collision / simulation_time_step must be <= {MAX_APPROACH_STEPS} "
                                 f"steps, got {self.time_before_collision:g} / {self.simulation_time_step:g}")
        body = self.body()
        if body[0].size == 0 and body[1] <= 0.0:
            raise ParameterError("collision monitor: give the body as footprint or as robot_radius > 0")

    def body(self) -> tuple[np.ndarray, float]:
        """(vertices (V, 2), 0) of a polygon, or (empty, radius) of a circle."""
        vertices = parse_footprint(self.footprint, "collision monitor footprint")
        if vertices.size:
            return vertices, 0.0
        return np.empty((0, 2)), self.robot_radius

    def linear_accel(self) -> float:
        """max_linear_accel, or (0) that of the simulated drive that max_linear_speed implies (docs §11)."""
        if self.max_linear_accel > 0:
            return self.max_linear_accel
        return LAB_DRIVE[1] if self.max_linear_speed <= LAB_DRIVE[0] + 1e-9 else JACKAL_DRIVE[1]

    def stopping_time(self) -> float:
        """Seconds the drive takes to stop from its top speed."""
        return self.max_linear_speed / (2.0 * self.linear_accel())


PARAMETERS = fields_of(CollisionMonitorConfig)


class Action(enum.Enum):
    PASS = "pass"
    SLOWDOWN = "slowdown"
    APPROACH = "approach"
    STOP = "stop"


@dataclass(frozen=True)
class Verdict:
    v: float
    w: float
    action: Action
    why: str = ""


def moved_by(points: np.ndarray, v: float, w: float, dt: float) -> np.ndarray:
    """Robot-frame points as seen after driving the arc (v, w) for dt seconds: a scan ``dt`` old seen from now."""
    th = w * dt
    if abs(w) > 1e-9:
        dx, dy = v / w * math.sin(th), v / w * (1.0 - math.cos(th))
    else:
        dx, dy = v * dt, 0.0
    return inverse_transform_points((dx, dy, th), points)


def track_velocities(points: np.ndarray, tracks: np.ndarray) -> np.ndarray:
    """(N, 2) velocity of each point: that of the track whose circle, widened by TRACK_MARGIN, holds it (the
    nearest centre if several do), zero for the rest. ``tracks`` (M, 5): x, y, radius, vx, vy in the robot frame
    as of now; a track wider than MAX_TRACK_RADIUS or slower than MIN_TRACK_SPEED moves nothing."""
    velocities = np.zeros((len(points), 2))
    tracks = tracks[(tracks[:, 2] <= MAX_TRACK_RADIUS) & (np.hypot(tracks[:, 3], tracks[:, 4]) >= MIN_TRACK_SPEED)]
    if not len(points) or not len(tracks):
        return velocities
    distance = np.hypot(points[:, None, 0] - tracks[None, :, 0], points[:, None, 1] - tracks[None, :, 1])
    nearest = distance.argmin(axis=1)
    held = distance[np.arange(len(points)), nearest] <= tracks[nearest, 2] + TRACK_MARGIN
    velocities[held] = tracks[nearest[held], 3:5]
    return velocities


class CollisionMonitor:
    """``limit(v, w, points, velocities)``: the command that may reach the wheels."""

    def __init__(self, config: CollisionMonitorConfig):
        self.config = config
        self.vertices, self.radius = config.body()
        self.circumradius = self.radius if self.radius > 0 else footprint_radii(self.vertices)[1]

    def outline(self) -> np.ndarray:
        """(N, 2) points along the body's edge, OUTLINE_STEP apart at most."""
        if self.radius > 0:
            angles = np.linspace(0.0, 2 * math.pi, max(64, math.ceil(2 * math.pi * self.radius / OUTLINE_STEP)),
                                 endpoint=False)
            return self.radius * np.stack([np.cos(angles), np.sin(angles)], axis=1)
        a, b = self.vertices, np.roll(self.vertices, -1, axis=0)
        return np.concatenate([a[i] + np.linspace(0.0, 1.0, max(1, math.ceil(np.hypot(*(b[i] - a[i])) / OUTLINE_STEP)),
                                                  endpoint=False)[:, None] * (b[i] - a[i]) for i in range(len(a))])

    def holds(self, other: CollisionMonitor) -> bool:
        """Whether this body covers all of ``other``'s (to BODY_TOLERANCE): a smaller body than the robot's
        lets the robot touch what the monitor believes is still outside it."""
        outline = other.outline()
        lengths = np.maximum(np.linalg.norm(outline, axis=1, keepdims=True), 1e-9)
        inward = outline - BODY_TOLERANCE * outline / lengths
        return all(kernels.inside_body(x, y, self.vertices, self.radius) for x, y in inward)

    def scan_points(self, ranges, angle_min: float, angle_increment: float, range_min: float, range_max: float,
                    sensor: np.ndarray) -> np.ndarray:
        """The returns of a LaserScan as (N, 2) robot-frame points; ``sensor`` (2, 3) maps the scan plane's
        (x, y, 1) to the robot frame (the top rows of the laser's static transform, so a laser mounted upside
        down works).

        Unlike a costmap, the monitor keeps what is nearer than range_min: it is what the robot is about to
        hit. A return below range_min is kept as it is, and -inf (REP 117: "too close to measure") becomes a
        point just outside the body along the beam (just ahead of a laser outside it), the nearest place the
        object can be. NaN, +inf, negative
        and out-of-range values are not points; a scan whose geometry is unusable raises ValueError."""
        r = np.asarray(ranges, dtype=float)
        problem = scan_problem(r, angle_min, angle_increment, range_min, range_max, np.asarray(sensor).ravel())
        if problem:
            raise ValueError(problem[1])
        angles = angle_min + angle_increment * np.arange(len(r))
        directions = np.stack([np.cos(angles), np.sin(angles)], axis=1) @ sensor[:, :2].T
        too_close = np.flatnonzero(r == -np.inf)
        if len(too_close):
            r = r.copy()
            exits = self._exit_ranges(sensor[:, 2], directions[too_close])
            r[too_close] = exits + TOUCH_MARGIN
        with np.errstate(invalid="ignore"):
            hit = np.flatnonzero((r >= 0.0) & (r < range_max))
        return sensor[:, 2] + r[hit, None] * directions[hit]

    def _exit_ranges(self, origin: np.ndarray, directions: np.ndarray) -> np.ndarray:
        """How far each ray from origin (inside the body) runs before it leaves the body; 0 from outside it."""
        if self.radius > 0:
            along = directions @ origin
            inside = self.radius ** 2 - origin @ origin
            return np.where(inside > 0, -along + np.sqrt(np.maximum(along ** 2 + inside, 0.0)), 0.0)
        a, b = self.vertices, np.roll(self.vertices, -1, axis=0)
        edge = b - a                                         # origin + r d = a + u edge, r > 0, 0 <= u <= 1
        denominator = directions[:, None, 0] * edge[None, :, 1] - directions[:, None, 1] * edge[None, :, 0]
        offset = a - origin
        with np.errstate(divide="ignore", invalid="ignore"):
            r = (offset[None, :, 0] * edge[None, :, 1] - offset[None, :, 1] * edge[None, :, 0]) / denominator
            u = (offset[None, :, 0] * directions[:, None, 1] - offset[None, :, 1] * directions[:, None, 0]) \
                / denominator
        r = np.where((r > 0) & (u >= 0) & (u <= 1), r, np.inf).min(axis=1)
        return np.where(np.isfinite(r), r, 0.0)

    def limit(self, v: float, w: float, points: np.ndarray, velocities: np.ndarray | None = None) -> Verdict:
        """``points`` (N, 2) in the robot frame, as of now; ``velocities`` (N, 2) how each moves in that frame
        (m/s; None: all stand, as without tracks, see ``track_velocities``).

        A moving point's contact counts against the command only if it comes sooner than the robot standing
        still would suffer it (and within ``time_before_collision``): the monitor stops the robot driving into
        a person, never the motion that takes it out of a person's way."""
        c = self.config
        if not c.enabled or (abs(v) < STANDING_SPEED and abs(w) < STANDING_TURN_RATE):
            return Verdict(v, w, Action.PASS)
        if velocities is None or not len(points):
            velocities = np.zeros((len(points), 2))
        reach = self.circumradius + max(c.slowdown_distance, abs(v) * c.time_before_collision)
        speed = np.hypot(velocities[:, 0], velocities[:, 1])
        keep = np.hypot(points[:, 0], points[:, 1]) <= reach + speed * c.time_before_collision
        near, moves = points[keep], velocities[keep]
        until = self._standing_contact(near, moves)
        ratio, action, why = 1.0, Action.PASS, ""
        if abs(v) >= STANDING_SPEED and len(near):
            travel = self._travel_to_contact(v, w, near, moves, until)
            where = f"contact after {travel:.2f} m {'ahead' if v > 0 else 'reversing'} along the commanded arc"
            if travel <= c.stop_distance:     # no nearer; turning on the spot stays open where it is free
                turn, _ = self._approach(0.0, w, near, moves, until)
                return Verdict(0.0, w * turn, Action.STOP, where)
            if travel <= c.slowdown_distance:
                ratio, action, why = c.slowdown_ratio, Action.SLOWDOWN, where
        approach, contact = self._approach(v, w, near, moves, until)
        if approach < ratio:
            ratio, action, why = approach, Action.APPROACH, f"contact in {contact:.2f} s at the commanded velocity"
        return Verdict(v * ratio, w * ratio, action, why)

    def _standing_contact(self, near: np.ndarray, moves: np.ndarray) -> float:
        """Seconds until moving points reach the robot standing still, at most time_before_collision: how long
        moving points count against a command."""
        c = self.config
        steps = math.ceil(c.time_before_collision / c.simulation_time_step - 1e-9)
        beyond = c.time_before_collision + 0.5 * c.simulation_time_step     # the horizon's last step included
        if not moves.any():
            return beyond
        k = kernels.first_contact_step(near, moves, math.inf, 0.0, 0.0, c.simulation_time_step, steps,
                                       self.vertices, self.radius, self.circumradius, c.min_points)
        return beyond if k < 0 else k * c.simulation_time_step

    def _travel_to_contact(self, v: float, w: float, near: np.ndarray, moves: np.ndarray, until: float) -> float:
        """Metres the body can drive along the command's arc before it holds min_points points; inf beyond
        the slowdown zone. The arc is walked in ZONE_STEP steps of its length (at 1 m/s, turning w / |v|), so
        moving points move by their velocity / |v| per metre, and count for ``until`` seconds of it."""
        c = self.config
        steps = max(1, math.ceil(c.slowdown_distance / ZONE_STEP - 1e-9))
        k = kernels.first_contact_step(near, moves / abs(v), until * abs(v), math.copysign(1.0, v), w / abs(v),
                                       ZONE_STEP, steps, self.vertices, self.radius, self.circumradius, c.min_points)
        return math.inf if k < 0 else (k - 1) * ZONE_STEP

    def _approach(self, v: float, w: float, near: np.ndarray, moves: np.ndarray,
                  until: float) -> tuple[float, float]:
        """(the factor on the command, the time of the last free pose) of the approach check."""
        c = self.config
        steps = math.ceil(c.time_before_collision / c.simulation_time_step - 1e-9)
        if steps == 0 or not len(near) or (abs(v) < STANDING_SPEED and abs(w) < STANDING_TURN_RATE):
            return 1.0, math.inf
        k = kernels.first_contact_step(near, moves, until, float(v), float(w), c.simulation_time_step, steps,
                                       self.vertices, self.radius, self.circumradius, c.min_points)
        if k < 0:
            return 1.0, math.inf
        contact = (k - 1) * c.simulation_time_step   # the last pose known to be free
        return contact / c.time_before_collision, contact
