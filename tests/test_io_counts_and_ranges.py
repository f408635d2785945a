"""Element counts against the data (PLY), column types by their text (XYZ), and
coordinates beyond what a format can store (LAS scale and offset, float32 templates)."""

from __future__ import annotations

import os

import numpy as np
import pytest

from pcl_rg.io import PlyLayout, PointFile, read_points, write_points

POINTS = np.array([[1.0, 2.0, 3.0], [4.0, 5.0, 6.0]])


def _ply_with_faces(encoding: str, vertex_count: int, vertices, faces_head: str, body: bytes):
    """A PLY header of float x, y, z vertices then `faces_head`, the vertex data, `body`."""
    head = (
        f"ply\nformat {encoding} 1.0\nelement vertex {vertex_count}\nproperty float x\n"
        f"property float y\nproperty float z\n{faces_head}end_header\n"
    ).encode()
    if encoding == "ascii":
        return head + b"".join(b"%g %g %g\n" % tuple(v) for v in vertices) + body
    return head + np.asarray(vertices, "<f4").tobytes() + body


FACE = "element face {}\nproperty list uchar int vertex_indices\n"
TRIANGLE = b"\x03" + np.array([0, 1, 2], "<i4").tobytes()
THREE = [[1, 2, 3], [4, 5, 6], [7, 8, 9]]


@pytest.mark.parametrize(
    ("encoding", "faces_head", "body", "message"),
    [
        ("ascii", FACE.format(0), b"", "more data rows than the 2 .*2 vertex, 0 face"),
        ("ascii", FACE.format(1), b"3 0 1 2\n", "more data rows than the 3 .*2 vertex, 1 face"),
        ("ascii", "element extra 1\nproperty float a\n", b"0.5\n", "more data rows"),
        ("binary_little_endian", FACE.format(0), b"", "12 bytes after .*2 vertex, 0 face"),
        ("binary_little_endian", "element extra 1\nproperty float a\n", bytes(4), "bytes after"),
        # The third vertex read as two empty faces (its first byte is 0), then 36 bytes.
        ("binary_little_endian", FACE.format(2), TRIANGLE * 2, "36 bytes after .*2 face"),
    ],
)
def test_ply_surplus_vertices_before_another_element(tmp_path, encoding, faces_head, body, message):
    # Three vertices in the data, two in the header, another element after them: the
    # third vertex was taken for the next element's data and never noticed.
    path = tmp_path / "s.ply"
    path.write_bytes(_ply_with_faces(encoding, 2, THREE, faces_head, body))
    with pytest.raises(ValueError, match=f"invalid PLY file .*s.ply.*{message}"):
        read_points(path)
    # The same with the right vertex count is read.
    path.write_bytes(_ply_with_faces(encoding, 3, THREE, faces_head, body))
    np.testing.assert_array_equal(read_points(path).points, THREE)


@pytest.mark.parametrize(
    ("faces_head", "message"),
    [
        (FACE.format(1), "data row 3 is not one 'face' entry"),
        ("element extra 1\nproperty int a\n", "data row 3 is not one 'extra' entry"),
    ],
)
def test_ply_ascii_surplus_vertex_in_place_of_the_next_row(tmp_path, faces_head, message):
    # The next element's row is missing and a surplus vertex row takes its place: the
    # sum of rows is right, but that row is no entry of the next element.
    path = tmp_path / "s.ply"
    path.write_bytes(_ply_with_faces("ascii", 2, THREE, faces_head, b""))
    with pytest.raises(ValueError, match=message):
        read_points(path)


@pytest.mark.parametrize(
    ("faces_head", "body"),
    [
        (FACE.format(2), TRIANGLE * 2 + b"\0\0\n"),  # padding at the end
        # Entries of different lengths: where the faces end is not looked for.
        (FACE.format(2), TRIANGLE + b"\x01" + bytes(4)),
        (
            "element face 2\nproperty uchar flag\nproperty list ushort short ids\n"
            "element extra 1\nproperty double a\n",
            (b"\x07\x02\x00" + bytes(4)) * 2 + bytes(8),
        ),
    ],
)
def test_ply_binary_elements_after_the_vertices(tmp_path, faces_head, body):
    path = tmp_path / "m.ply"
    path.write_bytes(_ply_with_faces("binary_little_endian", 3, THREE, faces_head, body))
    np.testing.assert_array_equal(read_points(path).points, THREE)


