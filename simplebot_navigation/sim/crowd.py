"""Generated worlds with moving obstacles: ``crowd:<seed>`` (the dynamic-obstacle benchmark) and
``people:<seed>`` (people walking in the lab's corridor).

A crowd world is an arena of ARENA_LENGTH x ARENA_WIDTH m walled on three sides (the goal end is
open). The robot starts at (0, 0) facing +x and its goal lies ARENA_LENGTH m ahead. Every obstacle is
a cylinder of CROWD_RADIUS that runs a closed loop from a point on the arena border through a few
random interior points and back, as a Catmull-Rom spline, at a speed drawn per segment; the loop
repeats, so the arena never empties out. The seed picks the level (seed % 3: easy, medium, hard),
the number of obstacles and their speeds (CROWD_LEVELS), the paths and their phases. Obstacles do
not react to the robot and pass through each other.

A people world is the lab with the robot at one end of its corridor and the goal at the other,
and 3-8 people of PERSON_RADIUS walking back and forth: head-on along the corridor, and across
it from a room on one side to a room on the other through their doors.

Both carry the world keys ``time_budget`` and ``success_radius``, which the scenario runner uses
instead of its defaults: success is reaching within success_radius of the goal without a
collision while moving, within time_budget seconds.
"""

from __future__ import annotations

import math

import numpy as np
import yaml

from simplebot_description import world_path

from simplebot_navigation.sim.world import World, world_from_dict

ARENA_LENGTH = 20.0
ARENA_WIDTH = 20.0
#: the arena's walls stand this far behind the start and past the sides
ARENA_BACK = 2.0
CROWD_RADIUS = 0.5
CROWD_HEIGHT = 1.8
CROWD_TIME_BUDGET_S = 100.0
SUCCESS_RADIUS = 1.0
#: level: (obstacles min, max), (speed min, max) in m/s
CROWD_LEVELS = {"easy": ((5, 14), (0.5, 0.9)), "medium": ((15, 19), (1.0, 1.4)), "hard": ((20, 24), (1.4, 1.9))}
LEVELS = tuple(CROWD_LEVELS)
INTERIOR_POINTS = (2, 4)
#: border points are kept this far from the start and the goal, so no loop turns on them
BORDER_KEEP_OUT = 3.0
#: for the first START_CLEAR_S seconds no obstacle comes nearer to the start than START_CLEAR_M
START_CLEAR_S = 8.0
START_CLEAR_M = 2.0
_PHASE_TRIES = 200

PERSON_RADIUS = 0.25
PERSON_HEIGHT = 1.7
PERSON_SPEEDS = (0.6, 1.4)
PEOPLE_COUNT = (3, 8)
PEOPLE_TIME_BUDGET_S = 100.0
#: a crossing walker passes 1.7 m from the start, a body length and more from the robot
PEOPLE_START_CLEAR_M = 1.5
#: the lab's corridor runs along x between y = -1.25 and 1.25; the robot drives it from START to GOAL
PEOPLE_START = (-9.5, 0.0)
PEOPLE_GOAL = (4.5, 0.0)
#: door pairs (north door x, south door x) a person crosses the corridor through, and how far into
#: the rooms their walk reaches
CROSSINGS = ((-8.0, -5.0), (1.5, 0.0), (8.0, 7.0))
ROOM_DEPTH = 3.0
CORRIDOR_HALF_WIDTH = 1.25
HEAD_ON_LANE = 0.6
#: head-on walkers turn round past the goal and 2.5-4 m before the start
HEAD_ON_ENDS = ((8.5, 11.0), (-7.0, -5.5))


def crowd_level(seed: int) -> str:
    return LEVELS[seed % len(LEVELS)]


