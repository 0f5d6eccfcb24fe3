"""Worlds exported as maps: the static obstacles rasterised exactly, moving ones left out, the noisy variant
reproducible per seed and different where its rule says, and the command line's bad arguments refused."""

from __future__ import annotations

import math

import numpy as np
import pytest

from simplebot_navigation.maps import load_map
from simplebot_navigation.sim import load_world
from simplebot_navigation.sim.map_export import FURNITURE_AREA_M2, MARGIN_M, export_map, main
from simplebot_navigation.sim.world import Cylinder, Wall, World

RESOLUTION = 0.1


@pytest.fixture(scope="module")
def lab():
    return load_world("lab")


@pytest.fixture(scope="module")
def lab_map(lab):
    return export_map(lab, RESOLUTION)


def cell_of(occupancy_map, x, y):
    ox, oy, _ = occupancy_map.origin
    return occupancy_map.data[math.floor((y - oy) / occupancy_map.resolution),
                              math.floor((x - ox) / occupancy_map.resolution)]


def cell_centres(occupancy_map):
    ox, oy, _ = occupancy_map.origin
    rows, cols = np.mgrid[0:occupancy_map.height, 0:occupancy_map.width]
    res = occupancy_map.resolution
    return np.column_stack(((ox + (cols + 0.5) * res).ravel(), (oy + (rows + 0.5) * res).ravel()))


@pytest.mark.parametrize("x, y, what", [(0.0, -9.0, "outer wall, south"), (12.0, 3.0, "outer wall, east"),
                                        (-10.0, 1.25, "corridor wall, north"), (3.0, -4.0, "lab wall"),
                                        (8.0, -5.0, "the rotated rack"), (0.0, -5.5, "round table")])
def test_obstacles_are_occupied(lab_map, x, y, what):
    assert cell_of(lab_map, x, y) == 100, what


@pytest.mark.parametrize("x, y, what", [(0.0, 0.0, "corridor"), (-6.0, 0.3, "corridor"), (-8.0, 1.25, "door"),
                                        (8.55, -4.05, "beside the rack, inside its bounding box"),
                                        (-10.0, 5.0, "an office"), (10.0, -6.0, "the lab room")])
def test_what_the_robot_can_reach_is_free(lab_map, x, y, what):
    assert cell_of(lab_map, x, y) == 0, what


def test_what_the_robot_cannot_reach_is_unknown_as_a_mapping_run_leaves_it(lab_map):
    assert cell_of(lab_map, -12.9, -9.9) == -1          # the margin beyond the outer walls
    assert cell_of(lab_map, 12.5, 0.0) == -1


def test_a_cell_is_occupied_exactly_when_an_obstacle_overlaps_it(lab, lab_map):
    distance = lab.distance(cell_centres(lab_map)).reshape(lab_map.data.shape)
    assert np.all(lab_map.data[distance == 0.0] == 100)                       # centre inside: overlapped
    assert np.all(lab_map.data[distance >= RESOLUTION / math.sqrt(2)] != 100)  # beyond the cell's corners: not
    assert set(np.unique(lab_map.data).tolist()) == {-1, 0, 100}


def test_the_map_covers_the_world_with_the_margin(lab, lab_map):
    xmin, ymin, xmax, ymax = lab.bounds()
    ox, oy, yaw = lab_map.origin
    assert yaw == 0.0 and ox <= xmin - MARGIN_M and oy <= ymin - MARGIN_M
    assert ox + lab_map.width * RESOLUTION >= xmax + MARGIN_M > ox + (lab_map.width - 1) * RESOLUTION
    assert round(ox / RESOLUTION, 6).is_integer()


def test_a_wall_ending_on_a_cell_boundary_leaves_the_next_cell_free():
    grid = export_map(World("w", walls=(Wall((0.0, 0.05), (1.0, 0.05), 0.1),)), RESOLUTION)
    assert cell_of(grid, 0.55, 0.05) == 100 and cell_of(grid, 0.05, 0.05) == 100 and cell_of(grid, 0.95, 0.05) == 100
    assert cell_of(grid, 0.55, 0.15) == 0 and cell_of(grid, 0.55, -0.05) == 0
    assert cell_of(grid, 1.05, 0.05) == 0 and cell_of(grid, -0.05, 0.05) == 0
    assert export_map(load_world("empty"), RESOLUTION).data.max() == 0


