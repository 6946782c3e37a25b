"""pcrp_core: PCRP object retrieval and pose estimation on plain numpy arrays. No ROS here."""
from pcrp_core.errors import InvalidCloud, ModelError
from pcrp_core.result import PoseResult
from pcrp_core.pipeline import PCRP, default_model_path

__all__ = ["PCRP", "PoseResult", "InvalidCloud", "ModelError", "default_model_path"]
