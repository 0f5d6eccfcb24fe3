"""The mapper on a scripted drive through the lab with drifting encoders (testing/slam_drive.py): the map against the
world, loop closures against the true poses, sessions on disk, localization on a saved session, bad input."""

import math
import zipfile

import numpy as np
import pytest

from simplebot_navigation.geometry import compose2, inverse2
from simplebot_navigation.sim.world_loader import load_world
from simplebot_navigation.slam import session
from simplebot_navigation.slam.mapper import Mapper
from simplebot_navigation.slam.scan_points import ScanPoints
from simplebot_navigation.testing.slam_drive import configured_params as lab_params
from simplebot_navigation.testing.slam_drive import drive, map_score, trajectory_rmse


@pytest.fixture(scope="module")
def lab():
    world = load_world("lab")
    # the lab tour (bench/slam.py's): the six goals and back to the start; the corridor, driven again, closes loops
    run = drive(world, [*world.goals, world.start], lab_params())
    assert run.reached
    return world, run


def test_the_map_is_the_lab_although_odometry_drifts_metres(lab):
    world, run = lab
    odometry_error = trajectory_rmse(run.odometry, run.truth)
    slam_error = trajectory_rmse(run.mapper.graph.poses, run.truth)
    assert odometry_error > 1.0
    # the marks for the lab: ATE within 5 cm, precision and recall at least 0.95 with a cell's tolerance
    assert slam_error < 0.05
    score = map_score(run.mapper.occupancy_map(), world, run)
    assert score.precision >= 0.95 and score.recall >= 0.95, score


def test_loop_closures_agree_with_the_true_poses(lab):
    _, run = lab
    truth = run.truth
    loops = [e for e in run.mapper.graph.edges if e.kind == "loop"]
    assert loops, "driving back along the corridor closes at least one loop"
    for edge in loops:
        true = compose2(inverse2(truth[edge.i]), truth[edge.j])
        # a loop edge spans metres of driving: within 3 cm and 0.01 rad of the truth (the matcher's own error is ~1 cm)
        assert math.dist(edge.relative[:2], true[:2]) < 0.03, edge
        assert abs(math.remainder(edge.relative[2] - true[2], math.tau)) < 0.01, edge


def test_without_scan_matching_the_map_is_odometry_s(lab):
    world, _ = lab
    run = drive(world, [world.goal("nw_office")], lab_params(use_scan_matching=False, do_loop_closing=False))
    assert trajectory_rmse(run.mapper.graph.poses, run.odometry) < 1e-6
    assert map_score(run.mapper.occupancy_map(), world, run).precision < 0.8


def test_a_saved_session_comes_back_whole(lab, tmp_path):
    _, run = lab
    path = session.save(run.mapper, tmp_path / "lab")
    assert path.name == "lab.posegraph.npz"
    loaded = session.load(tmp_path / "lab", run.mapper.params)
    assert len(loaded.scans) == len(run.mapper.scans)
    assert np.allclose(loaded.graph.poses, run.mapper.graph.poses, atol=1e-9)
    assert np.array_equal(loaded.occupancy_map().data, run.mapper.rendered().occupancy_map().data)


@pytest.mark.parametrize("damage", ["truncated", "not a zip", "missing", "other resolution"])
def test_a_bad_session_file_is_refused_naming_it(lab, tmp_path, damage):
    _, run = lab
    path = session.save(run.mapper, tmp_path / "lab")
    params = run.mapper.params
    if damage == "truncated":
        path.write_bytes(path.read_bytes()[: path.stat().st_size // 2])
    elif damage == "not a zip":
        path.write_text("slam session\n")
    elif damage == "missing":
        with zipfile.ZipFile(path, "w") as z:
            z.writestr("format.npy", b"")
    else:
        params = lab_params(resolution=0.1)
    with pytest.raises(ValueError, match="lab.posegraph.npz"):
        session.load(tmp_path / "lab", params)


def test_localization_on_a_saved_session_finds_the_robot(lab, tmp_path):
    world, run = lab
    session.save(run.mapper, tmp_path / "lab")
    localizer = session.load(tmp_path / "lab", lab_params(mode="localization"))
    # the robot drives the tour again, told it starts 0.2 m and 0.1 rad away from where it is
    start = (world.start.x + 0.2, world.start.y - 0.1, world.start.yaw + 0.1)
    again = drive(world, [world.goal("nw_office")], localizer.params, mapper=localizer, start=start, seed=5)
    odom = again.final_odometry
    here = localizer.pose(odom)
    truth = again.final_truth
    assert math.dist(here[:2], truth[:2]) < 0.05
    assert abs(math.remainder(here[2] - truth[2], math.tau)) < 0.02
    assert len(localizer.scans) == len(run.mapper.scans)       # localization does not extend the session


def test_hostile_input_is_refused_and_the_mapper_unchanged(lab):
    _, run = lab
    mapper = run.mapper
    nodes, poses = len(mapper.scans), mapper.graph.poses.copy()
    scan = mapper.scans[-1]
    for pose in ((math.nan, 0.0, 0.0), (0.0, math.inf, 0.0), (0.0, 0.0)):
        with pytest.raises(ValueError, match="odometry pose"):
            mapper.add_scan(pose, scan)
    empty = type(scan)(scan.origins[:2], scan.ends[:2], np.zeros(2, bool))
    with pytest.raises(ValueError, match="returns"):
        mapper.add_scan((100.0, 0.0, 0.0), empty)
    with pytest.raises(ValueError, match="pose"):
        mapper.set_pose((math.nan, 0.0, 0.0), (0.0, 0.0, 0.0))
    assert len(mapper.scans) == nodes and np.array_equal(mapper.graph.poses, poses)


def test_a_localization_mapper_without_a_session_has_no_map():
    mapper = Mapper(lab_params(mode="localization"))
    with pytest.raises(ValueError, match="no map"):
        mapper.add_scan((0.0, 0.0, 0.0), ScanPoints(np.zeros((3, 2)), np.ones((3, 2)), np.ones(3, bool)))
