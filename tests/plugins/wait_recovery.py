"""An example recovery behaviour: stand still for a while (Nav2's Wait), so that a passing obstacle can clear.

One module, and its registration ``SPEC``, which a test or an application registers with
``RECOVERY_BEHAVIORS.register(SPEC)`` before move_base starts.
"""

from __future__ import annotations

from dataclasses import dataclass

from simplebot_navigation.move_base.recovery import ParameterisedRecovery, RecoveryContext, RecoveryStep
from simplebot_navigation.parameters import param
from simplebot_navigation.pluginlib import PluginSpec


@dataclass
class WaitParams:
    wait_duration: float = param(1.0, "s", "how long to stand still", gt=0)


class WaitRecovery(ParameterisedRecovery):
    PARAMS = WaitParams

    def __init__(self, name: str, params: dict):
        self.name = name
        self._until = 0.0
        self.warnings = self.configure(params)

    def start(self, now: float, pose) -> None:
        self._until = now + self.wait_duration

    def tick(self, now: float, pose) -> RecoveryStep:
        if now >= self._until:
            return RecoveryStep((0.0, 0.0), True, f"{self.name}: waited {self.wait_duration:g} s")
        return RecoveryStep((0.0, 0.0), False)


def create(context: RecoveryContext, name: str, params: dict) -> WaitRecovery:
    return WaitRecovery(name, params)


SPEC = PluginSpec("example/WaitRecovery", create, WaitParams)
