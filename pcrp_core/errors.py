"""Errors a caller can act on, each with a short machine-readable reason."""


class InvalidCloud(ValueError):
    """The input cannot be answered (too few finite points, degenerate geometry...).

    ``reason`` is a short stable key (``"too_few_points"``, ``"non_finite"``,
    ``"degenerate"``) that the node counts rejections under.
    """

    def __init__(self, reason: str, message: str):
        super().__init__(message)
        self.reason = reason


class ModelError(RuntimeError):
    """A model file is missing, truncated, tampered with or from another format version."""
