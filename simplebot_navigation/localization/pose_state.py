"""amcl's last estimate on disk, so that a respawned amcl starts where the robot is (docs/reference.md §8.9).

The file holds map -> odom, not the robot's map pose: the odometry keeps running while amcl is down, so the map pose
at the restart is this transform composed with the odometry then. It is written whole or not at all (a temporary
file renamed over it), so a kill during a write leaves the previous one.
"""

from __future__ import annotations

import math
import os
from dataclasses import dataclass
from pathlib import Path

import yaml

from simplebot_navigation.localization.amcl_params import MAX_COORDINATE, AmclParams
from simplebot_navigation.parameters import fields_of

#: the largest file taken (a few hundred bytes are written)
MAX_BYTES = 4096
VARIANCES = ("initial_cov_xx", "initial_cov_yy", "initial_cov_aa")


@dataclass(frozen=True)
class PoseState:
    frame: str                                  # the global frame
    stamp: float                                # s: the stamp of the scan the estimate is of
    map_to_odom: tuple[float, float, float]     # x, y, yaw
    variances: tuple[float, float, float]       # of x (m^2), y (m^2) and yaw (rad^2)


def save(path: str | Path, state: PoseState) -> None:
    """Write the state atomically; OSError if the folder cannot take it."""
    text = yaml.safe_dump({"frame": state.frame, "stamp": float(state.stamp),
                           "map_to_odom": [float(v) for v in state.map_to_odom],
                           "variances": [float(v) for v in state.variances]}, default_flow_style=None)
    temporary = f"{path}.tmp"
    with open(temporary, "w", encoding="utf-8") as handle:
        handle.write(text)
    os.replace(temporary, path)


def load(path: str | Path, frame: str) -> PoseState | None:
    """The state saved in ``path`` (None when there is none); ValueError naming the file and what is wrong."""
    try:
        with open(path, "rb") as handle:
            raw = handle.read(MAX_BYTES + 1)
    except FileNotFoundError:
        return None
    except OSError as err:
        raise ValueError(f"{path}: cannot be read ({err.strerror or type(err).__name__})") from None
    if len(raw) > MAX_BYTES:
        raise ValueError(f"{path}: more than {MAX_BYTES} bytes, not a saved pose")
    try:
        data = yaml.safe_load(raw.decode("utf-8"))
    except (UnicodeDecodeError, yaml.YAMLError):
        raise ValueError(f"{path}: not a saved pose (unreadable YAML)") from None
    if not isinstance(data, dict) or set(data) != {"frame", "stamp", "map_to_odom", "variances"}:
        raise ValueError(f"{path}: expected the keys frame, stamp, map_to_odom and variances")
    if data["frame"] != frame:
        raise ValueError(f"{path}: frame: the pose is in {data['frame']!r}, not in global_frame_id {frame!r}")

    def numbers(key: str, count: int) -> list[float]:
        values = data[key] if isinstance(data[key], list) else [data[key]]
        if len(values) != count or not all(isinstance(v, (int, float)) and not isinstance(v, bool)
                                           and math.isfinite(v) for v in values):
            raise ValueError(f"{path}: {key}: expected {count} finite numbers, got {data[key]!r}")
        return [float(v) for v in values]

    (stamp,), (x, y, yaw) = numbers("stamp", 1), numbers("map_to_odom", 3)
    if stamp < 0 or max(abs(x), abs(y)) > MAX_COORDINATE:
        raise ValueError(f"{path}: stamp or map_to_odom out of range: {stamp}, ({x}, {y})")
    specs = fields_of(AmclParams)       # each variance within its initial_cov_* bounds (a ParameterError otherwise)
    variances = tuple(specs[name].check(value, f"{path}: variances: {name}")
                      for name, value in zip(VARIANCES, numbers("variances", 3)))
    return PoseState(frame, stamp, (x, y, math.remainder(yaw, 2 * math.pi)), variances)
