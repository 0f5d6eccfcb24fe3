"""The parameter layer: declared fields, validation, unknown keys and overrides (no rclpy)."""

from simplebot_navigation.parameters.spec import (PLUGIN_TYPE_KEY, Param, ParameterError, Status, build, fields_of,
                                                  load, namespace, param, unknown_key_warning)

__all__ = ["PLUGIN_TYPE_KEY", "Param", "ParameterError", "Status", "build", "fields_of", "load", "namespace", "param",
           "unknown_key_warning"]
