"""Warnings of the pure costmap package, spoken through the node whose costmap raised them.

The costmap package logs with Python's `logging` (it knows no node). A move_base node runs two
costmaps, so one handler per process forwards each warning to the logger of the costmap that is
working at that moment, naming the sensor topic being processed, throttled per message (and per
``record.throttle_key``, such as the malformed field of a scan).
"""

from __future__ import annotations

import contextvars
import logging
import threading
from contextlib import contextmanager

import rclpy.logging

from simplebot_navigation.costmap.costmap_core import warm_up
from simplebot_navigation.log_throttle import Throttle

#: the Costmap2DROS whose work is running in this context (it has `name` and `logger`)
_SPEAKER: contextvars.ContextVar[object | None] = contextvars.ContextVar("costmap_speaker", default=None)
#: the sensor topic whose message is being processed, if any
_TOPIC: contextvars.ContextVar[str] = contextvars.ContextVar("costmap_topic", default="")
_process_lock = threading.Lock()
_process_prepared = False


class _NodeLogHandler(logging.Handler):
    """Forwards warnings of simplebot_navigation.costmap to the node logger, at most every 5 s per costmap,
    topic, message and throttle key."""

    def __init__(self):
        super().__init__(logging.WARNING)
        self._fallback = rclpy.logging.get_logger("simplebot_navigation.costmap")
        self._throttle = Throttle()

    def emit(self, record: logging.LogRecord) -> None:
        costmap, topic = _SPEAKER.get(), _TOPIC.get()
        if not self._throttle((id(costmap), topic, record.name, record.msg, getattr(record, "throttle_key", None)),
                              5.0):
            return
        text = f"[{topic}] {record.getMessage()}" if topic else record.getMessage()
        if costmap is None:
            self._fallback.warning(text)
        else:
            costmap.logger.warning(f"{costmap.name}: {text}")


def prepare_process() -> None:
    """Once per process: route the costmap package's warnings, load its compiled kernels."""
    global _process_prepared
    with _process_lock:
        if not _process_prepared:
            logging.getLogger("simplebot_navigation.costmap").addHandler(_NodeLogHandler())
            warm_up()
            _process_prepared = True


@contextmanager
def speaking_for(costmap, topic: str = ""):
    """Costmap warnings raised inside the block are logged by `costmap`'s node, under its name (and the
    sensor topic whose message is being processed)."""
    token, topic_token = _SPEAKER.set(costmap), _TOPIC.set(topic)
    try:
        yield
    finally:
        _TOPIC.reset(topic_token)
        _SPEAKER.reset(token)