@pytest.mark.parametrize(
    ("faces_head", "body", "message"),
    [
        (FACE.format(2), TRIANGLE, "2 'face' entries need at least 14 bytes from byte 36"),
        (FACE.format(1), b"\x05" + bytes(8), "1 'face' entries need at least 21 bytes"),
        (
            "element face 1\nproperty list uchar int a\nproperty list uchar int b\n",
            b"\x05" + bytes(20),
            "first 'face' entry runs past the 57 bytes",
        ),
        (
            "element face 1\nproperty list char int vertex_indices\n",
            b"\xff",
            "negative list length -1",
        ),
        (
            "element face 2\nproperty list uchar int vertex_indices\nelement extra 1\n"
            "property double a\n",
            TRIANGLE * 2,
            "need 70 .*truncated",
        ),
    ],
)
def test_ply_binary_elements_after_the_vertices_cut_short(tmp_path, faces_head, body, message):
    path = tmp_path / "t.ply"
    path.write_bytes(_ply_with_faces("binary_little_endian", 3, THREE, faces_head, body))
    with pytest.raises(ValueError, match=message):
        read_points(path)


def test_ply_ascii_rows_of_every_element_counted(tmp_path):
    # Faces of different lengths after the vertices, and before them an element whose
    # rows are checked at its first and last row.
    path = tmp_path / "a.ply"
    head = (
        "ply\nformat ascii 1.0\nelement camera 2\nproperty float f\nproperty uchar k\n"
        "element vertex 3\nproperty float x\nproperty float y\nproperty float z\n"
        + FACE.format(2)
        + "end_header\n"
    )
    vertices = b"1 2 3\n4 5 6\n7 8 9\n"
    path.write_bytes(head.encode() + b"0.5 1\n1.5 2\n" + vertices + b"3 0 1 2\n4 0 1 2 0\n\n")
    np.testing.assert_array_equal(read_points(path).points, THREE)
    path.write_bytes(head.encode() + b"0.5 1\n1.5 2\n" + vertices + b"3 0 1 2\n")
    with pytest.raises(ValueError, match=r"count 7 data rows, the data hold 6 \(truncated\?\)"):
        read_points(path)
    # A camera row short and a vertex row more: a vertex row is read as a camera row.
    path.write_bytes(head.encode() + b"0.5 1\n" + vertices + b"0 0 0\n3 0 1 2\n4 0 1 2 0\n")
    with pytest.raises(ValueError, match="data row 2 is not one 'camera' entry"):
        read_points(path)


def test_xyz_float64_fields_come_back_as_written(tmp_path):
    # Whole doubles beyond 2**53 were read as the integer their shortest text spells
    # (1.2345678901234568e+17 as ...680, the double is ...664), and every whole
    # double came back int64 (-0.0 as 0).
    rng = np.random.default_rng(5)
    wide = np.round(rng.uniform(-1, 1, 60) * 10.0 ** rng.integers(0, 300, 60))
    wide[:2] = [1e308, -(2.0**64)]
    fields = {
        "big": np.array([1.2345678901234567e17, 2.0**60 + 2**9, 2.0**53, -(2.0**63)] * 15),
        "small": np.array([1.0, -0.0, 3.0, -7.0] * 15),
        "wide": wide,
        "tiny": np.array([5e-324, -2.2250738585072014e-308, 0.1, 1e-300] * 15),
    }
    path = tmp_path / "f.xyz"
    write_points(path, np.zeros((60, 3)), fields)
    cloud = read_points(path)
    for key, values in fields.items():
        assert cloud.fields[key].dtype == np.float64
        np.testing.assert_array_equal(cloud.fields[key].view(np.int64), values.view(np.int64))


def test_xyz_uint64_fields_come_back_as_written(tmp_path):
    # uint64 values from 2**63 on came back as float64 (rounded).
    values = np.array([2**64 - 1, 2**63 + 1, 2**63, 5], np.uint64)
    signed = np.array([-(2**63), 2**63 - 1, 0, -7], np.int64)
    path = tmp_path / "u.xyz"
    write_points(path, np.zeros((4, 3)), {"id": values, "signed": signed, "small": values % 9})
    cloud = read_points(path)
    assert cloud.fields["id"].dtype == np.uint64
    assert cloud.fields["id"].tolist() == values.tolist()
    assert cloud.fields["signed"].dtype == np.int64
    assert cloud.fields["signed"].tolist() == signed.tolist()
    assert cloud.fields["small"].dtype == np.int64  # as uint8 does: the text has no type


@pytest.mark.parametrize(
    ("tokens", "dtype", "expected"),
    [
        (["1.0", "2.0"], np.float64, [1.0, 2.0]),  # floats as the text writes them
        (["1", "2.0", "3e0"], np.int64, [1, 2, 3]),  # one integer: whole numbers
        (["18446744073709551615", "1e3"], np.uint64, [2**64 - 1, 1000]),
        (["18446744073709551615", "-1"], np.float64, [2.0**64, -1.0]),  # beyond both
    ],
)
def test_xyz_columns_by_their_text(tmp_path, tokens, dtype, expected):
    path = tmp_path / "t.xyz"
    path.write_text("".join(f"0 0 0 {token}\n" for token in tokens))
    column = read_points(path).fields["column_4"]
    assert column.dtype == dtype and column.tolist() == expected


