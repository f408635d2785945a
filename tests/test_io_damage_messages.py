"""Damaged files whose refusal (or warning) used to say little or the wrong thing: the
message must name what is wrong, so that a user knows whether to fix the file or the
call."""

from __future__ import annotations

import struct

import laspy
import numpy as np
import pytest

from pcl_rg.io import read_points, write_points

RNG = np.random.default_rng(20261207)
POINTS = RNG.uniform(0.0, 100.0, (1000, 3))


def _write(path, data: bytes):
    path.write_bytes(data)
    return path


def _bytes_as_written(path, points=POINTS) -> bytes:
    """The bytes of `points` written by write_points to `path` (format by extension)."""
    write_points(path, points)
    return path.read_bytes()


def test_laz_points_that_end_too_soon_are_called_damaged(tmp_path):
    # Zeros over a stretch of the compressed points: lazrs's "IoError: failed to fill
    # whole buffer" alone did not say that the file, not the reader, was at fault.
    source = tmp_path / "whole.laz"
    write_points(source, np.random.default_rng(0).uniform(0.0, 100.0, (200_000, 3)))
    data = bytearray(source.read_bytes())
    start = int(len(data) * 0.3)
    data[start : start + 64] = bytes(64)
    path = _write(tmp_path / "zeroed.laz", bytes(data))
    with pytest.raises(ValueError, match=r"zeroed\.laz.*fill whole buffer.*damaged or cut short"):
        read_points(path)


def _las_with_extra_bytes(tmp_path) -> bytes:
    path = tmp_path / "extra.las"
    fields = {
        "amplitude": RNG.uniform(0.0, 1.0, len(POINTS)).astype(np.float32),
        "tag": RNG.integers(0, 9, len(POINTS)).astype(np.uint16),
    }
    write_points(path, POINTS, fields=fields)
    return path.read_bytes()


def test_a_name_that_is_not_utf8_is_named_as_such(tmp_path):
    data = bytearray(_las_with_extra_bytes(tmp_path))
    name = data.find(b"amplitude\0")
    data[name : name + 3] = b"\xff\xfe\xfd"
    path = _write(tmp_path / "name.las", bytes(data))
    with pytest.raises(ValueError, match=r"name\.las.*extra bytes field's\) is not UTF-8"):
        read_points(path)


def test_a_vlr_user_id_that_is_not_utf8_is_named_as_such(tmp_path):
    data = bytearray(_las_with_extra_bytes(tmp_path))
    data[data.find(b"LASF_Spec")] = 0xFF
    path = _write(tmp_path / "user_id.las", bytes(data))
    with pytest.raises(ValueError, match=r"user_id\.las.*a VLR's user id.* is not UTF-8"):
        read_points(path)


@pytest.mark.parametrize("shorter_by", [1, 100, 292])
def test_an_extra_bytes_vlr_laspy_cannot_parse_is_warned_of(tmp_path, shorter_by):
    # The record's length cut (the data stay): laspy keeps it as raw bytes and gives
    # the points' extra bytes as one unnamed field. The coordinates are right, so the
    # file is read, with a warning instead of the fields' silent loss.
    data = bytearray(_las_with_extra_bytes(tmp_path))
    header = data.find(b"LASF_Spec")  # the VLR header: user id, record id, length
    assert struct.unpack_from("<H", data, header + 16)[0] == 4  # the Extra Bytes VLR
    (length,) = struct.unpack_from("<H", data, header + 18)
    struct.pack_into("<H", data, header + 18, length - shorter_by)
    path = _write(tmp_path / "cut.las", bytes(data))
    with pytest.warns(UserWarning, match=r"cut\.las.*Extra Bytes VLR .* not a whole number"):
        cloud = read_points(path)
    np.testing.assert_allclose(cloud.points, POINTS, atol=0.0006)
    assert "amplitude" not in cloud.fields and cloud.fields["ExtraBytes"].shape == (1000, 6)


def test_an_unparsable_extra_bytes_vlr_of_points_without_extra_bytes_is_ignored(tmp_path):
    header = laspy.LasHeader(version="1.4", point_format=6)
    header.vlrs.append(laspy.VLR("LASF_Spec", 4, "", bytes(100)))
    las = laspy.LasData(header)
    las.x, las.y, las.z = POINTS.T
    path = tmp_path / "odd.las"
    las.write(path)
    with pytest.warns(UserWarning, match=r"odd\.las.*Extra Bytes VLR \(100 bytes\).*ignored"):
        cloud = read_points(path)
    assert "ExtraBytes" not in cloud.fields


def test_a_well_formed_extra_bytes_vlr_gives_no_warning(tmp_path, recwarn):
    path = _write(tmp_path / "fine.las", _las_with_extra_bytes(tmp_path))
    assert read_points(path).fields["tag"].dtype == np.uint16
    assert not [w for w in recwarn if "Extra Bytes" in str(w.message)]
    assert laspy.read(path).header.point_format.extra_dimension_names


@pytest.mark.parametrize("points", [POINTS, POINTS[:10]], ids=["1000 points", "10 points"])
@pytest.mark.parametrize("comment", [b"", b"# written by another tool\n"])
def test_a_pcd_header_without_its_data_line_says_so(tmp_path, points, comment):
    # The header ran into the binary data: the file was called "binary data of an
    # unknown format", which sent the user to the file's extension. Ten points' data
    # may hold no line feed at all, and a comment may come first.
    lines = _bytes_as_written(tmp_path / "whole.pcd", points).split(b"\n")
    data = comment + b"\n".join(x for x in lines if x[:4] != b"DATA")
    path = _write(tmp_path / "no_data.pcd", data)
    with pytest.raises(ValueError, match=r"no_data\.pcd.*no DATA line before .*point data"):
        read_points(path)


def test_a_pcd_header_cut_inside_its_data_keyword_is_called_truncated(tmp_path):
    data = _bytes_as_written(tmp_path / "whole.pcd")
    path = _write(tmp_path / "cut.pcd", data[: data.index(b"DATA") + 3])
    with pytest.raises(ValueError, match=r"cut\.pcd.*header is truncated"):
        read_points(path)


def test_a_ply_header_of_cr_line_ends_says_so(tmp_path):
    data = _bytes_as_written(tmp_path / "whole.ply")
    end = data.index(b"end_header\n") + len(b"end_header\n")
    path = _write(tmp_path / "cr.ply", data[:end].replace(b"\n", b"\r") + data[end:])
    with pytest.raises(ValueError, match=r"cr\.ply.*lines end in CR alone"):
        read_points(path)
