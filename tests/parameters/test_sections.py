"""Sections group a configuration's parameters (as teb_config.h's structs); the names stay flat for
parsing, listing, warnings and setting by name."""

from dataclasses import dataclass

import pytest

from simplebot_navigation.parameters import (ParameterError, build, fields_of, param, section, set_value, value_of,
                                             values_of)


@dataclass(slots=True)
class Limits:
    speed: float = param(1.0, "m/s", "top speed", gt=0)


@dataclass(slots=True)
class Drive:
    frame: str = param("odom", "", "planning frame", restart=True)
    limits: Limits = section(Limits)


def test_a_section_parameter_is_parsed_listed_and_set_by_its_flat_name():
    cfg, warnings = build(Drive, {"speed": 2.0, "frame": "map", "sped": 1}, "drive")
    assert (cfg.frame, cfg.limits.speed) == ("map", 2.0)
    assert warnings == ["drive: unknown parameter 'sped' ignored (did you mean 'speed'?)"]
    assert list(fields_of(Drive)) == ["frame", "speed"] and fields_of(Drive)["speed"].unit == "m/s"
    set_value(cfg, "speed", 3.0)
    assert cfg.limits.speed == value_of(cfg, "speed") == 3.0
    assert values_of(cfg) == {"frame": "map", "speed": 3.0}
    assert build(Drive, None, "drive")[0].limits.speed == 1.0
    with pytest.raises(ParameterError, match=r"drive/speed: must be > 0, got -1.0"):
        build(Drive, {"speed": -1}, "drive")


def test_a_name_declared_in_two_sections_is_refused():
    @dataclass
    class Twice:
        front: Limits = section(Limits)
        back: Limits = section(Limits)

    with pytest.raises(TypeError, match="'speed' is declared twice"):
        fields_of(Twice)
