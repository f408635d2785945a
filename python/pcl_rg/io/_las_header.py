"""Checks of a LAS/LAZ file's header against the file's size, before laspy reads it.

laspy trusts the header: it loops over as many VLRs as the header claims and
allocates ``point_count * record_length`` bytes before decompressing a single
point. A damaged or hostile header then means minutes of looping or an allocation
of terabytes. Every count and offset in the header is checked here against the
file size first, with bounded work (at most one read per VLR, and the VLR count is
checked against the bytes available before the walk).

The extra-bytes records' checks and repairs are in _las_extra_bytes.py.

Layout of the public header block (ASPRS LAS 1.4 R15, table 3; the earlier
versions are prefixes of it): version at byte 24, header size at 94, offset to
the point data at 96, VLR count at 100, point format at 104, record length at
105, the legacy point count at 107; LAS 1.4 adds the first EVLR's offset at 235,
the EVLR count at 243 and the 64-bit point count at 247.
"""

from __future__ import annotations

import math
import os
import struct
from collections.abc import Iterator
from typing import BinaryIO, NamedTuple

# Smallest public header block of each minor version 0-4.
_HEADER_SIZE = {0: 227, 1: 227, 2: 227, 3: 235, 4: 375}
# Smallest record of each point data format 0-10 (LAS 1.4 R15, tables 7-17).
_RECORD_SIZE = (20, 28, 26, 34, 57, 63, 30, 36, 38, 59, 67)
# reserved u16, user id 16 bytes, record id u16, length after header (u16 for a VLR,
# u64 for an EVLR), description 32 bytes.
_VLR_HEADER = 54
_EVLR_HEADER = 60
_LASZIP_USER_ID = "laszip encoded"
_LASZIP_RECORD_ID = 22204
_VARIABLE_CHUNKS = 0xFFFFFFFF
_LAYERED_CHUNKED = 3  # LASzip's compressor code for LAS 1.4 point formats 6-10
_BYTE14 = 14
_LAYERS = {10: 9, 11: 1, 12: 2, 13: 1}  # Point14, RGB14, RGBNIR14, Wavepacket14
# LASzip's item types for each point data format 0-10, in record order: Point10 (6),
# GpsTime11 (7), Rgb12 (8), Wavepacket13 (9); Point14 (10), Rgb14 (11), RgbNir14 (12),
# Wavepacket14 (13); extra bytes add one Byte (0) item, or Byte14 (14) in formats 6-10.
_ITEM_TYPES = (
    (6,), (6, 7), (6, 8), (6, 7, 8), (6, 7, 9), (6, 7, 8, 9),
    (10,), (10, 11), (10, 12), (10, 13), (10, 12, 13),
)  # fmt: skip
# Largest accepted ratio of a LAZ file's point records to its compressed bytes. A
# million identical points compress about 3000-fold (point formats 0-7, measured
# with lazrs); real surveys 5- to 10-fold. A larger claim is damage.
_LAZ_MAX_RATIO = 100_000
# Most bytes a point after a pointwise chunk's first takes, per byte of its record:
# LASzip's arithmetic coder spends about a tenth on real surveys and never more than
# about twice on any; 4x is a bound that only a count far too low can beat.
_POINTWISE_MAX_RATIO = 4
# Largest chunk handed to lazrs's parallel reader (LASzip's default chunk of 50 000
# points takes 1.5-3.4 MB); files with larger chunks are read sequentially.
_PARALLEL_CHUNK_BYTES = 64 << 20


class LasRecord(NamedTuple):
    """A VLR or EVLR as its header in the file gives it (``pcl-rg info`` lists them)."""

    kind: str  # "VLR" or "EVLR"
    user_id: str
    record_id: int
    description: str
    length: int  # bytes after the record's header


