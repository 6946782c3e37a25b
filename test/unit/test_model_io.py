"""Model files: a round trip keeps every array and answer. (Every way a file can be broken is
in pcrp_ros/faults.py, tried on the core, the node and the CLI by test_node_robustness.py.)"""
import numpy as np

from pcrp_core import PCRP


def test_round_trip_keeps_every_array_and_answer(small_model, tmp_path):
    model = PCRP.load(small_model)
    model.save(tmp_path / "again")
    again = PCRP.load(tmp_path / "again")
    assert again.gallery_ids == model.gallery_ids
    np.testing.assert_array_equal(again.gallery.vectors, model.gallery.vectors)
    q = model.gallery_cloud(model.gallery_ids[3])
    a, b = model.estimate(q), again.estimate(q)
    assert a.gallery_id == b.gallery_id
    np.testing.assert_allclose(a.transform, b.transform)
