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

"""
Model directory format: `model.json` (metadata) + `arrays.npz` (numbers).

Never pickle.

`model.json` holds the format version, hyperparameters, gallery IDs and categories and what the
model was built from, plus the SHA-256 of `arrays.npz`, so a truncated or altered array file
is refused with a message instead of producing wrong poses.
"""
from __future__ import annotations

import hashlib
import json
from pathlib import Path
import zipfile

import numpy as np
from pcrp_core.errors import ModelError

FORMAT = 'pcrp-model'
# 2: a view calibration may be boosted trees, which version 1's readers would silently drop
FORMAT_VERSION = 2
READS = (1, 2)
META_FILE = 'model.json'
ARRAYS_FILE = 'arrays.npz'


def _sha256(path: Path) -> str:
    h = hashlib.sha256()
    with open(path, 'rb') as f:
        for chunk in iter(lambda: f.read(1 << 20), b''):
            h.update(chunk)
    return h.hexdigest()


def write_model(path, meta: dict, arrays: dict) -> Path:
    path = Path(path)
    path.mkdir(parents=True, exist_ok=True)
    arrays_path = path / ARRAYS_FILE
    np.savez_compressed(arrays_path, **arrays)
    # the format this code writes, first, whatever a model read from an older file says it had
    own = ('format', 'format_version', 'arrays_sha256')
    meta = {'format': FORMAT, 'format_version': FORMAT_VERSION,
            **{k: v for k, v in meta.items() if k not in own},
            'arrays_sha256': _sha256(arrays_path)}
    (path / META_FILE).write_text(json.dumps(meta, indent=1))
    return path


def read_model(path) -> tuple[dict, dict]:
    path = Path(path)
    if not path.exists():
        raise ModelError(
            f'{path}: no such model (expected a directory with {META_FILE} and {ARRAYS_FILE})'
        )
    if path.is_file():
        raise ModelError(
            f'{path}: a model is a directory holding {META_FILE} and {ARRAYS_FILE}, not a file'
        )
    meta_path, arrays_path = path / META_FILE, path / ARRAYS_FILE
    for p in (meta_path, arrays_path):
        if not p.is_file():
            raise ModelError(f'{p}: missing from the model directory')
    try:
        meta = json.loads(meta_path.read_text())
    except (OSError, UnicodeDecodeError, json.JSONDecodeError) as e:
        raise ModelError(f'{meta_path}: unreadable model metadata ({e})') from None
    if not isinstance(meta, dict) or meta.get('format') != FORMAT:
        raise ModelError(
            f'{meta_path}: not a pcrp model (format field is '
            f"{meta.get('format') if isinstance(meta, dict) else None!r})"
        )
    if meta.get('format_version') not in READS:
        raise ModelError(
            f"{meta_path}: model format version {meta.get('format_version')!r}, "
            f"this pcrp reads versions {', '.join(map(str, READS))}; rebuild the model with "
            '`pcrp build`'
        )
    if _sha256(arrays_path) != meta.get('arrays_sha256'):
        raise ModelError(
            f'{arrays_path}: checksum does not match {META_FILE} (truncated or modified)'
        )
    try:
        with np.load(arrays_path, allow_pickle=False) as npz:
            arrays = {k: npz[k] for k in npz.files}
    except (OSError, ValueError, zipfile.BadZipFile, EOFError) as e:
        raise ModelError(f'{arrays_path}: unreadable arrays ({e})') from None
    return meta, arrays


def model_size(path) -> int:
    """Bytes on disk of a model directory."""
    return sum(p.stat().st_size for p in Path(path).glob('*') if p.is_file())
