"""What a campaign is: worlds x robot bodies x parameter sets x goals x seeds, and the runs it expands to.

A run is a plain dict ``{world, seed, robot, params, goal}``; in lockstep it determines the whole run,
so any record of a results file can be repeated exactly. A body is ``box``, ``round`` (radius 0.3 m)
or ``round:R``; a parameter set is ``K=V`` overrides and, optionally, the name of a parameter set the
navigation launch ships (``tight``: config/tight/ over the lab's files), so ``tight
TebLocalPlannerROS.max_vel_x=1.0`` is the narrow-passage set at 1 m/s; ``max_speed=V`` is the one speed setting
(docs/reference.md §10), from which the other K=V of the set may still differ. ``time_budget`` (sim seconds per goal,
for the campaign or per world family) replaces the budget from the shortest path. The spec comes from a YAML file or
from the command line flags; every error names the key (or flag) it is about.
"""

from __future__ import annotations

import itertools
import json
import math
import re
from dataclasses import asdict, dataclass, field

from simplebot_description import robot_description
from simplebot_navigation.launch.loader import LaunchError, load_launch
from simplebot_navigation.launch.overrides import apply_set, speed_assignments
from simplebot_navigation.move_base.speed_profile import check_speed
from simplebot_navigation.sim.crowd import crowd_level
from simplebot_navigation.sim.world_loader import load_world
from simplebot_navigation.scenarios.runner import parse_goals
from simplebot_navigation.scenarios.launch_args import launch_args

ROBOT_BODY = re.compile(r"^(?P<name>box|round)(?::(?P<radius>\d+(?:\.\d+)?))?$")
ROUND_RADIUS_RANGE = (0.1, 1.0)
SHIPPED_SETS = ("tight", "no_collision_monitor", "no_moving_obstacles", "true_obstacles")   # launch arguments of the navigation launch (tight: config/tight/); true_obstacles: scenarios/true_obstacles.py
SPEC_KEYS = ("worlds", "seeds", "robots", "params", "goals", "run_timeout", "time_budget")
SPEED_KEY = "max_speed"
#: a time_budget (sim seconds per goal) is at most this
MAX_TIME_BUDGET_S = 3600.0
FAMILY_RANGE = re.compile(r"^(?P<family>[A-Za-z_][\w-]*):(?P<a>\d+)-(?P<b>\d+)$")
DEFAULT_RUN_TIMEOUT_S = 900.0
#: bounds of what a spec may ask for (README, "Campaigns"): values in one range (seeds, a world family), and
#: runs in all (worlds x robots x parameter sets x seeds, before goals; each run is minutes of a core)
MAX_RANGE_VALUES = 10_000
MAX_RUNS = 100_000


class SpecError(ValueError):
    """A malformed campaign spec; the message starts with the key or flag at fault."""


@dataclass(frozen=True)
class CampaignSpec:
    worlds: tuple[str, ...]
    seeds: tuple[int, ...] = (0,)
    robots: tuple[str, ...] = ("box",)
    params: tuple[tuple[str, ...], ...] = ((),)   # parameter sets, each a tuple of "K=V" overrides
    goals: tuple[str, ...] | None = None          # goal items (names or "x,y,yaw"); None: every goal of the world
    run_timeout: float = DEFAULT_RUN_TIMEOUT_S    # wall seconds one run may take before it counts as hung
    time_budget: tuple[tuple[str, float], ...] = ()   # (family, sim s per goal); family "": every other world

    def to_dict(self) -> dict:
        return json.loads(json.dumps(asdict(self)))


