"""What the collision monitor's output may be, whatever it is sent: a command the drive can follow (no rclpy).

- ``clamp``: a command beyond the drive's top speed or yaw rate is scaled down along its curvature, as the
  drive itself does (sim/diff_drive.py). The monitor judges what the robot can do: the approach check's
  steps of 100 m/s would jump over the wall they should find.
- ``Ramp``: the output speeds up at most at the drive's accelerations (at most a scan period's worth per step
  of the monitor's time, so after a standstill the robot starts from zero); slowing down and stopping pass at
  once. Commands alternating between
  +1 and -1 m/s at 1 kHz then move the robot by a few millimetres, not at full speed in either direction.
- ``RateLimit``: at most ``rate`` outputs per second of the monitor's (scan) time, a scan period's worth at
  once; braking (``brakes``) is never held back, it takes its share from the outputs after it.
"""

from __future__ import annotations

import math

#: the monitor's time (its scans' stamps) moves in steps of up to this (s): lidars at 10 Hz. The ramp counts at
#: most this per step, and the rate limit lets this much time's outputs out at once.
SCAN_PERIOD_S = 0.1


def clamp(v: float, w: float, top_v: float, top_w: float) -> tuple[float, float]:
    """(v, w) scaled by one factor so that |v| <= top_v and |w| <= top_w."""
    k = min(1.0, top_v / abs(v) if v else 1.0, top_w / abs(w) if w else 1.0)
    return v * k, w * k


class Ramp:
    """The output's acceleration limit, per component, in the monitor's time, which moves in scan-period steps:
    every output within a step may differ from the reference (the last output before the step) by acceleration
    x the step, speeding up or reversing; slowing down towards zero is always allowed, and a component that
    slows down becomes its reference at once (one that reverses, zero: it went through it). So two commands between two scans both speed up (a
    planner at 20 Hz beside 10 Hz scans is not held back every other command), and a flood alternating between
    +1 and -1 m/s gets no further than one step's worth before a reversal pins it. The monitor limits the
    command before judging it, so what it judged is what goes out."""

    def __init__(self):
        self.last, self.last_time = [0.0, 0.0], -math.inf
        self.ref, self.ref_time = [0.0, 0.0], [-math.inf, -math.inf]

    def restart(self, now: float) -> None:
        """Time went back: the last output is the reference from now on."""
        self.last_time, self.ref, self.ref_time = now, list(self.last), [now, now]

    def limit(self, target: tuple[float, float], now: float, accel: tuple[float, float]) -> tuple[float, float]:
        """``target`` with each component clipped to what its acceleration allows now."""
        if now > self.last_time:
            self.ref, self.ref_time = list(self.last), [self.last_time] * 2
        out = []
        for i, (want, a) in enumerate(zip(target, accel)):
            dt = now - self.ref_time[i]
            dt = min(dt, SCAN_PERIOD_S) if dt > 0 else 0.0      # NaN (no time yet) or time going back: no step
            ref = self.ref[i]
            out.append(min(max(want, min(ref - a * dt, 0.0)), max(ref + a * dt, 0.0)))
        return out[0], out[1]

    def published(self, out: tuple[float, float], now: float) -> None:
        for i, (o, r) in enumerate(zip(out, self.ref)):
            if o * r < 0 or abs(o) < abs(r):          # a reversal went through zero: it counts from there
                self.ref[i], self.ref_time[i] = (0.0 if o * r < 0 else o), now
        self.last, self.last_time = list(out), now


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
