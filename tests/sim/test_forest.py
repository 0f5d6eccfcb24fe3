"""The forest world family: seeded layouts, the passage rule, the C-space check and its metrics."""

import itertools
import math

import numpy as np
import pytest

from simplebot_navigation.sim.cspace import analyse
from simplebot_navigation.sim.forest import FOREST_BENCHMARK_SEEDS, benchmark_forest, benchmark_knobs, main
from simplebot_navigation.sim.world import Cylinder, Pose2D, Wall, World
from simplebot_navigation.sim.world_loader import load_world
from simplebot_navigation.sim.world_gen import FOREST_GOAL, forest_world


def test_same_seed_same_forest():
    assert forest_world(5) == forest_world(5)
    assert forest_world(5) != forest_world(6)
    assert benchmark_knobs(5) == benchmark_knobs(5) != benchmark_knobs(6)


def test_forest_has_every_shape_and_the_start_and_goal_around_the_field():
    world = forest_world(1, field=(8.0, 4.0), shapes={"cylinder": 0.6, "box": 0.2, "wall": 0.2})
    assert world.cylinders and world.boxes and len(world.walls) > 4
    assert all(c.radius == 0.075 for c in world.cylinders)
    assert (world.start.x, world.start.y) == (-3.0, 0.0)
    assert world.goal(FOREST_GOAL) == Pose2D(11.0, 0.0, 0.0, FOREST_GOAL)
    assert world.extra["field"] == [8.0, 4.0]


def _outline_points(shape, spacing=0.002):
    """Dense points on an obstacle's outline, for an independent check of the gaps."""
    if isinstance(shape, Cylinder):
        angles = np.arange(0.0, 2 * math.pi, spacing / shape.radius)
        return np.column_stack((np.cos(angles), np.sin(angles))) * shape.radius + shape.center
    hx, hy = shape.size[0] / 2, shape.size[1] / 2
    corners = np.array([(-hx, -hy), (hx, -hy), (hx, hy), (-hx, hy), (-hx, -hy)])
    local = np.concatenate([np.linspace(a, b, int(np.hypot(*(b - a)) / spacing) + 2)
                            for a, b in zip(corners, corners[1:])])
    c, s = math.cos(shape.yaw), math.sin(shape.yaw)
    return local @ np.array([[c, s], [-s, c]]) + shape.center


@pytest.mark.parametrize("seed, min_passage", [(2, 0.65), (3, 0.75), (4, 0.9)])
def test_every_passage_is_at_least_min_passage(seed, min_passage):
    world = forest_world(seed, min_passage=min_passage, shapes={"cylinder": 0.7, "box": 0.2, "wall": 0.1})
    solids = [shape for label, shape in world.obstacles() if label not in {f"walls[{i}]" for i in range(4)}]
    assert len(solids) > 15
    half_width = world.extra["field"][1] / 2
    for a, b in itertools.combinations(solids, 2):
        if isinstance(a, Cylinder) and isinstance(b, Cylinder):
            gap = math.dist(a.center, b.center) - a.radius - b.radius
        else:
            gap = World("pair", boxes=(b,) if not isinstance(b, Cylinder) else (),
                        cylinders=(b,) if isinstance(b, Cylinder) else ()).distance(_outline_points(a)).min()
        assert gap >= min_passage - 0.001, (a, b, gap)
    for shape in solids:
        assert half_width - np.abs(_outline_points(shape)[:, 1]).max() >= min_passage - 0.001


def test_a_field_too_tight_for_the_robot_is_rejected_with_the_reason():
    with pytest.raises(ValueError, match=r"forest:3: unsolvable for a robot of radius 0.25 m plus a 0.05 m margin: "
                                         r"no C-space path connects the start \(-3, 0\) to the goal \(13, 0\)"):
        forest_world(3, min_passage=0.3, shapes={"cylinder": 1.0})


def _corridor(*inner, start=Pose2D(0.0, 0.0), goal=Pose2D(4.0, 0.0, 0.0, "goal")) -> World:
    """A 6 m wide corridor from x = -1 to 5 (inner surfaces at y = +-2.95) with extra walls."""
    outer = (Wall((-1.0, -3.0), (5.0, -3.0)), Wall((5.0, -3.0), (5.0, 3.0)), Wall((5.0, 3.0), (-1.0, 3.0)),
             Wall((-1.0, 3.0), (-1.0, -3.0)))
    return World("corridor", outer + tuple(inner), (), (), start, (goal,), "<corridor>")


