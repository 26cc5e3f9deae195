"""Reading the records of an MCAP file that may be truncated or damaged.

The ``mcap`` package's stream reader stops at the first bad record and trusts every length
field (a length corrupted to 2⁴⁰ asks for a terabyte). This scanner frames the top-level
records itself, never reads past the end of the file, checks every chunk's CRC, and after
a damaged record resumes at the next record that parses as a whole chunk — so what is
readable after the damage is still read. Each problem is reported once, as one line.
"""

from __future__ import annotations

import io
import struct
import zlib
from collections.abc import Iterator
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import zstandard
from mcap.data_stream import ReadDataStream
from mcap.opcode import Opcode
from mcap.records import (
    Attachment,
    Channel,
    Chunk,
    Footer,
    Header,
    Message,
    Metadata,
    Schema,
)

MAGIC = b"\x89MCAP0\r\n"
MAX_CHUNK_BYTES = 1 << 31
"""Largest uncompressed chunk accepted (our writer's chunks are about 1 MiB)."""

_RECORDS: dict[int, Any] = {
    Opcode.HEADER: Header,
    Opcode.SCHEMA: Schema,
    Opcode.CHANNEL: Channel,
    Opcode.METADATA: Metadata,
    Opcode.ATTACHMENT: Attachment,
}
_CHUNK_HEAD = struct.Struct("<QQQII")  # start, end, uncompressed size, crc, compression length


class DamagedRecordError(ValueError):
    """A record's bytes are inconsistent (bad length, bad CRC, bad compression)."""


@dataclass
class ScanReport:
    """What the scan found wrong: one line per damaged record, and whether the file ends
    inside a record (a killed or still-running writer)."""

    problems: list[str] = field(default_factory=list)
    truncated: bool = False


def parse_chunk(body: bytes | memoryview) -> Chunk:
    """A Chunk record from its body, checked field by field against the body's length."""
    if len(body) < _CHUNK_HEAD.size:
        raise DamagedRecordError("chunk header cut short")
    start, end, size, crc, name_length = _CHUNK_HEAD.unpack_from(body, 0)
    offset = _CHUNK_HEAD.size + name_length
    if offset + 8 > len(body):
        raise DamagedRecordError("chunk compression name runs past the record")
    compression = bytes(body[_CHUNK_HEAD.size : offset]).decode("utf-8", errors="replace")
    if compression not in ("zstd", "lz4", ""):
        raise DamagedRecordError(f"unknown chunk compression {compression[:16]!r}")
    (data_length,) = struct.unpack_from("<Q", body, offset)
    if offset + 8 + data_length > len(body):
        raise DamagedRecordError(f"chunk data of {data_length} bytes runs past the record")
    if size > MAX_CHUNK_BYTES:
        raise DamagedRecordError(f"chunk claims {size} uncompressed bytes")
    data = bytes(body[offset + 8 : offset + 8 + data_length])
    return Chunk(
        compression=compression,
        data=data,
        message_end_time=end,
        message_start_time=start,
        uncompressed_crc=crc,
        uncompressed_size=size,
    )


def chunk_records(chunk: Chunk) -> list[Any]:
    """The records inside a chunk, after checking its CRC."""
    try:
        if chunk.compression == "zstd":
            data = zstandard.ZstdDecompressor().decompress(
                chunk.data, max_output_size=chunk.uncompressed_size
            )
        elif chunk.compression == "lz4":
            import lz4.frame  # type: ignore[import-not-found]

            data = lz4.frame.decompress(chunk.data)
        else:
            data = chunk.data
    except (zstandard.ZstdError, MemoryError, RuntimeError) as error:
        raise DamagedRecordError(f"chunk does not decompress ({type(error).__name__})") from None
    if len(data) != chunk.uncompressed_size:
        raise DamagedRecordError("chunk size differs from its header")
    if chunk.uncompressed_crc and zlib.crc32(data) != chunk.uncompressed_crc:
        raise DamagedRecordError("chunk CRC mismatch")
    records, offset = [], 0
    while offset < len(data):
        if offset + 9 > len(data):
            raise DamagedRecordError("record inside a chunk cut short")
        opcode, length = data[offset], struct.unpack_from("<Q", data, offset + 1)[0]
        body = data[offset + 9 : offset + 9 + length]
        if len(body) != length:
            raise DamagedRecordError("record inside a chunk runs past it")
        records.append(_parse(opcode, body))
        offset += 9 + length
    return [record for record in records if record is not None]


def _parse(opcode: int, body: bytes | memoryview) -> Any:
    """The record ``opcode`` from its body; None for record kinds we do not use."""
    stream = ReadDataStream(io.BytesIO(bytes(body)))
    try:
        if opcode == Opcode.MESSAGE:
            return Message.read(stream, len(body))
        if opcode == Opcode.CHUNK:
            return parse_chunk(body)
        if opcode == Opcode.FOOTER:
            return Footer.read(stream)
        if opcode in _RECORDS:
            record = _RECORDS[opcode].read(stream)
            if stream.count > len(body):
                raise DamagedRecordError("record fields run past its length")
            return record
    except DamagedRecordError:
        raise
    except Exception as error:  # any parse failure of hostile bytes is damage
        raise DamagedRecordError(f"unreadable record ({type(error).__name__})") from None
    return None


def _next_chunk(data: bytes, start: int) -> int | None:
    """Offset of the next top-level record at or after ``start`` that parses as a whole
    chunk (opcode, length within the file, consistent fields), or None."""
    position = data.find(bytes([Opcode.CHUNK]), start)
    while position >= 0:
        if position + 9 <= len(data):
            (length,) = struct.unpack_from("<Q", data, position + 1)
            end = position + 9 + length
            if end <= len(data):
                try:
                    parse_chunk(memoryview(data)[position + 9 : end])
                    return position
                except DamagedRecordError:
                    pass
        position = data.find(bytes([Opcode.CHUNK]), position + 1)
    return None


def scan_records(path: Path, report: ScanReport) -> Iterator[Any]:
    """Every readable record of the file in order (chunks opened), problems into
    ``report``. Raises ValueError (one line) only when the file is not MCAP at all."""
    data = path.read_bytes()
    if data[: len(MAGIC)] != MAGIC:
        raise ValueError(f"{path} is not an MCAP file (bad magic bytes)")
    position = len(MAGIC)
    while position < len(data):
        if position + 9 > len(data):
            report.truncated = True
            return
        opcode = data[position]
        (length,) = struct.unpack_from("<Q", data, position + 1)
        end = position + 9 + length
        try:
            if end > len(data):
                raise DamagedRecordError(f"length {length} runs past the end of the file")
            record = _parse(opcode, memoryview(data)[position + 9 : end])
            records = chunk_records(record) if isinstance(record, Chunk) else [record]
        except DamagedRecordError as error:
            resume = _next_chunk(data, position + 1)
            finished = data.endswith(MAGIC)  # a writer that stopped early wrote no end magic
            if resume is None and end > len(data) and not finished:
                report.truncated = True  # the writer stopped inside this record
                return
            where = "nothing readable after it" if resume is None else f"resuming at {resume}"
            report.problems.append(
                f"{path}: record at byte {position} (opcode {opcode:#04x}) is damaged "
                f"({error}); {where}"
            )
            if resume is None:
                return
            position = resume
            continue
        for item in records:
            if isinstance(item, Footer):
                return
            if item is not None:
                yield item
        position = end
