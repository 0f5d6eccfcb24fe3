"""Moving obstacles in the TEB optimiser: the edges, their prediction and the selection cost."""

import math

import numpy as np
import pytest

from simplebot_navigation.costmap.footprint import footprint_radii
from simplebot_navigation.teb import edge_kernels
from simplebot_navigation.teb.band import TimedElasticBand
from simplebot_navigation.teb.config import TebConfig
from simplebot_navigation.teb.feasibility import collision_model, is_trajectory_feasible
from simplebot_navigation.teb.footprint import FootprintModel
from simplebot_navigation.teb.homotopy_classes import Signature, moving_signature, path_times, same_class
from simplebot_navigation.teb.obstacles import planned_motion
from simplebot_navigation.teb.optimizer import TebOptimizer

from .scenes import LAB_PADDED_FOOTPRINT, LAB_TWO_CIRCLES, lab_planner, rolling_costmap, straight_plan


def straight_band(cfg, length=3.0):
    band = TimedElasticBand()
    band.init_from_path(straight_plan(0.0, length)[::6], cfg.robot.max_vel_x, cfg.robot.max_vel_theta, True,
                        cfg.trajectory.min_samples, False)
    return band


@pytest.mark.parametrize("predict", [True, False])
def test_each_interior_pose_meets_the_obstacle_where_it_is_predicted_at_the_pose_time(predict):
    cfg = TebConfig.from_params({"include_dynamic_obstacles": predict, "dynamic_obstacle_prediction_horizon": 0.0})
    band = straight_band(cfg)
    crossing = planned_motion(np.array([[1.5, -1.0, 0.0, 0.3, 0.25]]), predict)   # crosses the band's line
    edges = TebOptimizer(cfg, FootprintModel.point()).build_edges(band, None, None, 50.0, crossing, 400.0)
    stamps = band.time_stamps
    np.testing.assert_array_equal(edges.dyn_pose, np.arange(1, len(band.poses) - 1))
    expected_y = -1.0 + 0.3 * stamps[1:-1] if predict else np.full(len(stamps) - 2, -1.0)
    np.testing.assert_allclose(edges.dyn_obstacle, np.column_stack([np.full_like(expected_y, 1.5), expected_y,
                                                                    np.full_like(expected_y, 0.25)]))
    assert edges.dynamic_weight == 400.0


def test_pairs_beyond_the_association_cutoff_get_no_edge():
    cfg = TebConfig.from_params({"min_obstacle_dist": 0.3, "obstacle_association_cutoff_factor": 2.0})
    band = straight_band(cfg, length=6.0)
    model = FootprintModel.from_params(LAB_TWO_CIRCLES)
    obstacles = np.array([[5.5, 0.5, 0.0, 0.0, 0.2],           # near the end of the band only
                          [1.0, 3.0, 0.0, 0.0, 0.2]])          # 3 m off the band: beyond 0.6 + 0.4 + 0.2
    edges = TebOptimizer(cfg, model).build_edges(band, None, None, 50.0, obstacles, 50.0)
    near = band.poses[edges.dyn_pose]
    assert len(edges.dyn_pose) and np.all(edges.dyn_obstacle[:, 1] == 0.5)
    reach = 0.3 * 2.0 + model.bounding_radius + 0.2
    assert np.all(np.hypot(near[:, 0] - 5.5, near[:, 1] - 0.5) <= reach)
    inner = band.poses[1:-1]
    assert np.count_nonzero(np.hypot(inner[:, 0] - 5.5, inner[:, 1] - 0.5) <= reach) == len(edges.dyn_pose)


def test_dynamic_obstacle_cost_counts_in_the_selection_like_static_obstacles():
    cfg = TebConfig.from_params({"selection_obst_cost_scale": 7.0})
    band = straight_band(cfg)
    opt = TebOptimizer(cfg, FootprintModel.circular(0.3))
    edges = opt.build_edges(band, None, None, 50.0, np.array([[1.5, 0.2, 0.0, 0.0, 0.3]]), 50.0)
    params = opt.parameters(edges)
    chi2 = edge_kernels.family_chi2(band.poses, band.time_diffs, params, edges.arrays, opt.model.kernel_model,
                                    opt.residual_count(edges, params))
    assert chi2[edge_kernels.F_DYNAMIC] > 0
    others = chi2.sum() - chi2[edge_kernels.F_DYNAMIC]
    assert opt.selection_cost(band, edges) == pytest.approx(others + 7.0 * chi2[edge_kernels.F_DYNAMIC])


