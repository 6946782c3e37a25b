"""Bags: make-bag writes clouds with ground truth, process answers them into a results bag."""
import numpy as np
import pytest

from pcrp_core import PCRP, default_model_path
from pcrp_ros.bag_commands import make_bag, process_bag, summary
from pcrp_ros.bags import CLOUD, POSE, read_bag
from rosbags.rosbag2 import Reader


@pytest.mark.parametrize("storage", ["sqlite3", "mcap"])
def test_make_bag_then_process_it(tmp_path, storage):
    bag = tmp_path / "in"
    assert make_bag(bag, "procedural:20", count=6, rate=10, seed=3, storage=storage) == 6
    clouds, truths, problems = read_bag(bag)
    assert len(clouds) == 6 and len(truths) == 6 and not problems
    for c in clouds:
        h = c["msg"].header
        assert (c["topic"], h.stamp.sec, h.stamp.nanosec) in truths and h.frame_id == "camera_optical_frame"
        assert c["points"][:, 2].min() > 0.5        # in front of the camera
    model = PCRP.load(default_model_path())
    rows = process_bag(bag, tmp_path / "out", model, quiet=True)
    assert len(rows) == 6 and all("true_id" in r for r in rows)
    answered = [r for r in rows if r["status"] == "ok"]
    assert len(answered) >= 3
    assert np.median([r["rot_err"] for r in answered]) < 10.0
    assert "accuracy on answered clouds" in summary(rows)
    with Reader(tmp_path / "out") as reader:
        topics = {c.topic: c.msgtype for c in reader.connections}
    assert topics["segmented_object/pose"] == POSE and topics["segmented_object/aligned_model"] == CLOUD


def test_a_damaged_bag_is_reported_and_what_was_read_is_kept(tmp_path):
    bag = tmp_path / "in"
    make_bag(bag, "procedural:5", count=4, rate=10)
    db = next(bag.glob("*.db3"))
    raw = db.read_bytes()
    db.write_bytes(raw[: len(raw) // 2])
    clouds, _, problems = read_bag(bag)
    assert problems and len(clouds) < 4