def test_moving_obstacles_are_not_exported(lab_map):
    people = load_world("people:2")
    assert people.moving
    assert np.array_equal(export_map(people, RESOLUTION).data, lab_map.data)


def test_noisy_maps_are_the_same_per_seed_and_differ_by_the_rule(lab, lab_map):
    noisy = export_map(lab, RESOLUTION, noisy_seed=7)
    assert np.array_equal(noisy.data, export_map(lab, RESOLUTION, noisy_seed=7).data)
    assert not np.array_equal(noisy.data, export_map(lab, RESOLUTION, noisy_seed=8).data)
    assert noisy.origin == lab_map.origin and noisy.data.shape == lab_map.data.shape

    added = (noisy.data == 100) & (lab_map.data == 0)
    removed = (noisy.data == 0) & (lab_map.data == 100)
    assert added.any() and removed.any()
    walls_only = export_map(World("walls", walls=lab.walls, start=lab.start, goals=lab.goals), RESOLUTION).data == 100
    assert walls_only.shape == lab_map.data.shape
    beside_walls = np.zeros_like(walls_only)
    beside_walls[1:] |= walls_only[:-1]
    beside_walls[:-1] |= walls_only[1:]
    beside_walls[:, 1:] |= walls_only[:, :-1]
    beside_walls[:, :-1] |= walls_only[:, 1:]
    assert np.all(beside_walls[added]), "only cells beside a wall are added"

    def area(shape):
        return math.pi * shape.radius ** 2 if isinstance(shape, Cylinder) else shape.size[0] * shape.size[1]

    furniture = [s for s in (*lab.boxes, *lab.cylinders) if area(s) <= FURNITURE_AREA_M2]
    gone = [s for s in furniture if cell_of(noisy, *s.center) == 0]
    assert len(gone) == math.ceil(len(furniture) / 5)
    gone_world = World("gone", boxes=tuple(s for s in gone if not isinstance(s, Cylinder)),
                       cylinders=tuple(s for s in gone if isinstance(s, Cylinder)))
    distance = gone_world.distance(cell_centres(noisy)[removed.ravel()])
    assert np.all(distance < RESOLUTION / math.sqrt(2)), "only the missing furniture's cells are removed"


@pytest.mark.parametrize("resolution", [0.005, 1.5, float("nan"), True])
def test_resolution_is_bounded(lab, resolution):
    with pytest.raises(ValueError, match="resolution must be 0.01 to 1.0 m per cell"):
        export_map(lab, resolution)


def test_command_line_writes_the_map(tmp_path, capsys, lab):
    out = tmp_path / "office.yaml"
    assert main(["lab", "--resolution", "0.2", "--out", str(out), "--noisy", "3"]) == 0
    assert "office.pgm" in capsys.readouterr().out
    assert np.array_equal(load_map(out).data, export_map(lab, 0.2, noisy_seed=3).data)


def exit_code(argv):
    """main()'s exit code, whether it returns it or argparse raises it."""
    try:
        return main(argv)
    except SystemExit as exit:
        return exit.code


@pytest.mark.parametrize("args, message", [
    (["--resolution", "5"], "resolution must be 0.01 to 1.0 m per cell, got 5.0"),
    (["--resolution", "fine"], "argument --resolution: invalid float value: 'fine'"),
    (["--noisy", "-1"], "noisy seed must be a whole number >= 0"),
    (["--out", "office.pgm"], "the file name must end in .yaml"),
    (["--out", "/no/such/folder/office.yaml"], "folder /no/such/folder does not exist"),
    (["--world-typo"], "unrecognized arguments: --world-typo"),
])
def test_command_line_refuses_bad_arguments_in_one_line(tmp_path, capsys, args, message):
    out = [] if "--out" in args else ["--out", str(tmp_path / "office.yaml")]
    assert exit_code(["lab", *out, *args]) == 2
    err = capsys.readouterr().err
    assert message in err and err.count("\n") == 1, err
    assert not list(tmp_path.iterdir())
