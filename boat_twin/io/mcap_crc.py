"""Chunk checksums for MCAP files: the rosbags writer leaves every chunk's ``uncompressed_crc`` at 0 ("not
computed"), so a reader cannot tell a corrupt chunk from good data. :func:`fill_chunk_crcs` computes the CRC-32
of each chunk's uncompressed records and writes it in place; rosbags' reader (and the mcap library) then verify
it and refuse a corrupt chunk instead of returning wrong samples.

MCAP record layout (mcap.dev specification): magic (8 bytes), then records ``opcode u8, length u64, content``.
A Chunk (opcode 0x06) holds message_start_time u64, message_end_time u64, uncompressed_size u64,
uncompressed_crc u32, compression (u32 length + UTF-8), records (u64 length + bytes).
"""

from __future__ import annotations

import mmap
import struct
from binascii import crc32
from pathlib import Path

import zstandard

from boat_twin.errors import InputError

MAGIC = b"\x89MCAP0\r\n"
CHUNK_OPCODE = 0x06
FOOTER_OPCODE = 0x02
_CRC_OFFSET = 1 + 8 + 24
"""From a chunk record's opcode to its uncompressed_crc field, bytes."""


def _uncompressed(compression: str, records: bytes, size: int) -> bytes:
    if compression == "":
        return records
    if compression == "zstd":
        return zstandard.ZstdDecompressor().decompress(records, max_output_size=size)
    raise InputError(f"MCAP chunk compression {compression!r}: only zstd and none are written here")


def fill_chunk_crcs(path: Path) -> int:
    """Write the CRC-32 of every chunk of the MCAP file ``path`` in place; returns the number of chunks."""
    count = 0
    with path.open("r+b") as fh, mmap.mmap(fh.fileno(), 0) as data:
        if data[:8] != MAGIC:
            raise InputError(f"{path}: not an MCAP file")
        pos = len(MAGIC)
        while pos + 9 <= len(data):
            opcode = data[pos]
            (length,) = struct.unpack_from("<Q", data, pos + 1)
            if opcode == CHUNK_OPCODE:
                body = pos + 9
                (size,) = struct.unpack_from("<Q", data, body + 16)
                (name_length,) = struct.unpack_from("<I", data, body + 28)
                compression = bytes(data[body + 32:body + 32 + name_length]).decode()
                records_at = body + 32 + name_length
                (records_length,) = struct.unpack_from("<Q", data, records_at)
                records = bytes(data[records_at + 8:records_at + 8 + records_length])
                struct.pack_into("<I", data, pos + _CRC_OFFSET, crc32(_uncompressed(compression, records, size)))
                count += 1
            if opcode == FOOTER_OPCODE:
                break
            pos += 9 + length
    return count
