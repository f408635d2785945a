"""A LAZ file's LASzip VLR must describe its point record: lazrs divides by the items'
sizes and panics on none (found by `make fuzz FUZZ_SEED=1616`), and a panic from the
decoder is a ValueError naming the file, like every other complaint of a decoder. And
its chunks bound its point count: points beyond the header's count are warned of,
wherever the chunk table's offset is kept."""

from __future__ import annotations

import io
import re
import struct
import warnings

import laspy
import lazrs
import numpy as np
import pytest
from las_helpers import random_las

from pcl_rg.io import read_points


@pytest.mark.parametrize(
    ("version", "point_format"), [("1.2", 1), ("1.2", 3), ("1.4", 6), ("1.4", 8)]
)
def test_valid_laz_files_pass_the_items_check(version, point_format, tmp_path):
    path = tmp_path / "a.laz"
    random_las(version, point_format, 300, seed=point_format).write(path)
    assert len(read_points(path)) == 300


def laszip_record(data: bytes) -> int:
    """Offset of the LASzip VLR's record data in a LAZ file."""
    header_size, _, vlr_count = struct.unpack_from("<HII", data, 94)
    at = header_size
    for _ in range(vlr_count):
        record_id, length = struct.unpack_from("<HH", data, at + 18)
        if data[at + 2 : at + 16].rstrip(b"\0") == b"laszip encoded" and record_id == 22204:
            return at + 54
        at += 54 + length
    raise AssertionError("no LASzip VLR")


@pytest.mark.parametrize(
    ("damage", "message"),
    [
        ("no items", "lists 0 point items"),
        ("short items", "point items take"),
        # Sizes that still add up: lazrs decoded the items it was given, into garbage.
        ("Point10 as bytes", r"item types are \[0, 7\], point format 1 .* has \[6, 7\]"),
        ("items swapped", r"item types are \[7, 6\]"),
    ],
)
def test_a_laszip_vlr_unlike_the_point_record_is_refused(damage, message, tmp_path):
    path = tmp_path / "a.laz"
    random_las("1.2", 1, 300, seed=1, extra=False).write(path)
    data = bytearray(path.read_bytes())
    record = laszip_record(bytes(data))
    if damage == "no items":
        struct.pack_into("<H", data, record + 32, 0)
    elif damage == "Point10 as bytes":
        struct.pack_into("<H", data, record + 34, 0)
    elif damage == "items swapped":
        first, second = data[record + 34 : record + 40], data[record + 40 : record + 46]
        data[record + 34 : record + 46] = second + first
    else:  # the first item 1 byte shorter than the record it describes
        (size,) = struct.unpack_from("<H", data, record + 36)
        struct.pack_into("<H", data, record + 36, size - 1)
    path.write_bytes(bytes(data))
    with pytest.raises(ValueError, match=f"invalid LAS/LAZ file .*a.laz.*{message}"):
        read_points(path)


def test_a_panic_in_the_decoder_is_a_value_error(tmp_path, monkeypatch):
    # pyo3's PanicException derives from BaseException; stand in for one.
    class PanicException(BaseException):
        pass

    def panic(*args, **kwargs):
        raise PanicException("attempt to calculate the remainder with a divisor of zero")

    path = tmp_path / "a.laz"
    random_las("1.2", 1, 300, seed=2, extra=False).write(path)
    monkeypatch.setattr(laspy.LasReader, "read_points", panic)
    with pytest.raises(ValueError, match="invalid LAS/LAZ file .*divisor of zero"):
        read_points(path)


