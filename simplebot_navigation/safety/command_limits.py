"""What the collision monitor's output may be, whatever it is sent: a command the drive can follow (no rclpy).

- ``clamp``: a command beyond the drive's top speed or yaw rate is scaled down along its curvature, as the
  drive itself does (sim/diff_drive.py). The monitor judges what the robot can do: the approach check's
  steps of 100 m/s would jump over the wall they should find.
- ``ramp``: the output speeds up at most at the drive's accelerations over the time since the last one
  (a sign change counts from zero; at most a scan period counts, so after a standstill the robot starts
  from zero); slowing down and stopping pass at once. Commands alternating between
  +1 and -1 m/s at 1 kHz then move the robot by a few millimetres, not at full speed in either direction.
- ``RateLimit``: at most ``rate`` outputs per second of the monitor's (scan) time, a scan period's worth at
  once; braking (``brakes``) is never held back, it takes its share from the outputs after it.
"""

from __future__ import annotations

import math

#: the monitor's time (its scans' stamps) moves in steps of up to this (s): two lidars at 10 Hz. The ramp counts
#: at most this since the last output, and the rate limit lets this much time's outputs out at once.
SCAN_PERIOD_S = 0.1


def clamp(v: float, w: float, top_v: float, top_w: float) -> tuple[float, float]:
    """(v, w) scaled by one factor so that |v| <= top_v and |w| <= top_w."""
    k = min(1.0, top_v / abs(v) if v else 1.0, top_w / abs(w) if w else 1.0)
    return v * k, w * k


def ramp(last: tuple[float, float], target: tuple[float, float], dt: float, accel_v: float,
         accel_w: float) -> tuple[float, float]:
    """``target`` scaled along its curvature so that neither component grows by more than its acceleration
    times ``dt`` from ``last``."""
    dt = min(dt, SCAN_PERIOD_S) if dt > 0 else 0.0    # NaN (no time yet) or time going back: no speeding up
    k = 1.0
    for before, want, accel in ((last[0], target[0], accel_v), (last[1], target[1], accel_w)):
        allowed = (abs(before) if before * want > 0 else 0.0) + accel * dt
        if abs(want) > allowed:
            k = min(k, allowed / abs(want))
    return target[0] * k, target[1] * k


def brakes(last: tuple[float, float], new: tuple[float, float]) -> bool:
    """Whether ``new`` is ``last`` slowed down (and not the same)."""
    return new != last and all(n == 0 or (n * b > 0 and abs(n) <= abs(b)) for b, n in zip(last, new))


class RateLimit:
    """A token bucket filled by the monitor's time: ``allow`` says whether one more output may go now. A
    braking output never waits: it borrows from the outputs to come (down to a burst's worth)."""

    def __init__(self):
        self.tokens = math.inf
        self.time = -math.inf

    def allow(self, now: float, rate: float, braking: bool = False) -> bool:
        burst = 1.0 + rate * SCAN_PERIOD_S
        if now > self.time:
            self.tokens += rate * (now - self.time)
        self.time = now                   # time going back starts the count there
        self.tokens = min(self.tokens, burst)
        if self.tokens < 1.0 and not braking:
            return False
        self.tokens = max(self.tokens - 1.0, -burst)
        return True