class LasFacts(NamedTuple):
    """What the checks found, for the reader to size its work by."""

    point_count: int
    compressed: bool
    parallel_decompression: bool
    """False when a LAZ chunk is too large for lazrs's parallel reader, which
    allocates a whole chunk's points at once (the sequential reader does not), or when
    the chunk table misplaces a chunk (_first_points_in_box)."""
    spare_records: int
    """How many more point records the file holds after the counted ones: LAS, the
    room before what follows them (EVLRs, waveform packets, the end of the file);
    LAZ, the points its chunks hold beyond the count, at least (_check_chunk_table)."""
    records: tuple[LasRecord, ...]
    """The VLRs, then the EVLRs, in file order."""


def _bad(path: str, problem: str) -> ValueError:
    return ValueError(f"invalid LAS/LAZ file {path!r}: {problem}")


def _read_at(stream: BinaryIO, offset: int, size: int) -> bytes:
    stream.seek(offset)
    return stream.read(size)


def _records(
    stream: BinaryIO, path: str, kind: str, start: int, count: int, limit: int, limit_name: str
) -> Iterator[tuple[int, bytes, int]]:
    """(offset, header, payload length) of `count` (E)VLRs from `start`, checked to end by `limit`.

    A VLR's header is 54 bytes with a 2-byte length, an EVLR's 60 with an 8-byte
    length; both hold the length at byte 20.
    """
    header_size, length_format = (_VLR_HEADER, "<H") if kind == "VLR" else (_EVLR_HEADER, "<Q")
    position = start
    for index in range(count):
        header = _read_at(stream, position, header_size)
        if len(header) < header_size:
            raise _bad(path, f"{kind} {index} at offset {position} is truncated")
        (length,) = struct.unpack_from(length_format, header, 20)
        if length > limit - position - header_size:
            raise _bad(
                path,
                f"{kind} {index} ({length} bytes from offset {position}) runs past "
                f"{limit_name} at {limit}",
            )
        yield position, header, length
        position += header_size + length


