"""Closed-loop TEB runs without moving obstacles, recorded as per-cycle fingerprints (the command
bits and a digest of every band), so a change that must leave the static behaviour alone can be
held to the outputs of the code before it.

    PYTHONPATH=<checkout> python tests/teb/static_replay.py   # rewrite data/static_outputs.json

Run it with the checkout whose outputs are the reference on PYTHONPATH. The cycle budget is
lifted, so the wall clock of a loaded machine cannot postpone an alternative band.
"""

from __future__ import annotations

import hashlib
import json
from pathlib import Path

import numpy as np

from simplebot_navigation.teb import planner as planner_module
from simplebot_navigation.teb import warm_up
from tests.teb.scenes import box_cells, lab_door_scene, lab_planner, rolling_costmap, straight_plan, unicycle_step

RECORDING = Path(__file__).with_name("data") / "static_outputs.json"
CYCLES = 40


def _door():
    walls, plan = lab_door_scene()
    return walls, plan, (0.0, 0.0, 0.0)


SCENES = {
    "box": lambda: (box_cells(1.6, 0.25, 0.15, 0.15), straight_plan(0.0, 3.0), (0.0, 0.0, 0.0)),
    "barrier": lambda: (box_cells(1.5, 0.0, 0.05, 1.0), straight_plan(0.6, 3.5), (0.6, 0.0, 0.0)),
    "door": _door,
}
#: (scene, homotopy class planning, include_dynamic_obstacles)
RUNS = [(scene, hcp, dynamic) for scene in SCENES for hcp in (False, True) for dynamic in (False, True)]


def fingerprints(scene: str, homotopy: bool, dynamic: bool) -> list[str]:
    """One line per cycle: command bits, ok, and a digest of the bands' poses and time differences."""
    obstacles, plan, start = SCENES[scene]()
    planner = lab_planner(enable_homotopy_class_planning=homotopy, include_dynamic_obstacles=dynamic)
    planner.set_plan(plan)
    pose, vel, lines = np.array(start, dtype=float), (0.0, 0.0), []
    for _ in range(CYCLES):
        result = planner.compute_velocity_commands(pose, vel, rolling_costmap(pose[0], pose[1], obstacles))
        digest = hashlib.sha256()
        for cand in planner.planner.candidates:
            digest.update(np.ascontiguousarray(cand.band.poses).tobytes())
            digest.update(np.ascontiguousarray(cand.band.time_diffs).tobytes())
        lines.append(f"{result.v.hex()} {result.omega.hex()} {int(result.ok)} {digest.hexdigest()[:16]}")
        if result.goal_reached:
            break
        pose, vel = unicycle_step(pose, result.v, result.omega), (result.v, result.omega)
    return lines


def record() -> dict[str, list[str]]:
    budget = planner_module.CYCLE_BUDGET_FRACTION
    planner_module.CYCLE_BUDGET_FRACTION = 1e9
    try:
        return {f"{scene} hcp={hcp} dynamic={dynamic}": fingerprints(scene, hcp, dynamic)
                for scene, hcp, dynamic in RUNS}
    finally:
        planner_module.CYCLE_BUDGET_FRACTION = budget


if __name__ == "__main__":
    warm_up()
    RECORDING.parent.mkdir(exist_ok=True)
    RECORDING.write_text(json.dumps(record(), indent=1) + "\n")
    print(f"wrote {RECORDING}")