def test_the_band_gives_way_to_the_obstacle_where_it_will_be_not_where_it_is():
    cfg = TebConfig.from_params({"include_dynamic_obstacles": True, "max_vel_x": 0.5,
                                 "dynamic_obstacle_prediction_horizon": 0.0})
    model = FootprintModel.circular(0.25)
    # a 0.4 m obstacle comes head-on at 0.5 m/s, 0.3 m left of the band's line; now it is 6 m
    # away, beyond the band's end, but the band meets it half-way
    head_on = np.array([[6.0, 0.3, -0.5, 0.0, 0.4]])
    band = straight_band(cfg, length=4.0)
    TebOptimizer(cfg, model).optimize(band, np.zeros((0, 2)), None, (0.5, 0.0), False, dynamic_obstacles=head_on)
    centres = head_on[0, :2] + band.time_stamps[:, None] * head_on[0, 2:4]
    clearance = np.hypot(*(band.poses[:, :2] - centres).T) - 0.25 - 0.4
    assert clearance[1:-1].min() > cfg.obstacles.min_obstacle_dist - 0.1
    assert band.poses[:, 1].min() < -0.6                         # it swerved right
    assert np.hypot(*np.diff(band.poses[:, :2], axis=0).T).max() < 0.3


# -- the planner's input ---------------------------------------------------------------------------
def test_moving_obstacles_are_validated_and_the_bad_rows_reported_once():
    planner = lab_planner(include_dynamic_obstacles=True)
    planner.set_plan(straight_plan(0.0, 3.0))
    with pytest.raises(ValueError, match="x, y, vx, vy, radius"):
        planner.set_dynamic_obstacles(np.zeros((2, 4)))
    good = [2.0, 1.0, 0.0, -0.2, 0.3]
    for _ in range(2):
        planner.set_dynamic_obstacles(np.array([good, [np.nan, 0, 0, 0, 0.3], [1.0, 1.0, np.inf, 0, 0.3],
                                                [1.0, 1.0, 0.0, 0.0, -0.1]]))
    notices = planner.pop_notices()
    assert len(notices) == 1 and "dropped 3 of 4 dynamic obstacles" in notices[0][1]
    assert len(planner.dynamic_obstacles) == 0                   # used from the next cycle on
    planner.compute_velocity_commands((0.0, 0.0, 0.0), (0.0, 0.0), rolling_costmap(0, 0, np.zeros((0, 2))))
    np.testing.assert_array_equal(planner.dynamic_obstacles, [good])
    planner.set_dynamic_obstacles(np.zeros((0, 5)))
    planner.compute_velocity_commands((0.0, 0.0, 0.0), (0.0, 0.0), rolling_costmap(0, 0, np.zeros((0, 2))))
    assert planner.dynamic_obstacles.shape == (0, 5) and planner.pop_notices() == []


def test_the_dynamic_obstacle_parameters_take_effect_and_the_converter_names_the_tracker():
    cfg = TebConfig.from_params({"include_dynamic_obstacles": True, "weight_dynamic_obstacle": 20.0,
                                 "weight_dynamic_obstacle_inflation": 0.5, "dynamic_obstacle_inflation_dist": 0.9,
                                 "costmap_converter_plugin": "costmap_converter::CostmapToPolygonsDBSMCCH"})
    assert len(cfg.warnings) == 1
    assert "costmap_converter_plugin" in cfg.warnings[0] and "obstacle tracker" in cfg.warnings[0]