def check_las_header(path: str, stream: BinaryIO) -> LasFacts:
    """Raise ValueError naming the field if the header does not fit the file."""
    file_size = os.fstat(stream.fileno()).st_size
    head = _read_at(stream, 0, 375)
    if len(head) < 227 or head[:4] != b"LASF":
        raise _bad(path, f"file is {file_size} bytes, shorter than the 227-byte LAS header")
    major, minor = head[24], head[25]
    if major != 1 or minor not in _HEADER_SIZE:
        raise _bad(path, f"version {major}.{minor} is not LAS 1.0-1.4")
    (header_size, data_offset, vlr_count, format_byte, record_length, legacy_count) = (
        struct.unpack_from("<HIIBHI", head, 94)
    )
    if not _HEADER_SIZE[minor] <= header_size <= file_size:
        raise _bad(
            path,
            f"header size {header_size} must be between {_HEADER_SIZE[minor]} (LAS 1.{minor}) "
            f"and the file size {file_size}",
        )
    if not header_size <= data_offset <= file_size:
        raise _bad(
            path,
            f"offset to point data {data_offset} must be between the header size "
            f"{header_size} and the file size {file_size}",
        )
    # Bit 7 of the format byte marks LASzip compression. laspy reads a byte with bit 6
    # set too as uncompressed records, which is what LASzip's compressed bytes are not:
    # the checks below took such a file as LAZ, and laspy then read garbage.
    if format_byte & 0x40:
        raise _bad(
            path,
            f"point data format byte 0x{format_byte:02x} sets bit 6, which marks no "
            "format laspy reads (LAZ sets bit 7 alone)",
        )
    point_format, compressed = format_byte & 0x3F, bool(format_byte & 0x80)
    if point_format >= len(_RECORD_SIZE):
        raise _bad(path, f"point data format {point_format} is not one of 0-10")
    if record_length < _RECORD_SIZE[point_format]:
        raise _bad(
            path,
            f"point record length {record_length} is shorter than the "
            f"{_RECORD_SIZE[point_format]} bytes of point format {point_format}",
        )
    scales, offsets = struct.unpack_from("<3d", head, 131), struct.unpack_from("<3d", head, 155)
    for axis, scale, offset in zip("xyz", scales, offsets):
        # Stored coordinates are int32: every one of them must map to a finite number.
        if not (scale != 0.0 and math.isfinite(abs(scale) * 2.0**31 + abs(offset))):
            raise _bad(
                path, f"{axis} scale {scale!r} and offset {offset!r} do not give finite coordinates"
            )
    point_count = legacy_count
    evlr_start = evlr_count = 0
    if minor >= 4:
        evlr_start, evlr_count, point_count = struct.unpack_from("<QIQ", head, 235)
        # LAS 1.4 keeps the legacy count equal to the count, or 0 (more than 2^32 - 1
        # points, or formats 6-10). Another value is a damaged header: the count read
        # would be a guess, and 0 of them gave an empty output without a word.
        if legacy_count not in (0, point_count):
            raise _bad(
                path,
                f"header's point counts disagree: {point_count} (LAS 1.4) against "
                f"{legacy_count} (legacy); a damaged header?",
            )

    vlr_room = data_offset - header_size
    if vlr_count * _VLR_HEADER > vlr_room:
        raise _bad(
            path,
            f"header claims {vlr_count} VLRs, but the {vlr_room} bytes before the point data "
            f"hold at most {vlr_room // _VLR_HEADER}",
        )
    laszip_vlr = None
    vlrs = _records(
        stream, path, "VLR", header_size, vlr_count, data_offset, "the start of the point data"
    )
    records = []
    for position, vlr, length in vlrs:
        records.append(_record("VLR", vlr, length))
        if (records[-1].user_id, records[-1].record_id) == (_LASZIP_USER_ID, _LASZIP_RECORD_ID):
            laszip_vlr = _read_at(stream, position + _VLR_HEADER, length)

    if evlr_count:
        if not data_offset <= evlr_start <= file_size - evlr_count * _EVLR_HEADER:
            raise _bad(
                path,
                f"{evlr_count} EVLRs from offset {evlr_start} do not fit between the point "
                f"data at {data_offset} and the end of the file at {file_size}",
            )
        evlrs = _records(
            stream, path, "EVLR", evlr_start, evlr_count, file_size, "the end of the file"
        )
        records += [_record("EVLR", evlr, length) for _, evlr, length in evlrs]

    point_end = evlr_start if evlr_count else file_size
    payload = point_end - data_offset
    if not compressed:
        if point_count * record_length > payload:
            raise _bad(
                path,
                f"header claims {point_count} points of {record_length} bytes "
                f"({point_count * record_length} bytes), but the file holds {payload} "
                "bytes of point data (truncated?)",
            )
        # Room for more records after the counted ones: a damaged count would make the
        # cloud read silently partial (LAStools' lasinfo warns likewise). The records
        # end at the EVLRs (point_end) or, LAS 1.3-1.4, at the waveform packets stored
        # in the file (the header's uint64 at byte 227) when they start in between.
        counted_end = data_offset + point_count * record_length
        records_end = point_end
        if minor >= 3:
            (waveform_start,) = struct.unpack_from("<Q", head, 227)
            if counted_end <= waveform_start < records_end:
                records_end = waveform_start
        spare_records = (records_end - counted_end) // record_length
    else:
        spare_records = 0
    largest_chunk, first_points_fit = 0, True
    # A count of 0 too, when the data can hold a point: the chunks tell whether the
    # file holds more (an empty file's data is smaller; lazrs's sequential writer
    # gives it one chunk of no point).
    if compressed and (point_count or payload >= 8 + record_length):
        bounds = struct.unpack_from("<6d", head, 179)  # max x, min x, max y, min y, ...
        low, high = zip(*map(sorted, zip(bounds[1::2], bounds[0::2])))  # (sorted: laspy
        box = (scales, offsets, low, high)  # swaps the bounds of a negative scale)
        largest_chunk, spare_records, first_points_fit = _check_laz_payload(
            path,
            stream,
            laszip_vlr,
            data_offset,
            point_end,
            point_count,
            point_format,
            record_length,
            at_file_end=not evlr_count,
            box=box,
        )
    parallel = largest_chunk * record_length <= _PARALLEL_CHUNK_BYTES and first_points_fit
    return LasFacts(point_count, compressed, parallel, spare_records, tuple(records))