def test_blocked_start_and_cut_corridor_are_rejected():
    with pytest.raises(ValueError, match=r"<corridor>: unsolvable .*: "
                                         r"the start \(0, 0\) is blocked, 0.100 m from walls\[4\]"):
        analyse(_corridor(Wall((0.15, -1.0), (0.15, 1.0))), 0.25)
    with pytest.raises(ValueError, match=r"<corridor>: unsolvable .*: no C-space path connects"):
        analyse(_corridor(Wall((2.0, -3.0), (2.0, 3.0))), 0.25)


def test_metrics_of_a_detour_through_a_known_gap():
    """A wall from the floor up to y = 1.7 leaves a 1.25 m gap below the corridor's top surface.

    The robot's centre keeps 0.3 m from the wall's 0.1 m wide end: the shortest path is the tangent
    from (0, 0) to the circle of 0.3 m around the end's corner (1.95, 1.7), the arc over it, 0.1 m
    across and the mirror image down to (4, 0).
    """
    metrics = analyse(_corridor(Wall((2.0, -3.0), (2.0, 1.7))), 0.25)
    assert metrics.narrowest_passage == pytest.approx(1.25, abs=0.05)
    assert metrics.straight_line == 4.0
    centre = math.hypot(1.95, 1.7)
    tangent_heading = math.atan2(1.7, 1.95) + math.asin(0.3 / centre)
    exact = 2 * (math.sqrt(centre ** 2 - 0.3 ** 2) + 0.3 * tangent_heading) + 0.1
    assert metrics.path_length == pytest.approx(exact, rel=0.02)
    open_corridor = analyse(_corridor(), 0.25)
    assert open_corridor.tortuosity == pytest.approx(1.0, abs=0.01)
    # Nothing in the corridor is narrower than the room around the start, 0.95 m from the end wall.
    assert open_corridor.narrowest_passage == pytest.approx(1.9, abs=0.05)


def test_load_world_resolves_forest_names():
    assert load_world("forest", robot_radius=0.25) == benchmark_forest(0)
    world = load_world("forest:7", robot_radius=0.25)
    assert world.source == "forest:7" and world.extra["min_passage"] == benchmark_knobs(7)["min_passage"]
    with pytest.raises(ValueError, match=r"world 'forest:x'.*generated one \(forest, forest:<seed>, crowd:<seed>, people:<seed>\)"):
        load_world("forest:x")


def test_scenario_runs_of_forest_take_the_run_seed():
    from simplebot_navigation.scenarios.runner import world_for_run

    assert [world_for_run("forest", seed, "/nonexistent") for seed in (3, 4)] == ["forest:3", "forest:4"]
    assert world_for_run("forest:9", 4, "/nonexistent") == "forest:9"


def test_the_benchmark_set_generates_solvable_and_spans_difficulty():
    worlds = [benchmark_forest(seed) for seed in FOREST_BENCHMARK_SEEDS]
    assert len(worlds) >= 200
    narrowest = [w.extra["cspace"]["narrowest_passage"] for w in worlds]
    tortuosity = [w.extra["cspace"]["tortuosity"] for w in worlds]
    assert min(narrowest) < 0.8 and max(narrowest) > 1.2
    assert min(tortuosity) < 1.01 and max(tortuosity) > 1.03


def test_report_prints_one_row_per_world_and_the_spread(capsys):
    assert main(["--report", "--seeds", "0-2"]) == 0
    lines = capsys.readouterr().out.splitlines()
    assert lines[0].split() == ["seed", "occupancy", "min_passage", "cylinders", "boxes", "walls", "narrowest",
                                "tortuosity", "solvable"]
    assert [line.split()[0] for line in lines[1:4]] == ["0", "1", "2"]
    assert "3 of 3 worlds solvable" in lines[5]
    assert lines[6].split(":")[0].strip() == "narrowest passage (m)"