def integer_range(text: str, key: str) -> list[int]:
    """'0-9' -> 0..9, '3' -> [3], '0-2,7' -> [0, 1, 2, 7]; at most MAX_RANGE_VALUES of them."""
    values: list[int] = []
    for part in str(text).split(","):
        match = re.fullmatch(r"\s*(\d+)\s*(?:-\s*(\d+)\s*)?", part)
        if not match:
            raise SpecError(f"{key}: {part.strip()!r} is not an integer or a range a-b")
        a, b = int(match[1]), int(match[2] if match[2] is not None else match[1])
        if b < a:
            raise SpecError(f"{key}: range {part.strip()!r} runs backwards")
        if len(values) + b - a + 1 > MAX_RANGE_VALUES:
            raise SpecError(f"{key}: {text!r} holds more than {MAX_RANGE_VALUES} values")
        values += range(a, b + 1)
    return values


def expand_worlds(names: list[str], key: str = "worlds") -> list[str]:
    """Generated families: 'forest:0-199' becomes forest:0 ... forest:199, passed as such to load_world."""
    worlds = []
    for name in names:
        match = FAMILY_RANGE.match(name)
        if match:
            worlds += [f"{match['family']}:{n}" for n in integer_range(f"{match['a']}-{match['b']}", key)]
        else:
            worlds.append(name)
    return worlds


def world_family(world: str) -> str:
    """What the summary groups by: 'forest:17' -> 'forest', a crowd world by its level ('crowd:17' ->
    'crowd hard'), a file -> its stem, a built-in world -> itself."""
    name = world.split("/")[-1]
    if ":" not in name:
        return re.sub(r"\.ya?ml$", "", name)
    family, seed = name.split(":", 1)
    return f"crowd {crowd_level(int(seed))}" if family == "crowd" and seed.isdigit() else family


def robot_body(robot: str, key: str = "robots") -> tuple[str, float]:
    """'box' / 'round' / 'round:0.25' -> (body, radius of a round body); the radius is ignored for the box."""
    match = ROBOT_BODY.match(robot)
    if not match or (match["name"] == "box" and match["radius"]):
        raise SpecError(f"{key}: unknown body {robot!r} (bodies: box, round, round:R with R in metres)")
    radius = float(match["radius"] or 0.3)
    if not ROUND_RADIUS_RANGE[0] <= radius <= ROUND_RADIUS_RANGE[1]:
        raise SpecError(f"{key}: {robot!r}: the radius must lie in [{ROUND_RADIUS_RANGE[0]}, "
                        f"{ROUND_RADIUS_RANGE[1]}] m")
    return match["name"], radius


def split_parameter_set(params) -> tuple[tuple[str, ...], list[str]]:
    """(shipped sets named in it, its K=V overrides of move_base's parameters)."""
    return (tuple(p for p in params if p in SHIPPED_SETS),
            [p for p in params if p not in SHIPPED_SETS and p.partition("=")[0].strip() != SPEED_KEY])


def speed_of(params) -> float | None:
    """The set's max_speed=V, or None."""
    values = [p.partition("=")[2] for p in params if p.partition("=")[0].strip() == SPEED_KEY]
    return float(values[-1]) if values else None


def budget_for(spec: CampaignSpec, world: str) -> float | None:
    """The time budget of a world's family, else the campaign's, else None (from the shortest path)."""
    budgets = dict(spec.time_budget)
    return budgets.get(world_family(world), budgets.get(""))


def time_budgets(value, key: str = "time_budget") -> tuple[tuple[str, float], ...]:
    """A number (every world) or a mapping {family: seconds} ('' or 'default': every other world)."""
    items = value.items() if isinstance(value, dict) else [("", value)]
    out = []
    for family, seconds in items:
        if isinstance(seconds, bool) or not isinstance(seconds, (int, float)) or not math.isfinite(seconds) \
                or not 0 < seconds <= MAX_TIME_BUDGET_S:
            raise SpecError(f"{key}: expected sim seconds in (0, {MAX_TIME_BUDGET_S:g}]"
                            + (f" for {family!r}" if family else "") + f", got {seconds!r}")
        out.append(("" if family == "default" else str(family), float(seconds)))
    return tuple(out)


