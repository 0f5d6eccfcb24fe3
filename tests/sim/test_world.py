"""World files: the built-in worlds, the generators, and the loader's error messages."""

import math
import textwrap

import pytest

from simplebot_description import robot_description, world_path
from simplebot_navigation.sim import (
    World, clutter_world, door_goal_name, doors_world, load_world, world_from_dict, write_world)
from simplebot_navigation.sim.office import office_world

from .reachability import reachable_goals

LAB_BOX = robot_description("box")
# The lab's costmap footprint is the box plus footprint_padding 0.03.
PADDED_HALF_WIDTH = LAB_BOX.inscribed_radius + 0.03


def test_lab_world_fits_the_lab_global_costmap():
    world = load_world("lab", robot_radius=LAB_BOX.inscribed_radius)
    xmin, ymin, xmax, ymax = world.bounds()
    s = world.start
    # 30 x 30 m costmap centred on the start (odom origin = start pose), with a margin.
    assert max(s.x - xmin, xmax - s.x, s.y - ymin, ymax - s.y) <= 14.0


def test_lab_goals_are_in_different_rooms_and_reachable_by_the_box_robot():
    world = load_world("lab")
    names = [g.name for g in world.goals]
    assert len(names) >= 4 and len(set(names)) == len(names)
    assert reachable_goals(world, PADDED_HALF_WIDTH) == names


def test_lab_doors_are_too_narrow_for_a_1p5_m_wide_robot():
    # Rooms are closed except for their doors (all < 1.5 m): nothing but the corridor is reachable.
    assert reachable_goals(load_world("lab"), 0.75) == []


def test_doors_world_widths_and_one_door_per_goal():
    world = doors_world(0.6)
    doors = {d["goal"]: d for d in world.extra["doors"]}
    assert [d["width"] for d in doors.values()] == [0.75, 0.9, 1.2]
    assert [g.name for g in world.goals] == ["door_1.25x", "door_1.5x", "door_2x"]
    assert world.goal(door_goal_name(1.5)) == world.goals[1]
    # Clear opening = stated width: a disc just narrower passes, one just wider does not.
    for goal, door in doors.items():
        assert goal in reachable_goals(world, door["width"] / 2 - 0.03)
        assert goal not in reachable_goals(world, door["width"] / 2 + 0.03)


def test_doors_world_scales_with_the_robot():
    world = doors_world(0.9, ratios=(1.5,))
    assert world.extra["doors"][0]["width"] == 1.35
    with pytest.raises(ValueError, match="door ratio 5 gives width 4.5 m"):
        doors_world(0.9, ratios=(5,))
    with pytest.raises(ValueError, match="robot_width must be a positive number"):
        doors_world(-0.6)


def test_clutter_world_is_seeded_and_passable():
    a, b, c = clutter_world(3), clutter_world(3), clutter_world(4)
    assert a == b
    assert a.boxes != c.boxes
    assert len(a.boxes) == 8 and len(a.cylinders) == 8
    assert reachable_goals(a, 0.45) == [g.name for g in a.goals]


def test_clutter_world_that_cannot_fit_fails():
    with pytest.raises(ValueError, match="could not place 200 boxes"):
        clutter_world(0, n_boxes=200)


@pytest.mark.parametrize("name, generated", [("doors", doors_world(0.6)), ("clutter", clutter_world(0)),
                                             ("office", office_world())])
def test_shipped_generated_worlds_match_their_generator(name, generated):
    assert load_world(name).to_dict() == generated.to_dict()


def test_empty_world():
    world = load_world("empty")
    assert (world.walls, world.boxes, world.cylinders) == ((), (), ())
    assert world.distance([[0.0, 0.0]])[0] == math.inf


def test_write_world_round_trip(tmp_path):
    lab = load_world("lab")
    write_world(lab, tmp_path / "copy.yaml", header="copy of lab")
    copy = load_world(tmp_path / "copy.yaml")
    assert copy.to_dict() == lab.to_dict()
    assert (tmp_path / "copy.yaml").read_text().startswith("# copy of lab\n")


def test_distance_to_rotated_box_and_cylinder():
    world = world_from_dict({"boxes": [{"center": [0, 0], "size": [2, 1], "yaw": math.pi / 2}],
                             "cylinders": [{"center": [5, 0], "radius": 0.5}],
                             "start": {"x": 2.5, "y": 0}})
    # Rotated 90 degrees: the box spans x -0.5..0.5, y -1..1.
    assert world.distance([[1.5, 0.0], [0.0, 3.0], [2.5, 0.0], [5.0, 0.2]]) == pytest.approx([1.0, 2.0, 2.0, 0.0])
    assert world.nearest_obstacle(4.0, 0.0) == (pytest.approx(0.5), "cylinders[0]")