def crowd_world(seed: int) -> World:
    """Crowd benchmark world ``seed``; the same seed always gives the same world."""
    level = crowd_level(seed)
    (n_lo, n_hi), speeds = CROWD_LEVELS[level]
    rng = np.random.default_rng((25, seed))
    xmin, xmax = -ARENA_BACK, ARENA_LENGTH + ARENA_BACK
    half = ARENA_WIDTH / 2
    walls = [{"from": [xmax, -half], "to": [xmin, -half], "thickness": 0.2},
             {"from": [xmin, -half], "to": [xmin, half], "thickness": 0.2},
             {"from": [xmin, half], "to": [xmax, half], "thickness": 0.2}]
    moving = [_crowd_obstacle(rng, speeds, i) for i in range(int(rng.integers(n_lo, n_hi + 1)))]
    data = {"name": f"crowd_{seed}", "walls": walls, "moving": moving,
            "start": {"x": 0.0, "y": 0.0, "yaw": 0.0},
            "goals": [{"x": ARENA_LENGTH, "y": 0.0, "yaw": 0.0, "name": "goal"}],
            "time_budget": CROWD_TIME_BUDGET_S, "success_radius": SUCCESS_RADIUS, "level": level,
            "reference_path": ARENA_LENGTH}
    return world_from_dict(data, source=f"crowd:{seed}")


def _crowd_obstacle(rng, speeds, index: int) -> dict:
    while True:
        border = _border_point(rng, CROWD_RADIUS + 0.1)
        interior = [(float(rng.uniform(1.0, ARENA_LENGTH - 1.0)),
                     float(rng.uniform(-ARENA_WIDTH / 2 + 2.0, ARENA_WIDTH / 2 - 2.0)))
                    for _ in range(int(rng.integers(INTERIOR_POINTS[0], INTERIOR_POINTS[1] + 1)))]
        points = np.array([border, *interior, border])
        seg_speeds = rng.uniform(*speeds, size=len(points) - 1)
        times = np.concatenate([[0.0], np.cumsum(_spline_lengths(points) / seg_speeds)])
        keyframes = [[round(float(t), 3), round(float(x), 3), round(float(y), 3)]
                     for t, (x, y) in zip(times, points)]
        phase = _clear_phase(rng, keyframes, float(times[-1]), (0.0, 0.0), START_CLEAR_M + CROWD_RADIUS)
        if phase is not None:
            return {"shape": "cylinder", "radius": CROWD_RADIUS, "height": CROWD_HEIGHT, "keyframes": keyframes,
                    "interpolation": "spline", "loop": True, "phase": phase, "name": f"walker {index}"}


def _border_point(rng, inset: float) -> tuple[float, float]:
    """A point on the arena's border (the three walls, inset, and the open end), away from start and goal."""
    xmin, xmax = -ARENA_BACK + inset, ARENA_LENGTH + ARENA_BACK - inset
    ymax = ARENA_WIDTH / 2 - inset
    sides = np.array([xmax - xmin, 2 * ymax, xmax - xmin, 2 * ymax])
    while True:
        s = rng.uniform(0.0, sides.sum())
        side = int(np.searchsorted(np.cumsum(sides), s, side="right"))
        u = s - np.concatenate([[0.0], np.cumsum(sides)])[side]
        point = [(xmin + u, -ymax), (xmin, -ymax + u), (xmax - u, ymax), (xmax, ymax - u)][side]
        if min(math.hypot(point[0], point[1]), math.hypot(point[0] - ARENA_LENGTH, point[1])) >= BORDER_KEEP_OUT:
            return float(point[0]), float(point[1])


def _spline_lengths(points: np.ndarray, samples: int = 32) -> np.ndarray:
    """Arc length of each segment of the closed-loop Catmull-Rom spline through ``points`` (first ==
    last), so that the drawn speed is the speed along the path, not along the chord."""
    loop = points[:-1]
    n = len(loop)
    u = np.linspace(0.0, 1.0, samples)[:, None]
    lengths = []
    for i in range(n):
        p0, p1, p2, p3 = loop[(i - 1) % n], loop[i], loop[(i + 1) % n], loop[(i + 2) % n]
        curve = 0.5 * (2 * p1 + (p2 - p0) * u + (2 * p0 - 5 * p1 + 4 * p2 - p3) * u ** 2
                       + (3 * p1 - p0 - 3 * p2 + p3) * u ** 3)
        lengths.append(np.hypot(*np.diff(curve, axis=0).T).sum())
    return np.maximum(np.array(lengths), 1e-3)


