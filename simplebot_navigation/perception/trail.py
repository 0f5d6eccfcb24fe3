"""Where moving tracks have been lately: the regions the costmaps clear (docs/reference.md §6)."""

from __future__ import annotations

from collections import deque

import numpy as np


class ClearingTrail:
    """Track positions of the last `keep` seconds, and the ids that were moving then. A track that turns
    moving brings its earlier positions with it (the marks it left before it was known to move), and a deleted
    track's trail is cleared until it ages out."""

    def __init__(self, keep: float):
        self.keep = float(keep)
        self._entries: deque[tuple[float, np.ndarray, np.ndarray]] = deque()   # (stamp, ids, rows x y r)
        self._moving_until: dict[int, float] = {}                               # id -> last stamp it moved

    def add(self, stamp: float, ids: np.ndarray, rows: np.ndarray, moving_ids) -> None:
        """Positions (x, y, radius) of the tracks `ids` at `stamp`, and which of them move now; a second update at
        the same stamp (the other lidar) replaces the first."""
        if self._entries and self._entries[-1][0] == stamp:
            self._entries.pop()
        self._entries.append((float(stamp), np.asarray(ids, dtype=np.int64), np.asarray(rows, dtype=float)))
        for track_id in moving_ids:
            self._moving_until[int(track_id)] = float(stamp)
        self._forget(stamp)

    def _forget(self, now: float) -> None:
        while self._entries and now - self._entries[0][0] > self.keep:
            self._entries.popleft()
        for track_id in [i for i, t in self._moving_until.items() if now - t > self.keep]:
            del self._moving_until[track_id]

    def circles(self, now: float, margin: float) -> np.ndarray:
        """(K, 3) circles x, y, radius + margin where tracks that moved within `keep` of now have been."""
        if not self._moving_until:
            return np.empty((0, 3))
        moving = np.fromiter(self._moving_until, dtype=np.int64)
        parts = [rows[np.isin(ids, moving)] for stamp, ids, rows in self._entries if now - stamp <= self.keep]
        out = np.concatenate(parts) if parts else np.empty((0, 3))
        out[:, 2] += margin
        return out

    def clear(self) -> None:
        self._entries.clear()
        self._moving_until.clear()
