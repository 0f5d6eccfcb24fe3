"""The generated worlds with moving obstacles: crowd:<seed> (the benchmark's recipe) and people:<seed>."""

import math

import numpy as np
import pytest

from simplebot_navigation.sim.crowd import (ARENA_LENGTH, CROWD_LEVELS, CROWD_RADIUS, PEOPLE_COUNT, PEOPLE_START,
                                            PERSON_RADIUS, PERSON_SPEEDS, START_CLEAR_S, crowd_level)
from simplebot_navigation.sim.moving import MovingTracks
from simplebot_navigation.sim.world import write_world
from simplebot_navigation.sim.world_loader import load_world

SEEDS = range(0, 150, 13)


def loop_speeds(obstacle, samples: int = 500) -> np.ndarray:
    """The obstacle's speed at many times over one period of its loop."""
    t0, t1 = obstacle.keyframes[0][0], obstacle.keyframes[-1][0]
    times = np.linspace(t0, t1, samples, endpoint=False) + obstacle.phase
    return np.array([math.hypot(*obstacle.state(t)[2:]) for t in times])


@pytest.mark.parametrize("seed", SEEDS)
def test_crowd_world_follows_the_recipe(seed):
    world = load_world(f"crowd:{seed}", robot_radius=0.25)
    level = crowd_level(seed)
    (n_lo, n_hi), (v_lo, v_hi) = CROWD_LEVELS[level]
    assert world.extra["level"] == level and not world.warnings
    assert n_lo <= len(world.moving) <= n_hi
    assert math.hypot(world.goals[0].x - world.start.x, world.goals[0].y - world.start.y) == ARENA_LENGTH
    assert world.extra["time_budget"] == 100.0 and world.extra["success_radius"] == 1.0
    assert len(world.walls) == 3                                       # the goal end is open
    for obstacle in world.moving:
        assert obstacle.shape == "cylinder" and obstacle.radius == CROWD_RADIUS and obstacle.loop
        assert obstacle.keyframes[0][1:] == obstacle.keyframes[-1][1:]   # a closed loop: no jump when it repeats
        # The drawn speeds are the speeds along the spline, per segment: the mean over the loop lies in the range.
        assert v_lo * 0.97 <= loop_speeds(obstacle).mean() <= v_hi * 1.03, obstacle.name


def test_levels_take_a_third_of_the_seeds_each():
    levels = [crowd_level(seed) for seed in range(150)]
    assert {level: levels.count(level) for level in CROWD_LEVELS} == {"easy": 50, "medium": 50, "hard": 50}


@pytest.mark.parametrize("family,radius", [("crowd", 0.25), ("people", 0.3)])
def test_nothing_comes_near_the_waiting_robot_at_first(family, radius):
    for seed in range(10):
        world = load_world(f"{family}:{seed}", robot_radius=radius)
        tracks = MovingTracks(world.moving)
        for t in np.arange(0.0, START_CLEAR_S, 0.05):
            xy = tracks.states(t)[:, :2]
            gaps = np.hypot(xy[:, 0] - world.start.x, xy[:, 1] - world.start.y) - tracks.reach
            assert gaps.min() > 1.0, (seed, t)


@pytest.mark.parametrize("seed", range(0, 40, 3))
def test_people_walk_in_the_lab_clear_of_its_walls(seed):
    world = load_world(f"people:{seed}", robot_radius=0.3)
    assert PEOPLE_COUNT[0] <= len(world.moving) <= PEOPLE_COUNT[1]
    assert (world.start.x, world.start.y) == PEOPLE_START
    kinds = {obstacle.name.rsplit(" ", 1)[0] for obstacle in world.moving}
    assert "head-on walker" in kinds
    for obstacle in world.moving:
        assert obstacle.radius == PERSON_RADIUS
        speeds = loop_speeds(obstacle)
        assert PERSON_SPEEDS[0] - 1e-6 <= np.median(speeds) <= PERSON_SPEEDS[1] + 1e-6
        path = np.array([obstacle.state(t)[:2] for t in np.linspace(0.0, obstacle.keyframes[-1][0], 400)
                         + obstacle.phase])
        assert world.distance(path).min() >= PERSON_RADIUS, obstacle.name


def test_generated_worlds_round_trip_through_a_file(tmp_path):
    for name in ("crowd:4", "people:4"):
        world = load_world(name, robot_radius=0.25)
        path = tmp_path / (name.replace(":", "_") + ".yaml")
        write_world(world, path)
        again = load_world(str(path), robot_radius=0.25)
        assert not again.warnings
        assert again.moving == world.moving
        assert again.extra["time_budget"] == world.extra["time_budget"]
        assert again.extra["success_radius"] == world.extra["success_radius"]


@pytest.mark.parametrize("bad", [{"success_radius": -1.0}, {"time_budget": float("nan")}, {"time_budget": "long"}])
def test_run_keys_must_be_positive_numbers(tmp_path, bad):
    path = tmp_path / "w.yaml"
    key = next(iter(bad))
    path.write_text(f"walls: []\n{key}: {bad[key]}\n")
    with pytest.raises(ValueError, match=rf"w.yaml: top level.{key}"):
        load_world(str(path))