def parameter_set(value, key: str) -> tuple[str, ...]:
    """One parameter set from a list of 'K=V' (and shipped set names), a mapping {K: V}, 'K=V K=V' text,
    or 'default' / nothing."""
    if value is None or value == "default":
        return ()
    if isinstance(value, dict):
        items = [f"{k}={v}" for k, v in value.items()]
    elif isinstance(value, str):
        items = value.split()
    elif isinstance(value, list):
        items = [str(v) for v in value]
    else:
        raise SpecError(f"{key}: expected K=V overrides, got {value!r}")
    for item in items:
        name, sep, value = item.partition("=")
        if item not in SHIPPED_SETS and (not sep or not name.strip()):
            raise SpecError(f"{key}: {item!r} is not K=V nor a shipped parameter set ({', '.join(SHIPPED_SETS)})")
        if name.strip() == SPEED_KEY:
            try:
                problem = check_speed(float(value))
            except ValueError:
                problem = f"max_speed must be a number of m/s, got {value!r}"
            if problem:
                raise SpecError(f"{key}: {problem}")
    return tuple(items)


def params_label(params: tuple[str, ...] | list[str]) -> str:
    return " ".join(params) if params else "default"


def goal_items(text: str, key: str = "goals") -> list[str]:
    """Goals in the runner's syntax ('x,y,yaw;x,y,yaw' and/or 'name,name'), one item per goal."""
    items = []
    for item in (part.strip() for part in text.split(";")):
        fields = [f.strip() for f in item.split(",")]
        if not item or not all(fields):
            raise SpecError(f"{key}: empty item in {text!r}")
        if all(_is_number(f) for f in fields):
            items.append(item)      # one pose, checked by parse_goals when the plan is made
        else:
            items += fields         # goal names
    return items


def _is_number(text: str) -> bool:
    try:
        float(text)
    except ValueError:
        return False
    return True


def _as_list(value, key: str) -> list:
    if isinstance(value, str):
        return [v.strip() for v in value.split(",") if v.strip()]
    if isinstance(value, list) and value:
        return value
    raise SpecError(f"{key}: expected a non-empty list or a comma-separated string, got {value!r}")


def spec_from_dict(data, source: str = "spec") -> CampaignSpec:
    """Validate a parsed spec (YAML file or flags); errors name the key."""
    if not isinstance(data, dict):
        raise SpecError(f"{source}: expected a mapping with keys {', '.join(SPEC_KEYS)}, got {type(data).__name__}")
    unknown = sorted(set(data) - set(SPEC_KEYS))
    if unknown:
        raise SpecError(f"{unknown[0]}: unknown key in {source} (keys: {', '.join(SPEC_KEYS)})")
    if "worlds" not in data:
        raise SpecError(f"worlds: missing in {source}")
    worlds = expand_worlds([str(w) for w in _as_list(data["worlds"], "worlds")])
    seeds_value = data.get("seeds", 0)
    if isinstance(seeds_value, list):
        if not all(isinstance(s, int) and not isinstance(s, bool) and s >= 0 for s in seeds_value) or not seeds_value:
            raise SpecError(f"seeds: expected integers >= 0, got {seeds_value!r}")
        seeds = seeds_value
    elif isinstance(seeds_value, bool):
        raise SpecError(f"seeds: expected integers or a range a-b, got {seeds_value!r}")
    else:
        seeds = integer_range(str(seeds_value), "seeds")
    robots = [str(r) for r in _as_list(data.get("robots", "box"), "robots")]
    for robot in robots:
        robot_body(robot)
    params_value = data.get("params", [None])
    if not isinstance(params_value, list) or not params_value:
        raise SpecError(f"params: expected a list of parameter sets, got {params_value!r}")
    params = [parameter_set(p, f"params[{i}]") for i, p in enumerate(params_value)]
    goals = data.get("goals")
    if goals is not None and goals != "all":
        goals = goal_items(goals) if isinstance(goals, str) else [str(g) for g in _as_list(goals, "goals")]
    timeout = data.get("run_timeout", DEFAULT_RUN_TIMEOUT_S)
    if isinstance(timeout, bool) or not isinstance(timeout, (int, float)) or not math.isfinite(timeout) \
            or timeout <= 0:
        raise SpecError(f"run_timeout: expected a positive number of wall seconds, got {timeout!r}")
    for name, values in (("worlds", worlds), ("seeds", seeds), ("robots", robots), ("params", params)):
        if len(set(values)) != len(values):
            raise SpecError(f"{name}: listed twice in {values!r}")
    runs = len(worlds) * len(seeds) * len(robots) * len(params)
    if runs > MAX_RUNS:
        raise SpecError(f"{len(worlds)} worlds x {len(seeds)} seeds x {len(robots)} robots x {len(params)} parameter "
                        f"sets is {runs} runs, more than {MAX_RUNS}")
    budgets = time_budgets(data["time_budget"]) if data.get("time_budget") is not None else ()
    return CampaignSpec(tuple(worlds), tuple(seeds), tuple(robots), tuple(params),
                        None if goals in (None, "all") else tuple(goals), float(timeout), budgets)


