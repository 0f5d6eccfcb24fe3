"""teb_local_planner's FailureDetector: tells from the recent velocity commands whether the robot
oscillates, i.e. hardly moves and hardly turns on average while its turning direction keeps
flipping (a band that jumps between passing an obstacle left and right does exactly that).
"""

from __future__ import annotations

from collections import deque

import numpy as np

#: a turn rate below this fraction of max_vel_theta counts as no turn when the flips of its sign are counted: the
#: optimiser's numerical noise around a standstill (1e-4 rad/s of either sign) is not a robot rocking to and fro
TURN_NOISE_FLOOR = 0.01


def buffer_length(filter_duration: float, controller_period: float) -> int:
    """Commands in oscillation_filter_duration seconds of control cycles."""
    return max(0, round(filter_duration / controller_period))


class FailureDetector:
    """Ring buffer of the last commands, each normalised by its limit so that the thresholds
    (oscillation_v_eps, oscillation_omega_eps) are fractions of the robot's speeds."""

    def __init__(self, length: int):
        self._buffer: deque[tuple[float, float]] = deque(maxlen=length)
        self.oscillating = False

    def set_buffer_length(self, length: int) -> None:
        """A new window (live oscillation_filter_duration or controller_frequency); the newest
        commands are kept."""
        self._buffer = deque(self._buffer, maxlen=length)

    def clear(self) -> None:
        self._buffer.clear()
        self.oscillating = False

    def update(self, v: float, omega: float, max_vel_x: float, max_vel_x_backwards: float, max_vel_theta: float,
               v_eps: float, omega_eps: float) -> bool:
        """Add one command and decide afresh; returns whether the robot oscillates."""
        if self._buffer.maxlen == 0:
            return self.oscillating
        limit_v = max_vel_x if v > 0 else max_vel_x_backwards if v < 0 else 0.0
        self._buffer.append((v / limit_v if limit_v > 0 else v,
                             omega / max_vel_theta if max_vel_theta > 0 else omega))
        self.oscillating = self._detect(v_eps, omega_eps)
        return self.oscillating

    def _detect(self, v_eps: float, omega_eps: float) -> bool:
        """Only once the buffer is half full: small mean v and omega, and omega's sign (zero, or a turn rate below
        the noise floor, counting as a sign of its own) changed more than once."""
        if len(self._buffer) < self._buffer.maxlen // 2:
            return False
        v, omega = np.array(self._buffer).T
        sign = np.where(np.abs(omega) < TURN_NOISE_FLOOR, 0.0, np.sign(omega))
        crossings = int(np.count_nonzero(sign[1:] != sign[:-1]))
        return bool(abs(v.mean()) < v_eps and abs(omega.mean()) < omega_eps and crossings > 1)