def _record(kind: str, header: bytes, length: int) -> LasRecord:
    """The LasRecord of an (E)VLR `header`; its texts as UTF-8, undecodable bytes as
    U+FFFD (the specification asks for ASCII, NUL-padded)."""
    (record_id,) = struct.unpack_from("<H", header, 18)

    def text(raw: bytes) -> str:
        return raw.split(b"\0", 1)[0].decode("utf-8", "replace")

    description = header[22:54] if kind == "VLR" else header[28:60]  # after a u16 or u64 length
    return LasRecord(kind, text(header[2:18]), record_id, text(description), length)


def _check_laz_payload(
    path: str,
    stream: BinaryIO,
    laszip_vlr: bytes | None,
    data_offset: int,
    point_end: int,
    point_count: int,
    point_format: int,
    record_length: int,
    at_file_end: bool,
    box: tuple,
) -> tuple[int, int, bool]:
    """Bound a LAZ file's point count by its chunks; return the largest chunk's points,
    how many points the chunks hold beyond the count, at least (0: none for sure), and
    whether the chunks' first points lie in the header's `box` (scales, offsets, least
    and greatest x, y, z: _first_points_in_box).

    LASzip compresses points in chunks and stores the first point of every chunk
    uncompressed, so a chunk takes at least `record_length` bytes; with a fixed
    chunk size, the points are at most chunks x chunk size. The chunk table's
    offset is the first 8 bytes of the point data, and the table starts with its
    version and chunk count (LASzip's laszip_dll and lazrs read it the same way).
    """
    if laszip_vlr is None or len(laszip_vlr) < 34:
        raise _bad(path, "compressed points but no valid LASzip VLR (user 'laszip encoded')")
    (chunk_size,) = struct.unpack_from("<I", laszip_vlr, 12)
    if chunk_size == 0:
        raise _bad(path, "LASzip VLR gives a chunk size of 0")
    # The VLR's items (type, size, version: 6 bytes each, from byte 34) describe the
    # point record field by field, so their sizes add up to the record length; lazrs
    # divides by that sum and trusts it (LASzip's laszip_dll checks the same).
    (items,) = struct.unpack_from("<H", laszip_vlr, 32)
    if items == 0 or len(laszip_vlr) < 34 + 6 * items:
        raise _bad(
            path,
            f"LASzip VLR lists {items} point items in {len(laszip_vlr)} bytes "
            f"(at least 1, of 6 bytes each after the first 34)",
        )
    item_bytes = sum(struct.unpack_from("<H", laszip_vlr, 36 + 6 * k)[0] for k in range(items))
    if item_bytes != record_length:
        raise _bad(
            path,
            f"LASzip VLR's point items take {item_bytes} bytes, the header's point "
            f"record {record_length}",
        )
    # And their types must be the point format's, in its order: lazrs decodes the items
    # it is given, so a Point10 item listed as bytes, or two items swapped, gave points
    # of garbage without a word.
    types = tuple(struct.unpack_from("<H", laszip_vlr, 34 + 6 * k)[0] for k in range(items))
    expected = _ITEM_TYPES[point_format]
    if record_length > _RECORD_SIZE[point_format]:
        expected += (_BYTE14 if point_format >= 6 else 0,)
    if types != expected:
        raise _bad(
            path,
            f"LASzip VLR's point item types are {list(types)}, point format {point_format} "
            f"with {record_length - _RECORD_SIZE[point_format]} extra bytes has "
            f"{list(expected)}",
        )
    head = _read_at(stream, data_offset, 8)
    if len(head) < 8:
        raise _bad(path, "compressed point data is truncated (no chunk table offset)")
    (table_offset,) = struct.unpack("<q", head)
    where = ""
    if table_offset == -1:
        # A LASzip writer that could not seek back to this place leaves -1 here and
        # puts the table's offset in the file's last 8 bytes, where LASzip and lazrs
        # read it: a hostile value there made lazrs allocate 40 GB for a chunk count
        # read from the middle of the data, and abort the process.
        file_end = stream.seek(0, os.SEEK_END)
        (table_offset,) = struct.unpack("<q", _read_at(stream, file_end - 8, 8))
        where = " (from the file's last 8 bytes, the point data's first 8 being -1)"
    payload = point_end - data_offset - 8
    max_chunks = payload // record_length
    if not data_offset + 8 <= table_offset <= point_end - 8:
        raise _bad(
            path,
            f"LASzip chunk table offset {table_offset}{where} lies outside the point "
            f"data ({data_offset + 8} to {point_end - 8})"
            # Past the end of the file, not of the points before the EVLRs: a cut.
            + (" (truncated?)" if at_file_end and table_offset > point_end - 8 else ""),
        )
    version, chunks = struct.unpack("<II", _read_at(stream, table_offset, 8))
    if version != 0:
        raise _bad(path, f"LASzip chunk table version {version} is not 0")
    if chunks > max_chunks:
        raise _bad(
            path,
            f"LASzip chunk table claims {chunks} chunks, but {payload} bytes of "
            f"compressed data hold at most {max_chunks} chunks of at least one "
            f"{record_length}-byte point",
        )
    if chunk_size != _VARIABLE_CHUNKS and point_count > chunks * chunk_size:
        raise _bad(
            path,
            f"header claims {point_count} points, but {chunks} LASzip chunks of "
            f"{chunk_size} points hold at most {chunks * chunk_size} (truncated?)",
        )
    if point_count * record_length > _LAZ_MAX_RATIO * payload:
        raise _bad(
            path,
            f"header claims {point_count} points of {record_length} bytes, more than "
            f"{_LAZ_MAX_RATIO} times the {payload} bytes of compressed data (truncated?)",
        )
    largest, held, fit = _check_chunk_table(
        path, stream, laszip_vlr, data_offset, table_offset, record_length, box
    )
    return largest, max(0, held - point_count), fit


