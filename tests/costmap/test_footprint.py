"""Footprint parsing, padding and radii (docs/reference.md §2.2)."""

import math

import numpy as np
import pytest

from simplebot_navigation.costmap.footprint import (footprint_from_radius, footprint_radii, pad_footprint,
                                                    parse_footprint, transform_footprint)

LAB = [[0.45, 0.3], [0.45, -0.3], [-0.45, -0.3], [-0.45, 0.3]]


def test_string_and_list_forms_agree():
    np.testing.assert_array_equal(parse_footprint("[[0.45, 0.3], [0.45, -0.3], [-0.45, -0.3], [-0.45, 0.3]]"),
                                  parse_footprint(LAB))
    assert parse_footprint("[]").shape == (0, 2)


@pytest.mark.parametrize("bad, message", [
    ("[[1, 2], [3, 4]]", "at least three"),
    ("[[1, 2], [3], [4, 5]]", "point 1"),
    ("[[1, 2], [3, 'a'], [4, 5]]", "point 1"),
    ("[[1, 2], [3, 4], [4, 5", "cannot parse"),
    (42, "list of"),
])
def test_malformed_footprints_fail_clearly(bad, message):
    with pytest.raises(ValueError, match=message):
        parse_footprint(bad, "local_costmap/footprint")


def test_padding_is_per_axis_with_sign0():
    padded = pad_footprint([[0.45, 0.3], [0.0, -0.3], [-0.45, 0.0]], 0.03)
    np.testing.assert_allclose(padded, [[0.48, 0.33], [0.0, -0.33], [-0.48, 0.0]])


def test_lab_radii():
    inscribed, circumscribed = footprint_radii(pad_footprint(LAB, 0.03))
    assert inscribed == pytest.approx(0.33)
    assert circumscribed == pytest.approx(math.hypot(0.48, 0.33))


def test_default_round_robot_radii():
    fp = footprint_from_radius(0.46)
    assert len(fp) == 16 and np.allclose(np.hypot(fp[:, 0], fp[:, 1]), 0.46)
    inscribed, circumscribed = footprint_radii(pad_footprint(fp, 0.01))
    assert round(inscribed, 3) == 0.461 and round(circumscribed, 3) == 0.474


def test_transform_to_pose():
    placed = transform_footprint(LAB, 1.0, 2.0, math.pi / 2)
    np.testing.assert_allclose(placed[0], [0.7, 2.45])