@pytest.mark.parametrize("ext", ["las", "laz"])
@pytest.mark.parametrize(
    ("points", "message"),
    [
        ([[-1e308, 0, 0], [1e308, 0, 0]], r"x coordinates from -1e\+308 to 1e\+308 .*scale inf"),
        (
            [[0, 0, 0], [1, 1.7e308, 2]],
            r"y coordinates from 0.0 to 1.7e\+308 .*scale 1[.0-9]*e\+299",
        ),
        ([[0, 0, -2e307], [1, 1, 2e307]], r"z coordinates from -2e\+307 to 2e\+307"),
    ],
)
def test_las_coordinates_beyond_scale_and_offset_are_refused(tmp_path, ext, points, message):
    # The header got an infinite scale (or one whose int32 range overflows float64):
    # a file was written that the reader then refused.
    path = tmp_path / f"far.{ext}"
    with pytest.raises(ValueError, match=message + r".*within \+-1e307 always fit"):
        write_points(path, np.array(points))
    assert os.listdir(tmp_path) == []  # no file, no temporary file
    # Within +-1e307 the extent fits (scale 1e298 at most) and reads back.
    near = np.array([[-1e307, 0, 5e306], [1e307, 1, -1e307]])
    write_points(path, near)
    np.testing.assert_allclose(read_points(path).points, near, rtol=1e-9)


def test_las_template_scale_and_offset_checked(tmp_path):
    path = tmp_path / "t.las"
    write_points(path, np.array([[-1e307, 0, 0], [1e307, 1, 1]]))
    template = read_points(path)
    # Beyond int32 with the template's scale: subtracting its offset overflowed with a
    # RuntimeWarning before the refusal.
    with pytest.raises(ValueError, match="do not fit LAS int32 storage"):
        write_points(tmp_path / "u.las", np.array([[1.75e308, 0, 0]]), template=template)
    template.header.scales = [0.0, 0.001, 0.001]  # a header the reader would refuse
    with pytest.raises(ValueError, match="x coordinates from 1.0 to 1.0 .* scale 0.0 and"):
        write_points(tmp_path / "u.las", np.array([[1.0, 0, 0]]), template=template)
    assert sorted(os.listdir(tmp_path)) == ["t.las"]


@pytest.mark.parametrize("encoding", ["ascii", "binary_little_endian", "binary_big_endian"])
def test_ply_template_float32_refuses_coordinates_beyond_float32(tmp_path, encoding):
    # They were written as inf without a word. PCD refuses them too; without a
    # template PLY and PCD write float64 and keep +-1.8e308.
    template = PointFile(POINTS, {}, "ply", PlyLayout(encoding, np.dtype("f4"), ()))
    path = tmp_path / "f.ply"
    far = np.array([[1.0, 2.0, 3.0], [4.0, -1e39, 6.0]])
    with pytest.raises(ValueError, match=r"points\[1, 1\] = -1e\+39 is beyond the float32"):
        write_points(path, far, template=template)
    assert os.listdir(tmp_path) == []
    # A value that rounds down to the float32 maximum, inf and nan are written.
    edge = np.array([[3.40282356e38, np.inf, np.nan]])
    write_points(path, edge, template=template)
    back = read_points(path).points
    assert back[0, 0] == np.finfo(np.float32).max and back[0, 1] == np.inf
    assert np.isnan(back[0, 2])
    for ext in ("ply", "pcd"):
        huge = np.array([[-1.7976931348623157e308, 1e308, 5e-324]])
        write_points(tmp_path / f"h.{ext}", huge)
        np.testing.assert_array_equal(read_points(tmp_path / f"h.{ext}").points, huge)


@pytest.mark.parametrize("ext", ["las", "laz"])
def test_las14_point_counts_that_disagree_are_refused(tmp_path, ext):
    # LAS 1.4 with the 64-bit count 0 and the legacy count 3000: the LAZ read 0 points
    # and pcl-rg wrote an empty output with exit 0 (LAS/LAZ hunt).
    import struct

    import laspy

    las = laspy.create(point_format=1, file_version="1.4")
    las.x, las.y, las.z = np.arange(3000) % 60, np.arange(3000) // 60, np.zeros(3000)
    las.write(tmp_path / f"ok.{ext}")
    assert len(read_points(tmp_path / f"ok.{ext}")) == 3000
    raw = bytearray((tmp_path / f"ok.{ext}").read_bytes())
    assert struct.unpack_from("<I", raw, 107)[0] in (0, 3000)
    struct.pack_into("<I", raw, 107, 3000)  # the legacy count, as LAStools writes it
    (tmp_path / f"legacy.{ext}").write_bytes(raw)
    assert len(read_points(tmp_path / f"legacy.{ext}")) == 3000
    struct.pack_into("<Q", raw, 247, 0)  # the LAS 1.4 count
    (tmp_path / f"bad.{ext}").write_bytes(raw)
    with pytest.raises(ValueError, match="point counts disagree: 0 .LAS 1.4. against 3000"):
        read_points(tmp_path / f"bad.{ext}")