def write(tmp_path, text, name="bad.yaml"):
    path = tmp_path / name
    path.write_text(textwrap.dedent(text))
    return path


@pytest.mark.parametrize("text, message", [
    ("boxes: [{center: [1, 1], size: [1, 1]}, {center: [3, 3], size: [0.5, -0.2]}]",
     "bad.yaml: boxes[1].size: negative size -0.2"),
    ("walls: [{from: [0, 1], to: [4, 1], thickness: thick}]",
     "bad.yaml: walls[0].thickness: expected a number, got str 'thick'"),
    ("walls: [{from: [0, 1], to: [4, 1], thicknes: 0.2}]",
     "bad.yaml: walls[0]: unknown key 'thicknes'"),
    ("walls: [{from: [0, 1], to: [0, 1]}]", r"bad.yaml: walls\[0\]: from and to are the same point"),
    ("walls: [{from: [0, 1, 2], to: [4, 1]}]", r"bad.yaml: walls\[0\].from: expected \[x, y\], got \[0, 1, 2\]"),
    ("cylinders: [{center: [2, 2], radius: -0.1}]", "bad.yaml: cylinders[0].radius: negative radius -0.1"),
    ("cylinders: [{center: [2, 2], radius: .nan}]", "bad.yaml: cylinders[0].radius: expected a finite number"),
    ("cylinders: [{center: [2, 2]}]", "bad.yaml: cylinders[0]: missing key 'radius'"),
    ("boxes: [{center: [2, 2], size: [1, 1], yaw: true}]", "bad.yaml: boxes[0].yaw: expected a number, got bool"),
    ("boxes: {center: [2, 2], size: [1, 1]}", "bad.yaml: boxes: expected a list, got dict"),
    ("boxes: [[2, 2]]", r"bad.yaml: boxes\[0\]: expected a mapping, got list"),
    ("start: {x: 0, y: zero}", "bad.yaml: start.y: expected a number, got str 'zero'"),
    ("start: [0, 0]", "bad.yaml: start: expected a mapping"),
    ("name: [lab]", "bad.yaml: name: expected a non-empty string"),
    ("- just a list", "bad.yaml: top level: expected a mapping"),
    ("boxes: [{center: [0, 0], size: [1, 1]}]", r"bad.yaml: start \(0.0, 0.0\) is inside boxes\[0\]"),
    ("cylinders: [{center: [4, 0], radius: 0.5}]\ngoals: [{x: 1, y: 1}, {x: 4.2, y: 0.1}]",
     r"bad.yaml: goals\[1\] \(4.2, 0.1\) is inside cylinders\[0\]"),
    ("walls: [{from: [-1, 0.2], to: [1, 0.2]}]",
     r"bad.yaml: start \(0.0, 0.0\) is 0.150 m from walls\[0\], closer than the robot radius 0.3"),
    ("walls: [{from: [0, 1], to: [4, 1]\n", "bad.yaml: not valid YAML"),
])
def test_bad_world_files_name_file_and_entry(tmp_path, text, message):
    with pytest.raises(ValueError, match=message.replace("[", r"\[").replace("]", r"\]")
                       if "\\" not in message else message):
        load_world(write(tmp_path, text), robot_radius=0.3)


def test_unknown_world_name_lists_builtins():
    with pytest.raises(ValueError, match=r"world 'attic': not a built-in world "
                                         r"\(clutter, doors, empty, lab, office\)"):
        load_world("attic")


def test_unknown_top_level_keys_warn_and_labels_are_kept(tmp_path):
    path = write(tmp_path, """\
        name: office
        author: me
        movng: []
        boxes: [{center: [3, 0], size: [1, 1], name: desk}]
        goals: [{x: 5, y: 0, name: window}]
        """)
    world = load_world(path)
    assert world.name == "office" and world.source == "bad.yaml"
    assert world.extra == {}
    assert world.warnings == ("bad.yaml: unknown world key 'author'; ignored",
                              "bad.yaml: unknown world key 'movng' (did you mean 'moving'?); ignored")
    assert world.boxes[0].name == "desk"
    assert world.goal("window").x == 5.0
    with pytest.raises(ValueError, match="bad.yaml: no goal named 'door'; goals: window"):
        world.goal("door")


def test_robot_radius_must_be_sane():
    with pytest.raises(ValueError, match="robot_radius must be a finite number >= 0"):
        load_world("lab", robot_radius=-1)


def test_world_path_is_what_load_world_reads():
    assert load_world(world_path("lab")).to_dict() == load_world("lab").to_dict()
    assert isinstance(load_world("lab"), World)
