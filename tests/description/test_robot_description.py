"""The simplebot URDF for both bodies, as the costmaps, planners and simulator read it."""

import math
import xml.etree.ElementTree as ET

import pytest

from simplebot_description import builtin_worlds, robot_description, world_path

LAB_FOOTPRINT = ((0.45, 0.3), (0.45, -0.3), (-0.45, -0.3), (-0.45, 0.3))


def test_box_body_is_the_lab_robot():
    d = robot_description("box")
    assert d.body == "box"
    assert d.footprint == LAB_FOOTPRINT
    assert d.radius is None
    assert d.width == pytest.approx(0.6)
    assert d.inscribed_radius == pytest.approx(0.3)
    assert d.circumscribed_radius == pytest.approx(math.hypot(0.45, 0.3))
    assert d.laser_poses["front_laser_link"] == pytest.approx((0.35, 0.0, 0.15, 0.0))
    assert d.laser_poses["back_laser_link"] == pytest.approx((-0.35, 0.0, 0.15, math.pi))


@pytest.mark.parametrize("body", ["box", "round"])
def test_lidars_match_the_lab_hokuyo_block(body):
    scans = robot_description(body).scans
    assert sorted(scans) == ["back_laser_link", "front_laser_link"]
    for side in ("front", "back"):
        s = scans[f"{side}_laser_link"]
        assert s.topic == f"{side}_laser/{side}_scan"
        assert (s.samples, s.angle_min, s.angle_max) == (683, -2.0944, 2.0944)
        assert (s.range_min, s.range_max, s.update_rate) == (0.2, 5.6, 10.0)
        assert s.angle_increment == pytest.approx(2 * 2.0944 / 682)


@pytest.mark.parametrize("body", ["box", "round"])
def test_static_transforms_are_the_fixed_joints_from_base_link(body):
    d = robot_description(body)
    by_child = {j.child: j for j in d.fixed_joints}
    for frame, (x, y, z, yaw) in d.laser_poses.items():
        joint = by_child[frame]
        assert joint.parent == "base_link"
        assert joint.xyz == pytest.approx((x, y, z))
        assert joint.rpy == pytest.approx((0.0, 0.0, yaw))
    assert {"front_caster_link", "back_caster_link"} <= set(by_child)


def test_round_body_default_radius():
    d = robot_description("round")
    assert d.footprint is None
    assert d.radius == 0.3
    assert d.width == pytest.approx(0.6)
    # Lidar housings (0.05 m) flush with the rim, front and back.
    assert d.laser_poses["front_laser_link"] == pytest.approx((0.275, 0.0, 0.15, 0.0))
    assert d.laser_poses["back_laser_link"] == pytest.approx((-0.275, 0.0, 0.15, math.pi))


def test_round_body_radius_arg_moves_lidars_and_wheels():
    d = robot_description("round", radius=0.5)
    assert d.radius == 0.5
    assert d.laser_poses["front_laser_link"][0] == pytest.approx(0.475)
    assert d.wheel_separation == pytest.approx(2 * (0.5 - 0.07))


def test_mass_is_every_links():
    # Chassis, two 1 kg wheels, two 0.3 kg casters, two 0.16 kg lidars; the round chassis grows with the radius squared.
    assert robot_description("box").mass == pytest.approx(15.0 + 2.0 + 0.6 + 0.32)
    assert robot_description("round", radius=0.6).mass == pytest.approx(40.0 + 2.0 + 0.6 + 0.32)


@pytest.mark.parametrize("body", ["box", "round"])
def test_wheels_fit_inside_the_footprint(body):
    d = robot_description(body)
    assert d.wheel_radius == pytest.approx(0.07)
    # The wheels touch the floor through spheres of the wheel radius, flush with the sides.
    assert d.wheel_separation / 2 + d.wheel_radius == pytest.approx(d.width / 2)


@pytest.mark.parametrize("body", ["box", "round"])
def test_urdf_is_plain_urdf(body):
    urdf = robot_description(body).urdf
    root = ET.fromstring(urdf)
    assert root.tag == "robot" and root.get("name") == "simplebot"
    assert "xacro" not in urdf.split("-->")[-1]
    links = {link.get("name") for link in root.findall("link")}
    assert {"base_link", "left_wheel_link", "right_wheel_link", "front_laser_link", "back_laser_link"} <= links
    joint_types = {j.get("name"): j.get("type") for j in root.findall("joint")}
    assert joint_types["left_wheel_joint"] == joint_types["right_wheel_joint"] == "continuous"
    # Every link has a mass, so a physics engine can simulate it.
    assert all(link.find("inertial/mass") is not None for link in root.findall("link"))


@pytest.mark.parametrize("kwargs, match", [
    ({"body": "triangle"}, "robot body must be one of box, round; got 'triangle'"),
    ({"body": "round", "radius": 0.05}, r"robot radius must be within 0.15 .. 1.0 m; got 0.05"),
    ({"body": "round", "radius": 2.0}, r"within 0.15 .. 1.0 m; got 2.0"),
    ({"body": "round", "radius": float("nan")}, "robot radius must be a finite number; got nan"),
    ({"body": "round", "radius": "0.3"}, "robot radius must be a finite number; got '0.3'"),
])
def test_bad_args_are_rejected(kwargs, match):
    with pytest.raises(ValueError, match=match):
        robot_description(**kwargs)


def test_builtin_worlds():
    assert builtin_worlds() == ["clutter", "doors", "empty", "lab", "office"]
    assert world_path("lab").name == "lab.yaml"
    with pytest.raises(ValueError, match="unknown world 'attic'; built-in worlds: clutter, doors, empty, lab, office"):
        world_path("attic")
    with pytest.raises(ValueError, match="unknown world"):
        world_path("../worlds/lab")
