"""Counters and latency windows behind the node's /diagnostics, safe to update from two threads."""
from __future__ import annotations

import threading
from collections import Counter, deque

import numpy as np


class StreamStats:
    def __init__(self, window: int = 500):
        self._lock = threading.Lock()
        self.counts = Counter()             # received, answered, rejected, dropped_stale
        self.rejections = Counter()         # by reason
        self.latency = deque(maxlen=window)  # seconds from receipt to publication
        self.age = deque(maxlen=window)      # seconds from the cloud's stamp to publication

    def count(self, key: str, reason: str | None = None) -> None:
        with self._lock:
            self.counts[key] += 1
            if reason:
                self.rejections[reason] += 1

    def timing(self, latency: float, age: float) -> None:
        with self._lock:
            self.latency.append(latency)
            self.age.append(age)

    def snapshot(self) -> dict:
        with self._lock:
            out = dict(self.counts)
            out.update({f"rejected_{k}": v for k, v in self.rejections.items()})
            for name, values in (("latency", self.latency), ("age", self.age)):
                if values:
                    p50, p95 = np.percentile(np.fromiter(values, float), [50, 95])
                    out[f"{name}_p50_ms"], out[f"{name}_p95_ms"] = 1e3 * p50, 1e3 * p95
            return out
