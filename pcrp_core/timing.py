"""Per-stage timings that cost nothing when nobody asks for them."""
from __future__ import annotations

import time


class Clock:
    """lap(name) adds the seconds since the previous lap to timings[name]; without a dict it
    only keeps time, so library code can always call it."""

    def __init__(self, timings: dict | None):
        self.timings = timings
        self.last = time.perf_counter()

    def lap(self, name: str) -> None:
        now = time.perf_counter()
        if self.timings is not None:
            self.timings[name] = self.timings.get(name, 0.0) + now - self.last
        self.last = now