def test_laz_with_whole_chunks_beyond_its_count_warns(tmp_path):
    random_las("1.2", 3, 120_000, seed=1, extra=False).write(tmp_path / "a.laz")
    data = bytearray((tmp_path / "a.laz").read_bytes())
    # LASzip's fixed chunks of 50,000 points: 3 chunks, the last one of 20,000. Whole
    # chunks beyond the count are points for sure, and so is a last chunk's share of
    # its bytes beyond what the count leaves it (at most 4 x 34 bytes a point).
    for count in (120_000, 100_001, 100_000, 30_000):
        data[107:111] = count.to_bytes(4, "little")
        (tmp_path / "b.laz").write_bytes(bytes(data))
        if count == 120_000:
            with warnings.catch_warnings():
                warnings.simplefilter("error")
                assert len(read_points(tmp_path / "b.laz").points) == count
            continue
        with pytest.warns(UserWarning, match="more records") as caught:
            assert len(read_points(tmp_path / "b.laz").points) == count
        at_least = int(re.search(r"holds at least (\d+) more", str(caught[0].message))[1])
        assert max(1, 100_001 - count) <= at_least <= 120_000 - count


def test_a_laz_count_of_0_or_too_low_for_its_chunks_warns(tmp_path):
    # A count of 0 skipped every check of the compressed data, and a count too low
    # for a file of one chunk passed them, so a damaged count read the file short (or
    # empty) without a word. Layered chunks (point formats 6-10) state their points:
    # the count of every point beyond is exact.
    random_las("1.4", 6, 5_000, seed=2, extra=False).write(tmp_path / "a.laz")
    random_las("1.2", 3, 5_000, seed=2, extra=False).write(tmp_path / "p.laz")
    for name, count_at, exact in (("a.laz", 247, True), ("p.laz", 107, False)):
        data = bytearray((tmp_path / name).read_bytes())
        for count in (0, 100):
            width = 8 if count_at == 247 else 4
            data[count_at : count_at + width] = count.to_bytes(width, "little")
            (tmp_path / "b.laz").write_bytes(bytes(data))
            with pytest.warns(UserWarning, match="more records") as caught:
                assert len(read_points(tmp_path / "b.laz").points) == count
            found = re.search(r"holds at least (\d+) more", str(caught[0].message))
            assert int(found[1]) == 5_000 - count if exact else 1 <= int(found[1]) <= 5_000 - count
    # A file of no point: nothing to warn of, whichever lazrs writer made it (the
    # sequential one gives it one chunk of no point, which the checks refused).
    for backend in (laspy.LazBackend.LazrsParallel, laspy.LazBackend.Lazrs):
        for version, point_format in (("1.2", 3), ("1.4", 6)):
            header = laspy.LasHeader(point_format=point_format, version=version)
            laspy.LasData(header).write(tmp_path / "empty.laz", laz_backend=backend)
            with warnings.catch_warnings():
                warnings.simplefilter("error")
                assert len(read_points(tmp_path / "empty.laz").points) == 0


def with_table_offset_at_the_end(data: bytes) -> bytearray:
    """The LAZ file as a LASzip writer that cannot seek back leaves it: -1 where the
    chunk table's offset belongs, and the offset in the file's last 8 bytes."""
    (data_offset,) = struct.unpack_from("<I", data, 96)
    (table_offset,) = struct.unpack_from("<q", data, data_offset)
    moved = bytearray(data) + struct.pack("<q", table_offset)
    struct.pack_into("<q", moved, data_offset, -1)
    return moved


def test_a_table_offset_in_the_last_8_bytes_is_read_and_checked(tmp_path):
    random_las("1.2", 3, 120_000, seed=3, extra=False).write(tmp_path / "a.laz")
    original = read_points(tmp_path / "a.laz").points
    moved = with_table_offset_at_the_end((tmp_path / "a.laz").read_bytes())
    (tmp_path / "b.laz").write_bytes(bytes(moved))
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        assert (read_points(tmp_path / "b.laz").points == original).all()
    # The table's checks hold for it too: a count too low for the chunks warns (the
    # file's chunks went unchecked when the offset was -1).
    moved[107:111] = (30_000).to_bytes(4, "little")
    (tmp_path / "c.laz").write_bytes(bytes(moved))
    with pytest.warns(UserWarning, match="more records"):
        assert len(read_points(tmp_path / "c.laz").points) == 30_000
    # An offset there that points into the compressed points: lazrs read a chunk count
    # from them, asked for 40 GB and aborted the process. Outside the data, or -1 again.
    (table_offset,) = struct.unpack_from("<q", moved, len(moved) - 8)
    for bad in (table_offset - 100, 5, -1, 2**62):
        struct.pack_into("<q", moved, len(moved) - 8, bad)
        (tmp_path / "d.laz").write_bytes(bytes(moved))
        with pytest.raises(ValueError, match="invalid LAS/LAZ file .*(last 8 bytes|chunk table)"):
            read_points(tmp_path / "d.laz")