def _check_chunk_table(
    path: str,
    stream: BinaryIO,
    laszip_vlr: bytes,
    data_offset: int,
    table_offset: int,
    record_length: int,
    box: tuple,
) -> tuple[int, int, bool]:
    """Check the chunks' byte counts against the data; return the largest chunk's points,
    how many points the chunks hold, at least, and whether every chunk's first point
    lies in the header's box (_first_points_in_box).

    lazrs's parallel reader allocates each chunk's stated bytes, and its stated
    points (the chunk size, with fixed chunks), before reading it. Variable chunks
    state their points in the table, and layered chunks (point formats 6-10) in their
    own headers. Fixed pointwise chunks are full but the last, which holds its first
    point raw and the others in at most _POINTWISE_MAX_RATIO x `record_length` bytes
    each: a count that leaves it more bytes than that is too low.
    """
    import lazrs

    stream.seek(data_offset)
    try:
        table = lazrs.read_chunk_table(stream, lazrs.LazVlr(laszip_vlr))
    except Exception as error:  # lazrs.LazrsError: an unknown item or compressor, a cut
        raise _bad(path, f"LASzip VLR or chunk table cannot be read ({error})") from None
    room = table_offset - data_offset - 8
    total = largest = points_in_all = 0
    for index, (points, byte_count) in enumerate(table):
        largest = max(largest, points)
        points_in_all += points
        total += byte_count
        if total > room:
            raise _bad(
                path,
                f"LASzip chunk table: chunk {index} ends {total - room} bytes past the "
                f"{room} bytes of compressed points",
            )
    (compressor,) = struct.unpack_from("<H", laszip_vlr, 0)
    (chunk_size,) = struct.unpack_from("<I", laszip_vlr, 12)
    fit = _first_points_in_box(stream, data_offset + 8, table, box)
    if compressor == _LAYERED_CHUNKED:
        return largest, _check_layers(path, stream, laszip_vlr, data_offset + 8, table), fit
    if chunk_size == _VARIABLE_CHUNKS or not table:
        return largest, points_in_all, fit
    last_bytes = table[-1][1] - record_length  # after the last chunk's raw first point
    in_last = 1 + max(0, last_bytes - 1) // (_POINTWISE_MAX_RATIO * record_length)
    return largest, (len(table) - 1) * chunk_size + min(in_last, chunk_size), fit


