"""A LAZ file's LASzip VLR must describe its point record: lazrs divides by the items'
sizes and panics on none (found by `make fuzz FUZZ_SEED=1616`), and a panic from the
decoder is a ValueError naming the file, like every other complaint of a decoder."""

from __future__ import annotations

import struct

import laspy
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
    [("no items", "lists 0 point items"), ("short items", "point items take")],
)
def test_a_laszip_vlr_unlike_the_point_record_is_refused(damage, message, tmp_path):
    path = tmp_path / "a.laz"
    random_las("1.2", 1, 300, seed=1, extra=False).write(path)
    data = bytearray(path.read_bytes())
    record = laszip_record(bytes(data))
    if damage == "no items":
        struct.pack_into("<H", data, record + 32, 0)
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