def write_variable_chunks(path, las, chunk_ends: list[int]) -> None:
    """`las` as LAZ with variable chunks, each closed after the points of `chunk_ends`
    (lazrs's compressor; the last one closed just before the file ends)."""
    point_format, record = las.point_format.id, las.point_format.size
    laszip = lazrs.LazVlr.new_for_compression(point_format, 0, True)  # variable chunks
    header = laspy.LasHeader(point_format=point_format, version=str(las.header.version))
    header.scales, header.offsets = las.header.scales, las.header.offsets
    header.vlrs.append(laspy.VLR("laszip encoded", 22204, "lazrs", laszip.record_data()))
    plain = io.BytesIO()
    with laspy.open(plain, mode="w", header=header, closefd=False) as writer:
        writer.write_points(las.points)
    head = bytearray(plain.getvalue()[: struct.unpack_from("<I", plain.getvalue(), 96)[0]])
    head[104] |= 0x80  # the compressed bit of the point format
    raw, start = las.points.array.tobytes(), 0
    with open(path, "wb") as stream:
        stream.write(head)
        compressor = lazrs.LasZipCompressor(stream, laszip)
        for end in chunk_ends:
            compressor.compress_many(raw[start * record : end * record])
            compressor.finish_current_chunk()
            start = end
        compressor.done()


def test_a_layered_file_whose_variable_chunks_end_in_an_empty_one_reads(tmp_path):
    # lazrs's compressor with variable chunks, told to close a chunk just before the
    # file ends, writes a last chunk of no point and no byte; lazrs reads the file,
    # and the layer check refused it ("chunk 2 is shorter than its layer header").
    las = random_las("1.4", 6, 3000, seed=1, extra=False)
    write_variable_chunks(tmp_path / "a.laz", las, [1000, 3000])
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        read = read_points(tmp_path / "a.laz")
    np.testing.assert_array_equal(read.points, np.c_[las.x, las.y, las.z])


@pytest.mark.parametrize("mark", [0xC0, 0x40])
def test_a_format_byte_with_bit_6_is_refused(tmp_path, mark):
    # Bit 6 made the checks take the file as LAZ, while laspy reads it as uncompressed
    # records: one point came back as garbage, silently.
    random_las("1.2", 3, 1, seed=4, extra=False).write(tmp_path / "a.laz")
    data = bytearray((tmp_path / "a.laz").read_bytes())
    data[104] = mark | (data[104] & 0x3F)
    (tmp_path / "b.laz").write_bytes(bytes(data))
    with pytest.raises(ValueError, match="invalid LAS/LAZ file .*sets bit 6"):
        read_points(tmp_path / "b.laz")


def test_a_chunk_table_that_misplaces_chunks_is_read_chunk_after_chunk(tmp_path):
    # A byte moved from one chunk's count to the next, their sum unchanged: lazrs's
    # parallel reader, which seeks each chunk by the table, decoded 50,000 points of
    # garbage without a word. The chunks' raw first points then lie outside the
    # header's box, and the file is read by the sequential reader, which does not
    # seek by the table.
    random_las("1.2", 3, 120_000, seed=5, extra=False).write(tmp_path / "a.laz")
    original = read_points(tmp_path / "a.laz").points
    data = (tmp_path / "a.laz").read_bytes()
    (data_offset,) = struct.unpack_from("<I", data, 96)
    (table_offset,) = struct.unpack_from("<q", data, data_offset)
    laszip = lazrs.LazVlr(data[laszip_record(data) : laszip_record(data) + 52])
    stream = io.BytesIO(data)
    stream.seek(data_offset)
    table = [list(entry) for entry in lazrs.read_chunk_table(stream, laszip)]
    table[0][1] += 1
    table[1][1] -= 1
    rewritten = io.BytesIO()
    lazrs.write_chunk_table(rewritten, [tuple(entry) for entry in table], laszip)
    (tmp_path / "b.laz").write_bytes(data[:table_offset] + rewritten.getvalue())
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        np.testing.assert_array_equal(read_points(tmp_path / "b.laz").points, original)


