"""Chunk checksums for MCAP files: the rosbags writer leaves every chunk's ``uncompressed_crc`` at 0 ("not
computed"), so a reader cannot tell a corrupt chunk from good data. :func:`fill_chunk_crcs` computes the CRC-32
of each chunk's uncompressed records and writes it in place; rosbags' reader (and the mcap library) then verify
it and refuse a corrupt chunk instead of returning wrong samples; :func:`check_chunk_crcs` names the byte offset
of the corrupt chunk when a read fails.

MCAP record layout (mcap.dev specification): magic (8 bytes), then records ``opcode u8, length u64, content``.
A Chunk (opcode 0x06) holds message_start_time u64, message_end_time u64, uncompressed_size u64,
uncompressed_crc u32, compression (u32 length + UTF-8), records (u64 length + bytes).
"""

from __future__ import annotations

import mmap
import struct
from binascii import crc32
from collections.abc import Iterator
from pathlib import Path

import zstandard

from boat_twin.errors import InputError
from boat_twin.files import MCAP_MAGIC as MAGIC

CHUNK_OPCODE = 0x06
FOOTER_OPCODE = 0x02
_CRC_OFFSET = 1 + 8 + 24
"""From a chunk record's opcode to its uncompressed_crc field, bytes."""


def _uncompressed(compression: str, records: bytes, size: int) -> bytes | None:
    """A chunk's records uncompressed; None for a compression other than zstd and none (not written here)."""
    if compression == "":
        return records
    if compression == "zstd":
        return zstandard.ZstdDecompressor().decompress(records, max_output_size=size)
    return None


def _chunks(data: mmap.mmap, path: Path) -> Iterator[tuple[int, int, bytes | None]]:
    """Each chunk of the MCAP bytes ``data``: (byte offset of its record, its stored CRC, its uncompressed
    records, or None if compressed otherwise than zstd or none). A chunk that does not decompress, or overruns
    the file, is an :class:`InputError` naming it."""
    if data[:8] != MAGIC:
        raise InputError(f"{path}: not an MCAP file")
    pos = len(MAGIC)
    while pos + 9 <= len(data):
        opcode = data[pos]
        (length,) = struct.unpack_from("<Q", data, pos + 1)
        if opcode == CHUNK_OPCODE:
            try:
                body = pos + 9
                (size, crc, name_length) = struct.unpack_from("<QII", data, body + 16)
                compression = bytes(data[body + 32:body + 32 + name_length]).decode()
                records_at = body + 32 + name_length
                (records_length,) = struct.unpack_from("<Q", data, records_at)
                if records_at + 8 + records_length > len(data):
                    raise ValueError("it runs past the end of the file: truncated")
                records = bytes(data[records_at + 8:records_at + 8 + records_length])
                yield pos, crc, _uncompressed(compression, records, size)
            except (ValueError, struct.error, zstandard.ZstdError) as err:
                raise InputError(f"{path}: MCAP chunk at byte {pos} is corrupt ({err})") from None
        if opcode == FOOTER_OPCODE:
            break
        pos += 9 + length


def fill_chunk_crcs(path: Path) -> int:
    """Write the CRC-32 of every chunk of the MCAP file ``path`` in place; returns the number of chunks."""
    count = 0
    with path.open("r+b") as fh, mmap.mmap(fh.fileno(), 0) as data:
        for pos, _, records in _chunks(data, path):
            if records is None:
                raise InputError(f"{path}: MCAP chunk at byte {pos}: only zstd and uncompressed chunks are written")
            struct.pack_into("<I", data, pos + _CRC_OFFSET, crc32(records))
            count += 1
    return count


def check_chunk_crcs(path: Path) -> None:
    """Raise an :class:`InputError` naming the byte offset of the first chunk of the MCAP file ``path`` that
    does not decompress or whose records do not match their stored CRC (a CRC of 0 means "not computed")."""
    if path.stat().st_size < len(MAGIC):
        raise InputError(f"{path}: not an MCAP file ({path.stat().st_size} bytes)")
    with path.open("rb") as fh, mmap.mmap(fh.fileno(), 0, access=mmap.ACCESS_READ) as data:
        for pos, stored, records in _chunks(data, path):
            if records is not None and stored != 0 and crc32(records) != stored:
                raise InputError(f"{path}: MCAP chunk at byte {pos} is corrupt (CRC-32 of its records "
                                 f"{crc32(records):#010x}, stored {stored:#010x})")
