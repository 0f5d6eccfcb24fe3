"""nav2_msgs and geographic_msgs, built from their definitions (docs/design.md §10): every interface imports, goes
through the middleware's serialization, and refers to the other packages' types by the hashes their wheels ship."""

import importlib
import json
import math
import pathlib
import sys

import pytest
from rclpy.serialization import deserialize_message, serialize_message

INTERFACES = pathlib.Path(__file__).resolve().parents[2] / "interfaces"
SHARE = pathlib.Path(sys.prefix) / "share"


def definitions(package: str) -> list[tuple[str, str]]:
    return sorted((p.parent.name, p.stem) for p in (INTERFACES / package).glob("*/*")
                  if p.suffix in (".msg", ".srv", ".action"))


@pytest.mark.parametrize("package", ["nav2_msgs", "geographic_msgs"])
def test_every_interface_of_the_definitions_imports(package):
    found = definitions(package)
    assert len(found) == {"nav2_msgs": 51, "geographic_msgs": 20}[package]
    for kind, name in found:
        assert hasattr(importlib.import_module(f"{package}.{kind}"), name), f"{package}/{kind}/{name}"


def test_a_follow_waypoints_result_survives_serialization():
    from geometry_msgs.msg import PoseStamped
    from nav2_msgs.action import FollowWaypoints
    from nav2_msgs.msg import MissedWaypoint
    missed = MissedWaypoint(index=2, error_code=FollowWaypoints.Result.TASK_EXECUTOR_FAILED)
    missed.goal = PoseStamped()
    missed.goal.pose.position.x = -3.25
    result = FollowWaypoints.Result(missed_waypoints=[missed], error_code=0, error_msg="goal outside the costmap")
    back = deserialize_message(serialize_message(result), FollowWaypoints.Result)
    assert back.missed_waypoints[0].index == 2
    assert back.missed_waypoints[0].goal.pose.position.x == -3.25
    assert back.missed_waypoints[0].error_code == FollowWaypoints.Result.TASK_EXECUTOR_FAILED
    assert back.error_msg == "goal outside the costmap"


def test_a_geo_pose_survives_serialization():
    from geographic_msgs.msg import GeoPoseStamped
    msg = GeoPoseStamped()
    msg.pose.position.latitude, msg.pose.position.longitude, msg.pose.position.altitude = 48.1, 11.5, math.nan
    back = deserialize_message(serialize_message(msg), GeoPoseStamped)
    assert (back.pose.position.latitude, back.pose.position.longitude) == (48.1, 11.5)
    assert math.isnan(back.pose.position.altitude)


def test_result_and_feedback_constants_of_the_same_name_both_exist():
    from nav2_msgs.action import DockRobot, FollowObject
    assert DockRobot.Result.NONE == DockRobot.Feedback.NONE == 0
    assert DockRobot.Result.UNKNOWN == 999 and DockRobot.Feedback.RETRY == 5
    assert FollowObject.Feedback.STOPPING == 3


def _hashes(package: str) -> dict[str, str]:
    out = {}
    for path in (SHARE / package).glob("*/*.json"):
        for entry in json.loads(path.read_text())["type_hashes"]:
            out.setdefault(entry["type_name"], entry["hash_string"])
    return out


def test_types_from_other_packages_carry_the_hashes_their_wheels_ship():
    referenced = {**_hashes("geographic_msgs"), **_hashes("nav2_msgs")}
    checked = 0
    for type_name, hash_string in referenced.items():
        package, kind, name = type_name.split("/")
        if package in ("nav2_msgs", "geographic_msgs"):
            continue
        if name.endswith(("_Goal", "_Result", "_Feedback", "_Request", "_Response", "_Event", "_FeedbackMessage")):
            continue
        own = json.loads((SHARE / package / kind / f"{name}.json").read_text())["type_hashes"][0]
        assert own["type_name"] == type_name
        assert own["hash_string"] == hash_string, type_name
        checked += 1
    assert checked >= 10     # builtin_interfaces, std_msgs, geometry_msgs, nav_msgs, unique_identifier_msgs