def _first_points_in_box(stream: BinaryIO, start: int, table: list, box: tuple) -> bool:
    """Whether the first point of every chunk, stored raw where the table's byte counts
    place the chunk (x, y, z: the record's first 12 bytes), lies near the header's box.
    Only lazrs's parallel reader goes by those counts: counts that move bytes from one
    chunk to the next, their sum unchanged, made it decode garbage without a word; the
    sequential reader, used when this fails, reads such a file right. Misplaced bytes
    land far from any box, while a box a little off (rounded, stale) or all 0 (never
    filled in) is common and harmless: so "near" is within the box's size and 1 m."""
    scales, offsets, low, high = box
    if not any(low) and not any(high):
        return True
    slack = [most - least + 1.0 for least, most in zip(low, high)]
    position = start
    for points, byte_count in table:
        if points and byte_count >= 12:  # (lazrs ends some tables with a chunk of none)
            raw = _read_at(stream, position, 12)
            for stored, scale, offset, least, most, margin in zip(
                struct.unpack("<3i", raw), scales, offsets, low, high, slack
            ):
                if not least - margin <= stored * scale + offset <= most + margin:
                    return False
        position += byte_count
    return True


def _check_layers(
    path: str, stream: BinaryIO, laszip_vlr: bytes, start: int, table: list[tuple[int, int]]
) -> int:
    """LAS 1.4 layered chunks: the layer sizes must fit in their chunk; return the
    points the chunks state.

    A layered chunk holds its first point raw, its point count (u32, that point
    included) and one u32 byte count per layer, then the layers; lazrs allocates each
    layer's stated size before reading it. Point14 items have 9 layers, RGB14 1, RGBNIR14 2,
    wave packets 1 and extra bytes one per byte (LASzip's layered compressor).
    """
    (item_count,) = struct.unpack_from("<H", laszip_vlr, 32)
    if len(laszip_vlr) < 34 + 6 * item_count:
        raise _bad(path, f"LASzip VLR is too short for its {item_count} items")
    raw_size = layers = 0
    for i in range(item_count):
        item_type, item_size, _ = struct.unpack_from("<HHH", laszip_vlr, 34 + 6 * i)
        raw_size += item_size
        layers += item_size if item_type == _BYTE14 else _LAYERS.get(item_type, 0)
    head_size = raw_size + 4 + 4 * layers
    position, stated = start, 0
    for index, (points, byte_count) in enumerate(table):
        if points == 0 and byte_count == 0:
            # A writer that closes a chunk just before it ends the file (lazrs's
            # finish_current_chunk then done, with variable chunks) leaves one of
            # nothing, which lazrs reads as nothing.
            continue
        head = _read_at(stream, position, head_size)
        if byte_count < head_size or len(head) < head_size:
            raise _bad(path, f"LASzip chunk {index} is shorter than its layer header")
        stated += struct.unpack_from("<I", head, raw_size)[0]
        sizes = struct.unpack_from(f"<{layers}I", head, raw_size + 4)
        if sum(sizes) > byte_count - head_size:
            raise _bad(
                path,
                f"LASzip chunk {index}: its layers claim {sum(sizes)} bytes, the chunk "
                f"holds {byte_count - head_size}",
            )
        position += byte_count
    return stated
