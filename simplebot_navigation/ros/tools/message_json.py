"""A ROS message from JSON, as a Foxglove client publishes it, checked field by field.

rclpy's generated setters check nothing unless ROS_PYTHON_CHECK_FIELDS is set, so a string where a
float belongs would only fail, or an out-of-range integer silently wrap, when the message is
serialized. Every value is therefore checked here against the field's declared type, and the error
names the field. Fields left out keep their defaults, as in ``ros2 topic pub``.
"""

from __future__ import annotations

import json

from rosidl_parser.definition import (AbstractGenericString, AbstractNestedType, Array, BasicType,
                                      BoundedSequence, NamespacedType)

from simplebot_navigation.ros.tools.raw_topics import message_class

FLOATS = {"float", "double", "long double"}
INTEGERS = {"octet": (0, 255), "uint8": (0, 255), "int8": (-2**7, 2**7 - 1),
            "uint16": (0, 2**16 - 1), "int16": (-2**15, 2**15 - 1), "uint32": (0, 2**32 - 1),
            "int32": (-2**31, 2**31 - 1), "uint64": (0, 2**64 - 1), "int64": (-2**63, 2**63 - 1)}


def message_from_json(msg_class: type, data: bytes):
    """The message of msg_class that the JSON object in data describes; ValueError naming the bad field."""
    try:
        values = json.loads(data)
    except (UnicodeDecodeError, json.JSONDecodeError) as err:
        raise ValueError(f"not JSON: {err}") from None
    msg = msg_class()
    _fill(msg, values, "")
    return msg


def _fill(msg, values, path: str) -> None:
    if not isinstance(values, dict):
        raise ValueError(f"{path.rstrip('.') or 'the message'} must be an object, got {_kind(values)}")
    fields = dict(zip(msg.get_fields_and_field_types(), msg.SLOT_TYPES))
    for key, value in values.items():
        name = key
        if name == "nsec" and "nanosec" in fields:
            name = "nanosec"  # Foxglove writes times as {sec, nsec}
        if name not in fields:
            raise ValueError(f"{path}{key}: {type(msg).__name__} has no such field")
        setattr(msg, name, _value(fields[name], value, f"{path}{name}"))


def _value(slot, value, path: str):
    if isinstance(slot, NamespacedType):
        nested = message_class("/".join([*slot.namespaces, slot.name]))()
        _fill(nested, value, f"{path}.")
        return nested
    if isinstance(slot, AbstractNestedType):
        if not isinstance(value, list):
            raise ValueError(f"{path} must be an array, got {_kind(value)}")
        if isinstance(slot, Array) and len(value) != slot.size:
            raise ValueError(f"{path} must have {slot.size} elements, got {len(value)}")
        if isinstance(slot, BoundedSequence) and len(value) > slot.maximum_size:
            raise ValueError(f"{path} may have at most {slot.maximum_size} elements, got {len(value)}")
        return [_value(slot.value_type, item, f"{path}[{i}]") for i, item in enumerate(value)]
    if isinstance(slot, AbstractGenericString):
        if not isinstance(value, str):
            raise ValueError(f"{path} must be of type string, got {_kind(value)}")
        return value
    if isinstance(slot, BasicType):
        kind = slot.typename
        if kind == "boolean" and isinstance(value, bool):
            return value
        if kind in FLOATS and isinstance(value, (int, float)) and not isinstance(value, bool):
            return float(value)
        if kind in INTEGERS and isinstance(value, int) and not isinstance(value, bool):
            low, high = INTEGERS[kind]
            if not low <= value <= high:
                raise ValueError(f"{path} = {value} is out of range for {kind} ({low}..{high})")
            return value
        raise ValueError(f"{path} must be of type {kind}, got {_kind(value)}")
    raise ValueError(f"{path}: fields of type {type(slot).__name__} cannot be given as JSON")


def _kind(value) -> str:
    return "null" if value is None else type(value).__name__
