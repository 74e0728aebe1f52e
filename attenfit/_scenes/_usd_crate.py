"""What a binary USD layer (a `.usdc` "crate" file) will need in memory, read from its
headers before usd-core opens it.

A crate file compresses its structure (tokens, paths, specs, fields) and its integer arrays:
a repeated face-vertex array of 90,000,000 entries takes 150 kB on disk, so its file size
says nothing about what reading it costs. `crate_memory` reads only headers: the table of
contents, each structural section's declared counts (usd-core decompresses those when it
opens the layer) and, from the FIELDS section's value representations, the element count
and type of every array value (decompressed when read), and returns an upper bound of the
bytes those need.

The format, from `pxr/usd/sdf/crateFile.cpp` (checked against files this usd-core writes,
versions 0.8.0 and 0.9.0): an 88-byte bootstrap (`PXR-USDC`, version major/minor/patch,
the table of contents' offset); the table: a count, then per section a 16-byte name and its
start and size; FIELDS: the field count, the token indices (compressed integers: their byte
count, then the bytes) and the value representations (`TfFastCompression`: a chunk count,
then LZ4 blocks) of 8 bytes each: bit 63 array, 62 inlined, 61 compressed, bits 48-55 the
type, the low 48 bits the file offset of the value, which for an array starts with its
element count (64 bits from version 0.7.0, 32 before). Integer arrays are compressed from
0.5.0 and structural sections from 0.4.0; older files are bounded by their size.
"""

from __future__ import annotations

import mmap
import os
import struct

from .._errors import DataFileError

__all__ = ["crate_memory"]

MAGIC = b"PXR-USDC"
#: Bytes in memory per element of an array value, by the crate's type number
#: (`crateDataTypes.h`: Bool 1 ... Vec4i 30, TimeCode 56); others count 128 (a Matrix4d).
ELEMENT_BYTES = {
    1: 1, 2: 1, 3: 4, 4: 4, 5: 8, 6: 8, 7: 2, 8: 4, 9: 8, 10: 32, 11: 8, 12: 96, 13: 32,
    14: 72, 15: 128, 16: 32, 17: 16, 18: 8, 19: 16, 20: 8, 21: 4, 22: 8, 23: 24, 24: 12,
    25: 6, 26: 12, 27: 32, 28: 16, 29: 8, 30: 16, 56: 8,
}  # fmt: skip
#: Bytes per declared entry of each structural section once usd-core has opened the layer
#: (generous: a path node, a spec in its table, a token in the registry).
SECTION_BYTES = {"TOKENS": 64, "STRINGS": 8, "FIELDS": 32, "FIELDSETS": 8, "PATHS": 256, "SPECS": 256}  # fmt: skip


def _length(src: bytes, i: int, length: int) -> tuple[int, int]:
    """An LZ4 sequence's length from its 4-bit field `length`: 15 goes on in the bytes from
    `i`, each added, until one under 255. Returns the length and the index after them."""
    if length == 15:
        while True:
            b = src[i]
            i += 1
            length += b
            if b != 255:
                break
    return length, i


