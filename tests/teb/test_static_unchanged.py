"""Without moving obstacles the planner's bands and commands are those recorded before dynamic
obstacles were modelled (tests/teb/static_replay.py wrote the recording from that code)."""

import json

import pytest

from .static_replay import RECORDING, RUNS, record


@pytest.fixture(scope="module")
def replayed():
    return record()


@pytest.mark.parametrize("run", [f"{s} hcp={h} dynamic={d}" for s, h, d in RUNS])
def test_cycles_without_moving_obstacles_are_bit_identical_to_the_recording(run, replayed):
    expected = json.loads(RECORDING.read_text())[run]
    assert replayed[run] == expected
