"""Exploration end to end in lockstep: navigation slam:=true explore:=true maps a small world on its own, a hall and
two bays behind doors of 1.5 and 2 times the box's width (sim.world_gen.doors_world; the stock doors world's third
door, 1.25 times, takes move_base's tight set). The explore node turns on the spot, drives to the frontiers of slam's
map until none is left, and has slam save the map; the map is judged by bench/exploration.py's coverage: the share of
the free space the robot can reach that the map shows free."""

import numpy as np
import pytest

from simplebot_navigation.maps.map_io import load_map
from simplebot_navigation.sim.map_export import export_map
from simplebot_navigation.sim.world import write_world
from simplebot_navigation.sim.world_gen import doors_world
from simplebot_navigation.sim.world_loader import load_world

pytestmark = [pytest.mark.e2e, pytest.mark.timeout(600)]

BENCH = "exploration"       # the conftest's bench fixture loads bench/exploration.py
#: sim seconds the two bays may take; the run repeats in lockstep and finishes at about 70 s
SIM_BUDGET_S = 240.0


@pytest.fixture(scope="module")
def two_bays(tmp_path_factory):
    path = tmp_path_factory.mktemp("world") / "two_bays.yaml"
    write_world(doors_world(0.6, ratios=(1.5, 2.0)), path)
    return str(path)


@pytest.fixture(scope="module")
def explored(bench, two_bays, tmp_path_factory):
    folder = tmp_path_factory.mktemp("explore")
    run = bench.explore(two_bays, seed=0, limit_s=SIM_BUDGET_S, save_map=str(folder / "bays"), wall_timeout_s=500.0)
    return run, folder


def test_the_world_s_own_map_covers_everything(bench, two_bays):
    world = load_world(two_bays, robot_radius=0.3)
    truth = export_map(world, 0.05)
    score = bench.coverage(truth, world, 0.3)
    assert score.swept == score.centre == score.precision == 1.0
    # every bay is behind a door the robot fits through: all of the floor counts
    assert score.reachable_cells == (truth.data == 0).sum()


def test_the_explore_node_maps_the_two_bays_to_the_end(explored):
    run, _ = explored
    assert run.finished, f"still exploring after {run.sim_time:.0f} s ({100 * run.coverage.swept:.1f} % mapped)"
    assert run.coverage.swept >= 0.95 and run.coverage.centre >= 0.98
    assert run.coverage.precision >= 0.95
    assert run.collisions == 0
    assert run.goals_sent >= 3 and run.driven > 5.0


def test_the_explored_map_is_saved(explored):
    run, folder = explored
    assert run.saved
    saved = load_map(folder / "bays.yaml")
    assert saved.resolution == pytest.approx(0.05)
    assert (folder / "bays.pgm").stat().st_size > 0
    assert (saved.data == 0).sum() > 10 * (saved.data == 100).sum() > 0
    assert np.isin(saved.data, (-1, 0, 100)).all()
