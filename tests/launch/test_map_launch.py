"""navigation map:=... : map_server and amcl start, the global costmap moves to map, the encoders drift, and each
robot's amcl starts where the robot does."""

import pytest

from simplebot_navigation.launch.loader import LaunchError, load_launch


def by_name(config):
    return {node.full_name: node for node in config.nodes}


def test_without_a_map_nothing_changes():
    nodes = by_name(load_launch("navigation", {}))
    assert "/amcl" not in nodes and "/map_server" not in nodes
    assert nodes["/move_base"].parameters["global_costmap.global_frame"] == "/odom"
    sim = nodes["/simulator"].parameters
    assert sim["map_to_odom"] is True and "odom_scale_std" not in sim


def test_a_map_starts_map_server_and_amcl_and_moves_the_global_costmap_to_map():
    nodes = by_name(load_launch("navigation", {"map": "people:2", "world": "people:2", "viewer": "true"}))
    assert nodes["/map_server"].parameters["yaml_filename"] == "people:2"
    amcl = nodes["/amcl"].parameters
    assert (amcl["initial_pose_x"], amcl["initial_pose_y"], amcl["initial_pose_a"]) == (-9.5, 0.0, 0.0)
    assert amcl["odom_frame_id"] == "odom" and amcl["global_frame_id"] == "map"
    assert ("map", "/map") in nodes["/amcl"].remaps
    move_base = nodes["/move_base"].parameters
    assert move_base["global_costmap.global_frame"] == "map"
    assert move_base["global_costmap.static_layer.map_topic"] == "/map"
    assert move_base["local_costmap.global_frame"] == "/odom"
    sim = nodes["/simulator"].parameters
    assert sim["map_to_odom"] is False and sim["odom_scale_std"] > 0 and sim["odom_speed_std"] > 0
    assert nodes["/viewer"].parameters["fixed_frame"] == "map"


def test_initial_pose_and_encoder_noise_arguments():
    nodes = by_name(load_launch("navigation", {"map": "lab", "initial_pose": "1.5,-2,0.5", "encoder_noise": "false"}))
    amcl = nodes["/amcl"].parameters
    assert (amcl["initial_pose_x"], amcl["initial_pose_y"], amcl["initial_pose_a"]) == (1.5, -2.0, 0.5)
    assert "odom_scale_std" not in nodes["/simulator"].parameters
    with pytest.raises(LaunchError, match="initial_pose:='1,2;3,4' must be one x,y,yaw"):
        load_launch("navigation", {"map": "lab", "initial_pose": "1,2;3,4"})
    with pytest.raises(LaunchError, match=r"entry 1 'x,y,z' is not x,y or x,y,yaw"):
        load_launch("navigation", {"map": "lab", "initial_pose": "x,y,z"})


def test_several_robots_share_one_map_and_each_amcl_starts_at_its_robot():
    nodes = by_name(load_launch("multi_navigation", {"robots": "2", "map": "lab", "starts": "0,0,0;2,1,3.0"}))
    assert "/map_server" in nodes and "/robot1/map_server" not in nodes
    second = nodes["/robot2/amcl"].parameters
    assert (second["initial_pose_x"], second["initial_pose_y"], second["initial_pose_a"]) == (2.0, 1.0, 3.0)
    assert second["odom_frame_id"] == "robot2/odom" and second["base_frame_id"] == "robot2/base_link"
    assert nodes["/robot2/move_base"].parameters["global_costmap.global_frame"] == "map"
    assert nodes["/robot2/move_base"].parameters["local_costmap.global_frame"] == "robot2/odom"
    assert nodes["/simulator"].parameters["map_to_odom"] is False
