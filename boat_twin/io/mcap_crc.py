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

import os
import struct
from binascii import crc32
from collections.abc import Iterator
from pathlib import Path
from typing import BinaryIO

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


def _chunks(fh: BinaryIO, path: Path) -> Iterator[tuple[int, int, bytes | None]]:
    """Each chunk of the open MCAP file ``fh``: (byte offset of its record, its stored CRC, its uncompressed
    records, or None if compressed otherwise than zstd or none). Reads one record header, and one chunk, at a
    time (a mapped file would count every page of a long recording in the process's resident memory). A chunk
    that does not decompress, or overruns the file, is an :class:`InputError` naming it."""
    if fh.read(len(MAGIC)) != MAGIC:
        raise InputError(f"{path}: not an MCAP file")
    file_size = os.fstat(fh.fileno()).st_size
    pos = len(MAGIC)
    while len(header := fh.read(9)) == 9:
        opcode, length = header[0], struct.unpack_from("<Q", header, 1)[0]
        if opcode == FOOTER_OPCODE:
            break
        if pos + 9 + length > file_size:  # a corrupt length: never read or seek by it
            raise InputError(f"{path}: MCAP record at byte {pos} claims {length} bytes, past the end of the file "
                             f"({file_size} bytes): corrupt or truncated")
        if opcode == CHUNK_OPCODE:
            try:
                body = fh.read(length)
                if len(body) < length:
                    raise ValueError("it runs past the end of the file: truncated")
                size, crc, name_length = struct.unpack_from("<QII", body, 16)
                compression = body[32:32 + name_length].decode()
                (records_length,) = struct.unpack_from("<Q", body, 32 + name_length)
                records = body[40 + name_length:40 + name_length + records_length]
                uncompressed = _uncompressed(compression, records, size)
            except (ValueError, struct.error, zstandard.ZstdError) as err:
                raise InputError(f"{path}: MCAP chunk at byte {pos} is corrupt ({err})") from None
            yield pos, crc, uncompressed
        pos += 9 + length
        fh.seek(pos)


def fill_chunk_crcs(path: Path) -> int:
    """Write the CRC-32 of every chunk of the MCAP file ``path`` in place; returns the number of chunks."""
    count = 0
    with path.open("r+b") as fh:
        for pos, _, records in _chunks(fh, path):
            if records is None:
                raise InputError(f"{path}: MCAP chunk at byte {pos}: only zstd and uncompressed chunks are written")
            fh.seek(pos + _CRC_OFFSET)  # the iterator seeks on to the next record itself
            fh.write(struct.pack("<I", crc32(records)))
            count += 1
    return count


def check_chunk_crcs(path: Path) -> None:
    """Raise an :class:`InputError` naming the byte offset of the first chunk of the MCAP file ``path`` that
    does not decompress or whose records do not match their stored CRC (a CRC of 0 means "not computed")."""
    with path.open("rb") as fh:
        for pos, stored, records in _chunks(fh, path):
            if records is not None and stored != 0 and crc32(records) != stored:
                raise InputError(f"{path}: MCAP chunk at byte {pos} is corrupt (CRC-32 of its records "
                                 f"{crc32(records):#010x}, stored {stored:#010x})")