def _clear_phase(rng, keyframes, period: float, point: tuple[float, float], clearance: float) -> float | None:
    """A phase that puts the obstacle somewhere along its loop at t = 0, redrawn while it would come
    within ``clearance`` of ``point`` (the robot's start, where it waits for its goal) in the first
    START_CLEAR_S (None if no phase does: the caller draws another path); the check follows the
    keyframes in straight lines."""
    kf = np.array(keyframes)
    for _ in range(_PHASE_TRIES):
        phase = -float(rng.uniform(0.0, period))
        t = (np.linspace(0.0, START_CLEAR_S, 33) - phase) % period
        x, y = np.interp(t, kf[:, 0], kf[:, 1]), np.interp(t, kf[:, 0], kf[:, 2])
        if np.hypot(x - point[0], y - point[1]).min() >= clearance:
            return round(phase, 3)
    return None


def people_world(seed: int) -> World:
    """The lab with 3-8 people walking head-on along its corridor and across it, seed ``seed``."""
    rng = np.random.default_rng((26, seed))
    lab = world_from_dict(_lab_data(), source="lab.yaml")
    count = int(rng.integers(PEOPLE_COUNT[0], PEOPLE_COUNT[1] + 1))
    head_on = max(1, count // 3)
    people = [_head_on_walker(rng, i) for i in range(head_on)]
    people += [_crossing_walker(rng, i) for i in range(head_on, count)]
    data = {**lab.to_dict(), "name": f"people_{seed}", "moving": people,
            "start": {"x": PEOPLE_START[0], "y": PEOPLE_START[1], "yaw": 0.0},
            "goals": [{"x": PEOPLE_GOAL[0], "y": PEOPLE_GOAL[1], "yaw": 0.0, "name": "goal"}],
            "time_budget": PEOPLE_TIME_BUDGET_S, "success_radius": SUCCESS_RADIUS, "people": count,
            "head_on": head_on, "reference_path": PEOPLE_GOAL[0] - PEOPLE_START[0]}
    data.pop("starts", None)
    return world_from_dict(data, source=f"people:{seed}")


def _lab_data() -> dict:
    return yaml.safe_load(world_path("lab").read_text())


def _person(rng, points, index: int, kind: str) -> dict:
    """A walk there and back along ``points`` at one speed, looping."""
    path = np.array(points + points[-2::-1], dtype=float)
    speed = float(rng.uniform(*PERSON_SPEEDS))
    times = np.concatenate([[0.0], np.cumsum(np.hypot(*np.diff(path, axis=0).T) / speed)])
    keyframes = [[round(float(t), 3), round(float(x), 3), round(float(y), 3)] for t, (x, y) in zip(times, path)]
    phase = _clear_phase(rng, keyframes, float(times[-1]), PEOPLE_START, PEOPLE_START_CLEAR_M)
    if phase is None:
        raise ValueError(f"people: {kind} {index} cannot keep {PEOPLE_START_CLEAR_M} m from the start")
    return {"shape": "cylinder", "radius": PERSON_RADIUS, "height": PERSON_HEIGHT, "keyframes": keyframes,
            "interpolation": "linear", "loop": True, "phase": phase, "name": f"{kind} {index}"}


def _head_on_walker(rng, index: int) -> dict:
    lane = float(rng.uniform(-HEAD_ON_LANE, HEAD_ON_LANE))
    far, near = (float(rng.uniform(*HEAD_ON_ENDS[0])), float(rng.uniform(*HEAD_ON_ENDS[1])))
    return _person(rng, [[far, lane], [near, lane]], index, "head-on walker")


def _crossing_walker(rng, index: int) -> dict:
    north, south = CROSSINGS[int(rng.integers(len(CROSSINGS)))]
    # Straight through the middle of each door, diagonally across the corridor between them.
    inside = CORRIDOR_HALF_WIDTH - 0.45
    points = [[north, CORRIDOR_HALF_WIDTH + ROOM_DEPTH - 1.0], [north, inside],
              [south, -inside], [south, -CORRIDOR_HALF_WIDTH - ROOM_DEPTH + 1.0]]
    if rng.uniform() < 0.5:
        points.reverse()
    return _person(rng, points, index, "crossing walker")
