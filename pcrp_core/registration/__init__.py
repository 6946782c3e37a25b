"""Registration: feature matches within symmetry halves, Procrustes in RANSAC, ICP, scoring."""
from pcrp_core.registration.icp import icp
from pcrp_core.registration.procrustes import procrustes, procrustes_batch
from pcrp_core.registration.ransac import ransac
from pcrp_core.registration.scoring import fit_quality

__all__ = ["icp", "procrustes", "procrustes_batch", "ransac", "fit_quality"]
