"""Model files: round trip, and every way a file can be wrong fails at load with a clear message."""
import json
import shutil

import numpy as np
import pytest

from pcrp_core import ModelError, PCRP
from pcrp_core.model_io import ARRAYS_FILE, META_FILE, _sha256


@pytest.fixture
def copy(small_model, tmp_path):
    dst = tmp_path / "m"
    shutil.copytree(small_model, dst)
    return dst


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


@pytest.mark.parametrize("damage, words", [
    (lambda p: shutil.rmtree(p), "no such model"),
    (lambda p: (p / ARRAYS_FILE).unlink(), "missing"),
    (lambda p: (p / ARRAYS_FILE).write_bytes((p / ARRAYS_FILE).read_bytes()[:1000]), "checksum"),
    (lambda p: (p / META_FILE).write_text("{not json"), "unreadable model metadata"),
    (lambda p: _edit_meta(p, format_version=99), "format version 99"),
    (lambda p: _edit_meta(p, format="something-else"), "not a pcrp model"),
])
def test_damaged_models_are_refused_with_a_message(copy, damage, words):
    damage(copy)
    with pytest.raises(ModelError, match=words):
        PCRP.load(copy)


def test_a_pickled_object_in_the_arrays_is_refused_even_with_a_valid_checksum(copy):
    arrays = dict(np.load(copy / ARRAYS_FILE, allow_pickle=False))
    arrays["gallery_lengths"] = np.array([{"evil": 1}], dtype=object)
    np.savez(copy / ARRAYS_FILE, **arrays)
    _edit_meta(copy, arrays_sha256=_sha256(copy / ARRAYS_FILE))
    with pytest.raises(ModelError, match="unreadable arrays"):
        PCRP.load(copy)


def test_inconsistent_contents_are_refused(copy):
    _edit_meta(copy, gallery_ids=["only_one"])
    with pytest.raises(ModelError, match="incomplete or inconsistent"):
        PCRP.load(copy)


def _edit_meta(path, **changes):
    meta = json.loads((path / META_FILE).read_text())
    meta.update(changes)
    (path / META_FILE).write_text(json.dumps(meta))
