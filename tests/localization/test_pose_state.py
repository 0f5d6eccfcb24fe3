"""amcl's saved estimate: written whole, read back the same, and a file that is not one refused naming why."""

from __future__ import annotations

import pytest

from simplebot_navigation.localization import pose_state
from simplebot_navigation.localization.pose_state import PoseState


def test_a_saved_state_loads_back_and_a_missing_one_is_none(tmp_path):
    state = PoseState("map", 12.5, (1.0, -2.0, 0.5), (0.01, 0.02, 0.003))
    pose_state.save(tmp_path / "amcl.pose.yaml", state)
    assert pose_state.load(tmp_path / "amcl.pose.yaml", "map") == state
    assert [p.name for p in tmp_path.iterdir()] == ["amcl.pose.yaml"]       # no temporary left behind
    assert pose_state.load(tmp_path / "none.yaml", "map") is None


@pytest.mark.parametrize("text, problem", [
    ("frame: map\nstamp: 1\nmap_to_odom: [0, 0, .nan]\nvariances: [1, 1, 1]\n", "map_to_odom: expected 3 finite"),
    ("frame: map\nstamp: 1\nmap_to_odom: [0, 0, 0]\nvariances: [1.0e+13, 1, 1]\n", "initial_cov_xx: must be"),
    ("frame: odom\nstamp: 1\nmap_to_odom: [0, 0, 0]\nvariances: [1, 1, 1]\n", "not in global_frame_id 'map'"),
    ("frame: map\nstamp: -5\nmap_to_odom: [0, 0, 0]\nvariances: [1, 1, 1]\n", "out of range"),
    ("[1, 2", "unreadable YAML"),
    ("x" * 5000, "more than 4096 bytes"),
])
def test_a_file_that_is_not_a_saved_pose_is_refused_naming_it(tmp_path, text, problem):
    path = tmp_path / "amcl.pose.yaml"
    path.write_text(text)
    with pytest.raises(ValueError, match=f"^{path}: ") as error:
        pose_state.load(path, "map")
    assert problem in str(error.value)
