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
Read the messages out of an MCAP file whose end is missing.

A recorder killed mid-write leaves no footer or summary, and readers that start from the
summary (rosbags does) refuse the file.

MCAP is a flat sequence of records (opcode u8, length u64, content), messages either at top
level or inside chunks that hold records in the same form, so reading front to back until
the bytes run out recovers every message written in full. Only uncompressed chunks are read
(what `pcrp make-bag` and rosbags write by default); others are reported and skipped.
Record layouts: https://mcap.dev/spec
"""
from __future__ import annotations

from pathlib import Path
import struct

MAGIC = b'\x89MCAP0\r\n'
SCHEMA, CHANNEL, MESSAGE, CHUNK = 0x03, 0x04, 0x05, 0x06


class _Cursor:
    def __init__(self, data: bytes, pos: int = 0):
        self.data, self.pos = data, pos

    def take(self, n: int) -> bytes:
        if self.pos + n > len(self.data):
            raise EOFError
        out = self.data[self.pos:self.pos + n]
        self.pos += n
        return out

    def u16(self) -> int:
        return struct.unpack('<H', self.take(2))[0]

    def u32(self) -> int:
        return struct.unpack('<I', self.take(4))[0]

    def u64(self) -> int:
        return struct.unpack('<Q', self.take(8))[0]

    def string(self) -> str:
        return self.take(self.u32()).decode('utf-8', 'replace')


def salvage(path: Path, problems: list[str]):
    """Yield (topic, schema name, log_time ns, raw CDR) of each complete message, in order."""
    data = Path(path).read_bytes()
    if not data.startswith(MAGIC):
        problems.append(f'{path.name}: not an MCAP file')
        return
    schemas, channels = {}, {}
    yield from _records(_Cursor(data, len(MAGIC)), schemas, channels, problems, path.name)


def _records(cur: _Cursor, schemas: dict, channels: dict, problems: list[str], name: str):
    while True:
        start = cur.pos
        try:
            opcode = cur.take(1)[0]
            length = cur.u64()
        except EOFError:
            if start < len(cur.data):
                problems.append(
                    f'{name}: truncated at byte {len(cur.data)}; kept the messages before it'
                )
            return
        truncated = cur.pos + length > len(cur.data)
        if truncated and opcode != CHUNK:
            problems.append(
                f'{name}: truncated at byte {len(cur.data)}; kept the messages before it'
            )
            return
        # a chunk cut short still holds whole messages before the cut
        body = _Cursor(cur.take(min(length, len(cur.data) - cur.pos)))
        try:
            if opcode == SCHEMA:
                sid = body.u16()
                schemas[sid] = body.string()
            elif opcode == CHANNEL:
                cid, sid = body.u16(), body.u16()
                channels[cid] = (body.string(), schemas.get(sid, ''))
            elif opcode == MESSAGE:
                cid, _, log_time, _ = body.u16(), body.u32(), body.u64(), body.u64()
                if cid in channels:
                    topic, msgtype = channels[cid]
                    yield topic, msgtype, log_time, body.data[body.pos:]
            elif opcode == CHUNK:
                body.u64(), body.u64(), body.u64(), body.u32()
                compression = body.string()
                if compression:
                    problems.append(f'{name}: skipped a {compression}-compressed chunk')
                    continue
                size = body.u64()
                inner = body.data[body.pos:body.pos + size]
                yield from _records(_Cursor(inner), schemas, channels, problems, name)
        except EOFError:
            problems.append(f'{name}: malformed record (opcode {opcode:#x}) skipped')
        if truncated:
            return
