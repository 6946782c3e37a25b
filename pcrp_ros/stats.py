# Copyright 2026 The pcrp authors
#
# Licensed under the Apache License, Version 2.0 (the "License");
# you may not use this file except in compliance with the License.
# You may obtain a copy of the License at
#
#     http://www.apache.org/licenses/LICENSE-2.0
#
# Unless required by applicable law or agreed to in writing, software
# distributed under the License is distributed on an "AS IS" BASIS,
# WITHOUT WARRANTIES OR CONDITIONS OF ANY KIND, either express or implied.
# See the License for the specific language governing permissions and
# limitations under the License.

"""Counters and windows behind the node's /diagnostics, safe to update from several threads."""

from __future__ import annotations

from collections import Counter, deque
import threading

import numpy as np

# consecutive rejections (without an answer between them) that turn a topic's status to WARN
WARN_STREAK = 10
# clouds dropped unanswered (a newer one came first) among the last RECENT decided that turn it to
# WARN: one in four. A node that keeps up drops one now and then, when a burst meets a slow answer
RECENT, DROP_WARN = 20, 5


class StreamStats:
    """What happened to the clouds of one input topic."""

    def __init__(self, window: int = 500):
        self._lock = threading.Lock()
        self._window = window
        self.counts = Counter()             # received, answered, rejected, dropped_stale
        self.rejections = Counter()         # by reason
        self.scenes = Counter()             # what estimates had of a scene: used, missing, ...
        self.latency = deque(maxlen=window)  # seconds from receipt to publication
        self.age = deque(maxlen=window)      # seconds from the cloud's stamp to publication
        self.confidence = deque(maxlen=window)  # of the answers published
        self.strays = deque(maxlen=window)  # share of each estimate's points set aside as strays
        self.with_strays = 0                # estimates that set some aside
        self.stages = {}                    # stage -> seconds of the last `window` estimates
        self.streak = 0                     # rejections since the last answer
        self.recent = deque(maxlen=RECENT)  # how the last clouds were decided

    def count(self, key: str, reason: str | None = None) -> None:
        with self._lock:
            self.counts[key] += 1
            if reason:
                self.rejections[reason] += 1
            if key == 'rejected':
                self.streak += 1
            elif key == 'answered':
                self.streak = 0
            if key in ('answered', 'rejected', 'dropped_stale'):
                self.recent.append(key)

    def falling_behind(self) -> str:
        """Say how many of the last clouds were dropped unanswered, if that is a warning ('')."""
        with self._lock:
            return self._falling_behind()

    def _falling_behind(self) -> str:
        dropped = self.recent.count('dropped_stale')
        if dropped < DROP_WARN:
            return ''
        return (f'falling behind, {dropped} of the last {len(self.recent)} clouds dropped '
                'unanswered (a newer one came first)')

    def scene(self, outcome: str) -> None:
        """Count what one estimate had of its scene; reported as scene_<outcome>."""
        with self._lock:
            self.scenes[outcome] += 1

    def timing(self, latency: float, age: float) -> None:
        with self._lock:
            self.latency.append(latency)
            self.age.append(age)

    def estimated(self, timings: dict, confidence: float | None = None,
                  stray_share: float = 0.0) -> None:
        """
        Record one estimate: its stage timings, the confidence of a published answer, strays.

        stray_share: the share of its points set aside as lying apart from the object (a
        segmenter's mask that takes in background or flying pixels).
        """
        with self._lock:
            for stage, seconds in timings.items():
                self.stages.setdefault(stage, deque(maxlen=self._window)).append(float(seconds))
            if confidence is not None:
                self.confidence.append(float(confidence))
            self.strays.append(float(stray_share))
            self.with_strays += stray_share > 0

    def snapshot(self) -> dict:
        with self._lock:
            out = dict(self.counts)
            out.update({f'rejected_{k}': v for k, v in self.rejections.items()})
            out.update({f'scene_{k}': v for k, v in self.scenes.items()})
            windows = [('latency', self.latency), ('age', self.age)]
            windows += [(f'stage_{k}', v) for k, v in sorted(self.stages.items())]
            for name, values in windows:
                if values:
                    p50, p95 = np.percentile(np.fromiter(values, float), [50, 95])
                    out[f'{name}_p50_ms'], out[f'{name}_p95_ms'] = 1e3 * p50, 1e3 * p95
            if self.confidence:
                out['confidence_last'] = self.confidence[-1]
                out['confidence_mean'] = float(np.mean(self.confidence))
            if self.strays:
                out['with_strays'] = self.with_strays
                out['stray_share_mean'] = float(np.mean(self.strays))
            return out

    def status(self) -> tuple[bool, str]:
        """
        Say whether the stream is healthy, and how it goes in one line.

        Unhealthy when clouds were decided and none answered, when the last WARN_STREAK
        decided clouds were all rejected, or when DROP_WARN of the last RECENT were dropped
        unanswered. A cloud still being answered, the first one included, is no reason for a
        warning.
        """
        with self._lock:
            c = self.counts
            text = f"{c['answered']} answered of {c['received']}"
            if c['rejected'] and not c['answered']:
                return False, f"{text}: none answered yet, {c['rejected']} rejected " \
                              f'({_top(self.rejections)})'
            if self.streak >= WARN_STREAK:
                return False, f'{text}: the last {self.streak} rejected ({_top(self.rejections)})'
            behind = self._falling_behind()
            if behind:
                return False, f'{text}: {behind}'
            if c['received'] and not c['answered'] and not c['rejected']:
                return True, f'{text}: answering the first cloud'
            return True, text


def _top(rejections: Counter) -> str:
    return ', '.join(f'{reason} {n}' for reason, n in rejections.most_common(3))
