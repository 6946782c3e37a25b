"""Registration: feature matches within symmetry halves, Procrustes in RANSAC, ICP, mirror planes, scoring."""
from pcrp_core.registration.icp import icp, icp_batch, icp_symmetric
from pcrp_core.registration.procrustes import procrustes, procrustes_batch
from pcrp_core.registration.ransac import ransac
from pcrp_core.registration.scoring import fit_quality, fit_quality_batch

__all__ = ["icp", "icp_batch", "icp_symmetric", "procrustes", "procrustes_batch", "ransac", "fit_quality", "fit_quality_batch"]