# -- runs ------------------------------------------------------------------------------------------
@dataclass(frozen=True)
class Run:
    world: str
    seed: int
    robot: str
    params: tuple[str, ...] = field(default=())
    goal: str = ""
    time_budget: float | None = None     # sim seconds for the goal; None: from the shortest path

    @property
    def key(self) -> str:
        """Identifies the run in a results file (resume, retries, comparisons); a budget only when it has one,
        so the keys of campaigns without one stay as they were."""
        fields = [self.world, self.seed, self.robot, list(self.params), self.goal]
        return json.dumps(fields + ([self.time_budget] if self.time_budget is not None else []))

    def to_dict(self) -> dict:
        out = {"world": self.world, "seed": self.seed, "robot": self.robot, "params": list(self.params),
               "goal": self.goal}
        return out | ({"time_budget": self.time_budget} if self.time_budget is not None else {})

    @classmethod
    def from_dict(cls, data: dict) -> Run:
        return cls(data["world"], int(data["seed"]), data["robot"], tuple(data["params"]), data["goal"],
                   data.get("time_budget"))


def plan(spec: CampaignSpec) -> list[Run]:
    """Every run of the campaign, worlds outermost; each world is loaded once here to check it and its goals."""
    for params in spec.params:     # each parameter set checked as move_base would take it
        shipped, overrides = split_parameter_set(params)
        if "true_obstacles" in shipped and "no_moving_obstacles" in shipped:
            raise SpecError(f"params: {params_label(params)!r}: true_obstacles replaces the tracker, which "
                            "no_moving_obstacles turns off")
        try:
            args = launch_args("lab", "box", 0.3, 0.0, "tight" in shipped,
                               collision_monitor="no_collision_monitor" not in shipped, max_speed=speed_of(params),
                               moving_obstacles="no_moving_obstacles" not in shipped)
            config = load_launch("navigation", args)
            apply_set(config, speed_assignments(config, overrides)[0] + overrides)
        except LaunchError as err:
            raise SpecError(f"params: {params_label(params)!r}: {err}") from err
    runs = []
    for world in spec.worlds:
        for robot in spec.robots:
            try:
                loaded = load_world(world, robot_radius=robot_description(*robot_body(robot)).inscribed_radius)
            except (ValueError, FileNotFoundError) as err:
                raise SpecError(f"worlds: {world} ({robot} robot): {err}") from err
            try:
                for goal in spec.goals or ():
                    parse_goals(goal, loaded)  # raises for an unknown name or bad coordinates
                goals = list(spec.goals) if spec.goals else [g.name for g in parse_goals(None, loaded)]
            except ValueError as err:
                raise SpecError(f"goals: world {world}: {err}") from err
            runs += [Run(world, seed, robot, params, goal, budget_for(spec, world))
                     for params, goal, seed in itertools.product(spec.params, goals, spec.seeds)]
    return runs
