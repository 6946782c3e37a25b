"""FR-PointHop point features: FPFH (or octant coordinates), Saab, sampling, octant hop 2."""
from pcrp_core.features.pointhop import PointHop

__all__ = ["PointHop"]
