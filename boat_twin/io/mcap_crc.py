"""Chunk checksums for MCAP files: the rosbags writer leaves every chunk's ``uncompressed_crc`` at 0 ("not
computed"), so a reader cannot tell a corrupt chunk from good data. :func:`fill_chunk_crcs` computes the CRC-32
of each chunk's uncompressed records and writes it in place; rosbags' reader (and the mcap library) then verify
it and refuse a corrupt chunk instead of returning wrong samples.

MCAP record layout (mcap.dev specification): magic (8 bytes), then records ``opcode u8, length u64, content``.
A Chunk (opcode 0x06) holds message_start_time u64, message_end_time u64, uncompressed_size u64,
uncompressed_crc u32, compression (u32 length + UTF-8), records (u64 length + bytes).
"""

from __future__ import annotations

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
    """Write the CRC-32 of every chunk of the MCAP file ``path`` in place; returns the number of chunks.

    Reads one record header, and one chunk, at a time (a mapped file would count every page of a long
    recording in the process's resident memory)."""
    count = 0
    with path.open("r+b") as fh:
        if fh.read(len(MAGIC)) != MAGIC:
            raise InputError(f"{path}: not an MCAP file")
        pos = len(MAGIC)
        while len(header := fh.read(9)) == 9:
            opcode, length = header[0], struct.unpack_from("<Q", header, 1)[0]
            if opcode == FOOTER_OPCODE:
                break
            if opcode == CHUNK_OPCODE:
                body = fh.read(length)
                (size,) = struct.unpack_from("<Q", body, 16)
                (name_length,) = struct.unpack_from("<I", body, 28)
                compression = body[32:32 + name_length].decode()
                records_at = 32 + name_length
                (records_length,) = struct.unpack_from("<Q", body, records_at)
                records = body[records_at + 8:records_at + 8 + records_length]
                fh.seek(pos + _CRC_OFFSET)
                fh.write(struct.pack("<I", crc32(_uncompressed(compression, records, size))))
                count += 1
            pos += 9 + length
            fh.seek(pos)
    return count
