"""Every configuration class is declared with the parameter layer: doc, status, one warning per
parameter without effect, NaN and wrong types rejected, unknown keys named once."""

import math

import pytest

from simplebot_navigation.parameters import ParameterError, Status, fields_of

from .loaders import DELIBERATE, LOADERS

ALL = [(cls, name, spec) for cls in LOADERS for name, spec in fields_of(cls).items()]
NOT_IMPLEMENTED = [(cls, name) for cls, name, spec in ALL if spec.status is not Status.IMPLEMENTED]
NUMBERS = [(cls, name) for cls, name, spec in ALL if spec.kind in (int, float)]


def _id(value):
    return value.__name__ if isinstance(value, type) else str(value)


def test_every_parameter_has_a_doc_a_status_and_a_reason_when_it_does_nothing():
    assert len(ALL) > 200
    for cls, name, spec in ALL:
        assert spec.doc and spec.name == name, (cls, name)
        assert isinstance(spec.status, Status)
        assert spec.implemented or spec.reason, (cls, name)
        if spec.kind is float:
            assert spec.unit or spec.doc, (cls, name)


def test_the_known_parameters_without_effect_are_declared():
    names = {name for _, name in NOT_IMPLEMENTED}
    assert {"shutdown_costmaps", "make_plan_clear_costmap", "make_plan_add_unreachable_goal",
            "weight_shortest_path", "exact_arc_length", "max_vel_y",
            "min_turning_radius", "costmap_converter_plugin", "divergence_detection_enable"} <= names
    teb = [name for cls, name in NOT_IMPLEMENTED if cls.__name__ == "TebConfig"]
    assert len(teb) >= 39          # the four dynamic obstacle parameters take effect


@pytest.mark.parametrize("cls, name", NOT_IMPLEMENTED, ids=[f"{c.__name__}.{n}" for c, n in NOT_IMPLEMENTED])
def test_setting_a_parameter_without_effect_warns_once_naming_it(cls, name):
    spec = fields_of(cls)[name]
    warnings = LOADERS[cls]({name: spec.default})
    naming = [w for w in warnings if f"/{name} " in w]
    assert len(naming) == 1, warnings
    assert "no effect" in naming[0] and spec.reason in naming[0]


@pytest.mark.parametrize("cls", list(LOADERS), ids=_id)
def test_setting_every_implemented_parameter_to_its_default_warns_about_none(cls):
    given = {name: spec.default for name, spec in fields_of(cls).items()
             if spec.implemented and spec.default is not None and name not in DELIBERATE.get(cls, ())}
    warnings = LOADERS[cls](given)
    assert not [w for w in warnings if "unknown parameter" in w or "no effect" in w or
                any(f"/{name} " in w or f"/{name}:" in w for name in given)], warnings


@pytest.mark.parametrize("cls", list(LOADERS), ids=_id)
def test_an_unknown_key_is_ignored_with_one_warning_naming_it_and_the_closest_key(cls):
    name = next(iter(fields_of(cls)))
    warnings = LOADERS[cls]({name + "x": fields_of(cls)[name].default})
    unknown = [w for w in warnings if "unknown parameter" in w]
    assert len(unknown) == 1 and f"'{name}x' ignored (did you mean '{name}'?)" in unknown[0]


@pytest.mark.parametrize("cls, name", NUMBERS, ids=[f"{c.__name__}.{n}" for c, n in NUMBERS])
@pytest.mark.parametrize("bad", [math.nan, math.inf, -math.inf, "1.0", True])
def test_nan_inf_and_wrong_types_are_rejected_naming_the_key(cls, name, bad):
    with pytest.raises(ParameterError, match=rf"/{name}: expected (a number|an integer)"):
        LOADERS[cls]({name: bad})


def test_ranges_are_checked_with_the_bound_in_the_message():
    teb = LOADERS[next(c for c in LOADERS if c.__name__ == "TebConfig")]
    with pytest.raises(ParameterError, match=r"TebLocalPlannerROS/max_vel_x: must be in \(0, 2\], got -0.1"):
        teb({"max_vel_x": -0.1})
    with pytest.raises(ParameterError, match=r"TebLocalPlannerROS/max_vel_x: must be in \(0, 2\], got 1e\+308"):
        teb({"max_vel_x": 1e308})
    with pytest.raises(ParameterError, match=r"GlobalPlanner/lethal_cost: must be in \[1, 255\], got 300"):
        LOADERS[next(c for c in LOADERS if c.__name__ == "GlobalPlannerConfig")]({"lethal_cost": 300})


def test_describe_gives_doc_unit_range_and_status():
    from simplebot_navigation.teb.config import TebConfig
    specs = fields_of(TebConfig)
    assert specs["max_vel_x"].describe() == "maximum forward speed [m/s] (in (0, 2])"
    assert "accepted, not for a differential-drive robot" in specs["max_vel_y"].describe()
    assert specs["footprint_model"].describe().endswith("-- requires restart")


def test_the_readme_lists_every_parameter_without_effect():
    from pathlib import Path
    readme = (Path(__file__).resolve().parents[2] / "README.md").read_text()
    section = readme[readme.index("## Parameters"):readme.index("## Failure behaviour")]
    assert [name for _, name in NOT_IMPLEMENTED if f"`{name}`" not in section] == []