@pytest.mark.parametrize("predict", [True, False])
def test_a_predicted_collision_within_the_checked_poses_stops_the_robot(predict):
    # an obstacle rushes at the robot along its line: whatever the band does, the first poses
    # meet it -- unless it is taken to stand still 1.5 m ahead, where the band can pass it
    planner = lab_planner(include_dynamic_obstacles=predict)
    planner.set_plan(straight_plan(0.0, 3.0))
    planner.set_dynamic_obstacles(np.array([[1.5, 0.0, -1.5, 0.0, 0.3]]))
    result = planner.compute_velocity_commands((0.0, 0.0, 0.0), (0.0, 0.0), rolling_costmap(0, 0, np.zeros((0, 2))))
    if predict:
        assert not result.ok and result.message == "trajectory is not feasible. Resetting planner..."
        assert (result.v, result.omega) == (0.0, 0.0)
    else:
        assert result.ok


def test_the_feasibility_check_meets_each_obstacle_where_it_is_at_the_pose_time():
    costmap = rolling_costmap(0, 0, np.zeros((0, 2)))
    footprint = LAB_PADDED_FOOTPRINT
    inscribed = footprint_radii(footprint)[0]
    model = collision_model(footprint, inscribed)
    poses = np.column_stack([np.linspace(0.0, 2.0, 11), np.zeros(11), np.zeros(11)])
    stamps = np.linspace(0.0, 5.0, 11)                               # 0.4 m/s
    crossing = np.array([[1.0, -2.0, 0.0, 0.8, 0.3]])               # on the line at t = 2.5 s, when the robot is

    def feasible(obstacles, no_poses=10):
        return is_trajectory_feasible(costmap, footprint, inscribed, poses, no_poses, -1.0, math.pi, stamps,
                                      obstacles, model)

    assert not feasible(crossing)
    assert feasible(crossing, no_poses=3)                            # not yet within the first poses' time
    assert feasible(crossing * [1, 1, 1, -1, 1])                     # walking away
    assert not feasible(planned_motion(np.array([[1.0, 0.2, 0.0, 5.0, 0.3]]), False))   # standing on the line
    # a fast one that only the pose inserted between x = 0.8 (t = 2 s) and 1.2 (t = 3 s) meets
    fast = np.array([[1.0, -10.0, 0.0, 4.0, 0.2]])
    sparse = (costmap, footprint, inscribed, poses[::2], 5, -1.0, math.pi, stamps[::2])
    assert not is_trajectory_feasible(*sparse, fast, model)
    assert is_trajectory_feasible(*sparse, fast + [0, 1.0, 0, 0, 0], model)        # a quarter second earlier


# -- homotopy classes in space and time ------------------------------------------------------------
def test_the_same_path_driven_before_or_after_a_crossing_obstacle_is_another_class():
    path = np.column_stack([np.linspace(0.0, 4.0, 41), np.zeros(41)])
    crossing = np.array([[2.0, -2.0, 0.0, 1.0, 0.3]])              # on the path at t = 2 s

    def signature(path_xy, speed):
        return Signature(np.zeros(0), moving_signature(path_xy, path_times(path_xy, speed), crossing))

    ahead, behind = signature(path, 2.0), signature(path, 0.5)    # at x = 2 at t = 1 s, or at t = 4 s
    assert not same_class(ahead, behind)
    bump = path + np.column_stack([np.zeros(41), 0.4 * np.sin(np.linspace(0.0, math.pi, 41))])
    assert same_class(behind, signature(bump, 0.5))
    # an obstacle that stays far from both does not separate them
    far = Signature(np.zeros(0), moving_signature(path, path_times(path, 2.0), crossing + [0, -30, 0, 0, 0]))
    assert same_class(far, Signature(np.zeros(0), moving_signature(path, path_times(path, 0.5),
                                                                     crossing + [0, -30, 0, 0, 0])))


def test_bands_are_seeded_on_both_sides_of_an_oncoming_obstacle():
    planner = lab_planner(include_dynamic_obstacles=True)
    planner.set_plan(straight_plan(0.0, 4.0))
    planner.set_dynamic_obstacles(np.array([[4.0, 0.1, -0.5, 0.0, 0.3]]))
    sides = set()
    for _ in range(6):
        planner.compute_velocity_commands((0.0, 0.0, 0.0), (0.0, 0.0), rolling_costmap(0, 0, np.zeros((0, 2))))
        sides |= {int(np.sign(c.signature.moving[0])) for c in planner.planner.candidates}
    assert sides == {-1, 1}
    assert len(planner.candidate_bands) >= 2
