"""The parameter layer: declared fields, validation, unknown keys and overrides (no rclpy)."""

from simplebot_navigation.parameters.spec import (PLUGIN_TYPE_KEY, Param, ParameterError, Status, build, fields_of,
                                                  load, namespace, param, section, set_value, unknown_key_warning,
                                                  value_of, values_of)

__all__ = ["PLUGIN_TYPE_KEY", "Param", "ParameterError", "Status", "build", "fields_of", "load", "namespace", "param",
           "section", "set_value", "unknown_key_warning", "value_of", "values_of"]