def test_points_decoded_past_a_wrong_chunk_size_are_warned_of(tmp_path):
    # A chunk size larger than the writer's: the decoder reads on past the end of the
    # first chunk into garbage (70,000 of 120,000 points here), which only decoding can
    # tell from a header count too low. The garbage lies outside the header's box, and
    # the reader says so.
    random_las("1.2", 3, 120_000, seed=6, extra=False).write(tmp_path / "a.laz")
    data = bytearray((tmp_path / "a.laz").read_bytes())
    struct.pack_into("<I", data, laszip_record(bytes(data)) + 12, 2_200_000)
    (tmp_path / "b.laz").write_bytes(bytes(data))
    with pytest.warns(UserWarning) as caught:
        read_points(tmp_path / "b.laz")
    outside = [str(w.message) for w in caught if "outside the header's box" in str(w.message)]
    assert len(outside) == 1 and re.search(r": \d+ of 120000 points lie outside", outside[0])


def header_facts(path):
    from pcl_rg.io._las_header import check_las_header

    with open(path, "rb") as stream:
        return check_las_header(str(path), stream)


@pytest.mark.parametrize("box", ["rounded to 1 cm", "all 0", "negative x scale"])
def test_a_header_box_a_little_off_or_unset_reads_in_parallel_without_a_word(tmp_path, box):
    # Common, harmless header faults: a box rounded (here inwards, to 1 cm with a 1 mm
    # scale), one never filled in, and laspy's swapped bounds of a negative scale. The
    # first points' check sent such files to the slower sequential reader, and the
    # box's check warned of every point.
    las = random_las("1.2", 3, 120_000, seed=7, extra=False)
    las.points = las.points[np.argsort(las.x)]  # the first chunk starts at the least x
    las.write(tmp_path / "a.laz")
    data = bytearray((tmp_path / "a.laz").read_bytes())
    bounds = np.frombuffer(bytes(data[179:227]), "<f8").copy()  # max x, min x, ...
    if box == "negative x scale":  # x' = offset - X scale = 2 offset - x, as laspy writes it
        (scale,), (offset,) = (
            struct.unpack_from("<d", data, 131),
            struct.unpack_from("<d", data, 155),
        )
        struct.pack_into("<d", data, 131, -scale)
        bounds[0], bounds[1] = 2 * offset - bounds[0], 2 * offset - bounds[1]  # swapped
    elif box == "rounded to 1 cm":
        bounds[0::2], bounds[1::2] = (
            np.floor(bounds[0::2] * 100) / 100,
            np.ceil(bounds[1::2] * 100) / 100,
        )
    elif box == "all 0":
        bounds[:] = 0.0
    data[179:227] = bounds.tobytes()
    (tmp_path / "b.laz").write_bytes(bytes(data))
    assert header_facts(tmp_path / "b.laz").parallel_decompression
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        assert len(read_points(tmp_path / "b.laz").points) == 120_000


def test_a_variable_chunk_table_ending_in_lazrs_empty_chunk_reads_in_parallel(tmp_path):
    # lazrs's compressor, told to close a chunk just before it ends the file, leaves a
    # last chunk of no point in 4 bytes; the first points' check read 12 bytes there,
    # from the chunk table, and sent the file to the sequential reader.
    las = random_las("1.2", 3, 3000, seed=8, extra=False)
    write_variable_chunks(tmp_path / "a.laz", las, [3000])
    assert header_facts(tmp_path / "a.laz").parallel_decompression
    np.testing.assert_array_equal(
        read_points(tmp_path / "a.laz").points, np.c_[las.x, las.y, las.z]
    )