def _lz4_block(src: bytes, limit: int) -> bytearray:
    """An LZ4 block decompressed (https://github.com/lz4/lz4/blob/dev/doc/lz4_Block_format.md),
    refusing more than `limit` bytes of output."""
    out = bytearray()
    i, n = 0, len(src)
    while i < n:
        token = src[i]
        i += 1
        lit, i = _length(src, i, token >> 4)
        out += src[i : i + lit]
        i += lit
        if i >= n:
            break
        off = src[i] | (src[i + 1] << 8)
        i += 2
        length, i = _length(src, i, token & 15)
        length += 4
        start = len(out) - off
        if off == 0 or start < 0:
            raise ValueError("an LZ4 match before the start")
        if off >= length:
            out += out[start : start + length]
        else:  # overlapping: the last `off` bytes repeated
            pattern = bytes(out[start:])
            out += (pattern * (length // off + 1))[:length]
        if len(out) > limit:
            raise ValueError("LZ4 output longer than declared")
    return out


def _fast_decompress(src: bytes, limit: int) -> bytearray:
    """`TfFastCompression::DecompressFromBuffer`: a chunk count (0: one block), then blocks,
    each after its 32-bit size when there are several."""
    chunks = src[0]
    if chunks == 0:
        return _lz4_block(src[1:], limit)
    out, i = bytearray(), 1
    for _ in range(chunks):
        (size,) = struct.unpack_from("<i", src, i)
        i += 4
        out += _lz4_block(src[i : i + size], limit - len(out))
        i += size
    return out


def crate_memory(path: str, size: int, where: str) -> int:
    """An upper bound on the bytes usd-core needs for the crate file `path` (`size` bytes,
    a regular file): the file, its structure once opened, and every array value read. A
    header that does not parse is refused with a `DataFileError` naming `where`."""
    fd = os.open(path, os.O_RDONLY)
    try:
        with mmap.mmap(fd, 0, access=mmap.ACCESS_READ) as mm:
            try:
                return size + _bound(mm, size)  # slices of an mmap are copies
            except (struct.error, ValueError, IndexError, KeyError, OverflowError) as exc:
                raise DataFileError(
                    f"{where}: a USD crate file whose headers do not parse ({exc})"
                ) from None
    finally:
        os.close(fd)


def _bound(b: mmap.mmap, size: int) -> int:
    if bytes(b[:8]) != MAGIC:
        raise ValueError("no PXR-USDC header")
    version = tuple(b[8:11])
    if version[0] != 0:
        raise ValueError(f"crate version {'.'.join(map(str, version))}")
    if version < (0, 4, 0):  # nothing compressed: the file's size bounds it
        return 16 * size
    (toc,) = struct.unpack_from("<q", b, 16)
    (count,) = struct.unpack_from("<Q", b, toc)
    if count > 64:
        raise ValueError(f"{count} sections")
    sections = {}
    for k in range(count):
        o = toc + 8 + 32 * k
        name = bytes(b[o : o + 16]).rstrip(b"\0").decode("ascii")
        start, length = struct.unpack_from("<qq", b, o + 16)
        if not (0 <= start and 0 <= length and start + length <= size):
            raise ValueError(f"section {name} outside the file")
        sections[name] = (start, length)
    need = 0
    for name, per in SECTION_BYTES.items():
        if name in sections:
            (n,) = struct.unpack_from("<Q", b, sections[name][0])
            need += per * n
    if "TOKENS" in sections:  # the token text, decompressed whole
        need += struct.unpack_from("<Q", b, sections["TOKENS"][0] + 8)[0]
    if version >= (0, 5, 0) and "FIELDS" in sections:
        need += _arrays(b, sections["FIELDS"][0], version)
    return need


def _arrays(b: mmap.mmap, start: int, version: tuple[int, ...]) -> int:
    """The bytes of every array value the FIELDS section at `start` refers to."""
    (fields,) = struct.unpack_from("<Q", b, start)
    p = start + 8
    (skip,) = struct.unpack_from("<Q", b, p)  # the token indices, compressed
    p += 8 + skip
    (reps_size,) = struct.unpack_from("<Q", b, p)
    p += 8
    raw = _fast_decompress(b[p : p + reps_size], 8 * fields)
    if len(raw) != 8 * fields:
        raise ValueError(f"{len(raw)} bytes of value representations for {fields} fields")
    wide = version >= (0, 7, 0)
    need = 0
    for (rep,) in struct.iter_unpack("<Q", raw):
        if rep >> 63 & 1 and not rep >> 62 & 1:  # an array, not inlined
            offset = rep & ((1 << 48) - 1)
            (n,) = struct.unpack_from("<Q" if wide else "<I", b, offset)
            need += n * ELEMENT_BYTES.get(rep >> 48 & 0xFF, 128)
    return need
