"""Per-key throttling of log messages, shared by every node: rclpy's throttle is per call site, and one call
site speaks of many topics, sensors and fields."""

from __future__ import annotations

import math
import time


class Throttle:
    """Per-key wall-clock throttling (rclpy's throttle is per call site, not per message)."""

    def __init__(self):
        self._last: dict = {}

    def __call__(self, key, period: float) -> bool:
        now = time.monotonic()
        if now - self._last.get(key, -math.inf) < period:
            return False
        self._last[key] = now
        return True
