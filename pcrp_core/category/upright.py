"""Which way is up, when the caller knows it: hypotheses that tip the gallery's up axis away from
it are dropped (the turns near-symmetric shapes are most confused by are upside-down and
lying-down ones)."""

from __future__ import annotations

import numpy as np


class UpPrior:
    """up: (the up direction in the query's frame, the gallery's up axis), unit vectors, or None
    when unknown; tolerance_deg: how far an answer may tip the object."""

    def __init__(self, up, tolerance_deg: float):
        self.up = None if up is None else tuple(np.asarray(u, dtype=np.float64) for u in up)
        self.cos_min = np.cos(np.radians(tolerance_deg)) - 1e-9

    @property
    def known(self) -> bool:
        return self.up is not None

    def upright(self, Rs) -> np.ndarray:
        """(H,) whether each query-to-gallery rotation keeps the gallery's up axis within the
        tolerance of the known up direction (all true when up is unknown)."""
        Rs = np.asarray(Rs).reshape(-1, 3, 3)
        if self.up is None:
            return np.ones(len(Rs), bool)
        q_up, g_up = self.up
        return (Rs @ q_up) @ g_up >= self.cos_min

    def keep(self, hyps: list) -> list:
        """The upright hypotheses; all of them when none is (a prior nothing satisfies, say a
        wrong up parameter, is ignored rather than answered with nothing)."""
        ok = self.upright([h.R for h in hyps]) if hyps else np.zeros(0, bool)
        return [h for h, k in zip(hyps, ok) if k] or hyps
