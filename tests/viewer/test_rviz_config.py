"""config/simplebot.rviz shows exactly the lab's step-10 list, on the topics and QoS our nodes use."""

from pathlib import Path

import yaml

RVIZ = Path(__file__).resolve().parents[2] / "config" / "simplebot.rviz"
LAB_DISPLAYS = [  # the handout's list, in its order (the Grid is RViz's default extra)
    ("rviz_default_plugins/RobotModel", "/robot_description"),
    ("rviz_default_plugins/TF", None),
    ("rviz_default_plugins/LaserScan", "/back_laser/back_scan"),
    ("rviz_default_plugins/LaserScan", "/front_laser/front_scan"),
    ("rviz_default_plugins/Path", "/move_base/GlobalPlanner/plan"),
    ("rviz_default_plugins/Path", "/move_base/TebLocalPlannerROS/local_plan"),
    ("rviz_default_plugins/PoseArray", "/move_base/TebLocalPlannerROS/teb_poses"),
    ("rviz_default_plugins/Pose", "/move_base/current_goal"),
    ("rviz_default_plugins/Map", "/global_costmap/costmap"),
    ("rviz_default_plugins/Map", "/local_costmap/costmap"),
    ("rviz_default_plugins/Odometry", "/simplebot_controller/odom"),
]


def topic_of(display: dict):
    topic = display.get("Description Topic") or display.get("Topic")
    return None if topic is None else topic["Value"]


def test_lab_display_list_in_the_odom_frame():
    config = yaml.safe_load(RVIZ.read_text())
    manager = config["Visualization Manager"]
    assert manager["Global Options"]["Fixed Frame"] == "odom"
    displays = [d for d in manager["Displays"] if d["Class"] != "rviz_default_plugins/Grid"]
    assert [(d["Class"], topic_of(d)) for d in displays] == LAB_DISPLAYS
    assert all(d["Enabled"] for d in displays)
    by_topic = {topic_of(d): d for d in displays}
    # QoS as our publishers offer it: latched description and costmaps, best-effort scans.
    assert by_topic["/robot_description"]["Description Topic"]["Durability Policy"] == "Transient Local"
    for costmap in ("/global_costmap", "/local_costmap"):
        display = by_topic[f"{costmap}/costmap"]
        assert display["Topic"]["Durability Policy"] == "Transient Local"
        assert display["Update Topic"]["Value"] == f"{costmap}/costmap_updates"
        assert display["Color Scheme"] == "costmap"
    for scan in ("/back_laser/back_scan", "/front_laser/front_scan"):
        assert by_topic[scan]["Topic"]["Reliability Policy"] == "Best Effort"


def test_2d_pose_estimate_and_2d_goal_tools_publish_to_amcl_and_move_base_simple():
    """RViz2 keeps only the tools its config lists: without SetInitialPose there is no 2D Pose Estimate button."""
    tools = yaml.safe_load(RVIZ.read_text())["Visualization Manager"]["Tools"]
    by_class = {t["Class"]: t for t in tools}
    topics = {name: by_class[f"rviz_default_plugins/{name}"]["Topic"] for name in ("SetInitialPose", "SetGoal")}
    assert topics["SetInitialPose"]["Value"] == "/initialpose"
    assert topics["SetGoal"]["Value"] == "/move_base_simple/goal"
    for topic in topics.values():       # reliable and volatile, as amcl and move_base subscribe
        assert topic["Reliability Policy"] == "Reliable" and topic["Durability Policy"] == "Volatile"
        assert topic["History Policy"] == "Keep Last" and topic["Depth"] >= 1
    estimate = by_class["rviz_default_plugins/SetInitialPose"]
    assert (estimate["Covariance x"], estimate["Covariance y"]) == (0.25, 0.25)    # RViz's spread: 0.5 m
