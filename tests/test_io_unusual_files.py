"""Files that are unusual but legal, or damaged in ways a header does not show: list
counts stored as floats, LAS extra bytes with a scale of 0, LAS 1.0, PCD and XYZ
headers of long or non-ASCII comments, and an existing output that is not a file."""

from __future__ import annotations

import io
import os

import laspy
import numpy as np
import pytest

from pcl_rg.io import read_points, write_pcd, write_points

POINTS = np.array([[1.0, 2.0, 3.0], [4.0, 5.0, 6.0], [7.0, 8.0, 9.5]])


@pytest.mark.parametrize("count", [np.inf, np.nan, 2.5, 3.0])
def test_a_ply_list_count_stored_as_a_float_must_be_whole(tmp_path, count):
    # int(inf) raised OverflowError (the command line's "internal error"), NaN a
    # ValueError that did not name the file. A float count type is legal: 3.0 reads.
    header = (
        b"ply\nformat binary_little_endian 1.0\nelement vertex 2\nproperty float x\n"
        b"property float y\nproperty float z\nelement face 1\n"
        b"property list float int vertex_indices\nend_header\n"
    )
    body = np.arange(6, dtype="<f4").tobytes() + np.array([count], "<f4").tobytes()
    path = tmp_path / "f.ply"
    path.write_bytes(header + body + bytes(12))
    if count == 3.0:
        assert read_points(path).points.tolist() == [[0.0, 1.0, 2.0], [3.0, 4.0, 5.0]]
        return
    with pytest.raises(ValueError, match=r"invalid PLY file .*f\.ply.*list length .* not a whole"):
        read_points(path)


def _las_with_extra_bytes(options: int, scale: float) -> bytes:
    """A LAS file of a float64 extra-bytes dimension 'depth' whose options byte and
    first scale are set by hand, as another program may write them."""
    header = laspy.LasHeader(version="1.4", point_format=6)
    header.add_extra_dims([laspy.ExtraBytesParams("depth", "f8")])
    las = laspy.LasData(header)
    las.x, las.y, las.z = POINTS.T
    las.depth = np.array([0.5, 1.0, 1.5])
    stream = io.BytesIO()
    las.write(stream)
    data = bytearray(stream.getvalue())
    name = data.find(b"depth\0")
    data[name - 1] = options  # the byte before the name (LAS 1.4, table 24)
    scale_at = name + 32 + 4 + 3 * 8 + 3 * 8 + 3 * 8  # name, unused, no data, min, max
    data[scale_at : scale_at + 8] = np.float64(scale).tobytes()
    return bytes(data)


@pytest.mark.parametrize("scale", [0.0, np.inf, np.nan])
def test_las_extra_bytes_with_a_scale_that_cannot_be_read_back_are_refused(tmp_path, scale):
    # With scale 0 every value read as 0.0, and a write in the file's layout divided by
    # that scale: the values came back as NaN, with a NumPy warning as the only sign.
    path = tmp_path / "scaled.las"
    path.write_bytes(_las_with_extra_bytes(0x08, scale))
    with pytest.raises(ValueError, match=r"extra bytes dimension 'depth' has scale"):
        read_points(path)


@pytest.mark.parametrize("options, scale", [(0x08, 2.0), (0x18, 1.0), (0x08, 0.1)])
def test_scaled_float_extra_bytes_are_written_back_unrounded(tmp_path, options, scale):
    # laspy rounds the stored value of a scaled dimension to a whole number: a float64
    # one flagged with scale 1 came back as 0, 1, 2 instead of 0.5, 1, 1.5.
    path = tmp_path / "scaled.las"
    path.write_bytes(_las_with_extra_bytes(options, scale))
    cloud = read_points(path)
    assert np.allclose(cloud.fields["depth"], np.array([0.5, 1.0, 1.5]) * scale)
    write_points(tmp_path / "copy.las", cloud.points, cloud.fields, template=cloud)
    stored = [laspy.read(p).points.array["depth"] for p in (path, tmp_path / "copy.las")]
    # (value - offset) / scale of value = stored * scale + offset: exact when the scale
    # is a power of 2, within rounding otherwise.
    assert np.allclose(stored[1], stored[0], rtol=1e-15, atol=0)


@pytest.mark.parametrize("ext", ["las", "laz"])
def test_a_las_10_file_is_written_back_as_12(tmp_path, ext):
    # laspy reads LAS 1.0 but writes no 1.0: every output in its layout failed after
    # the work ("cannot write ... in the layout of ...: 1.0").
    header = laspy.LasHeader(version="1.2", point_format=1)
    las = laspy.LasData(header)
    las.x, las.y, las.z = POINTS.T
    las.intensity = np.array([10, 20, 30], np.uint16)
    stream = io.BytesIO()
    las.write(stream)
    data = bytearray(stream.getvalue())
    data[25] = 0  # version minor
    (tmp_path / "old.las").write_bytes(bytes(data))
    cloud = read_points(tmp_path / "old.las")
    assert str(cloud.header.version) == "1.0"
    write_points(tmp_path / f"new.{ext}", cloud.points, cloud.fields, template=cloud)
    again = read_points(tmp_path / f"new.{ext}")
    assert str(again.header.version) == "1.2"
    assert again.header.point_format.id == 1
    assert np.array_equal(again.points, cloud.points)
    assert again.fields["intensity"].tolist() == [10, 20, 30]


def test_a_pcd_header_after_more_than_4_kib_of_comments_is_read(tmp_path):
    # The format check read 4,096 bytes of comments, no PCD keyword among them, and
    # took the file for text; read_pcd, which allows a 1 MiB header, read it.
    write_pcd(tmp_path / "plain.pcd", POINTS, encoding="ascii")
    comments = b"".join(b"# survey note %d: nothing of interest\n" % i for i in range(200))
    (tmp_path / "noted.pcd").write_bytes(comments + (tmp_path / "plain.pcd").read_bytes())
    assert np.array_equal(read_points(tmp_path / "noted.pcd").points, POINTS)
    # Comments alone are no PLY or LAS file.
    (tmp_path / "noted.ply").write_bytes(comments)
    with pytest.raises(ValueError, match="not a PLY file.*comment lines of a text file"):
        read_points(tmp_path / "noted.ply")


@pytest.mark.parametrize("bom", [b"", b"\xef\xbb\xbf"])
def test_xyz_text_in_utf8_with_or_without_a_byte_order_mark(tmp_path, bom):
    # A byte order mark (Windows editors) or a non-ASCII comment made the file
    # "binary data of an unknown format".
    text = "# Höhe über NN, Messung 3\n# x y z intensity\n1 2 3 7\n4 5 6 8\n"
    (tmp_path / "utf8.xyz").write_bytes(bom + text.encode("utf-8"))
    cloud = read_points(tmp_path / "utf8.xyz")
    assert cloud.points.tolist() == [[1.0, 2.0, 3.0], [4.0, 5.0, 6.0]]
    assert cloud.fields["intensity"].tolist() == [7, 8]


def test_xyz_text_that_is_not_utf8_is_refused(tmp_path):
    # Past the first 4 KiB, which the format check reads: the reader's own message.
    rows = "1 2 3\n" * 1000
    (tmp_path / "latin1.xyz").write_bytes((rows + "# H\xf6he\n4 5 6\n").encode("latin-1"))
    with pytest.raises(ValueError, match="not UTF-8 text at byte 6003"):
        read_points(tmp_path / "latin1.xyz")


@pytest.mark.parametrize("separator", ["\u0085", "\u2028"])
def test_a_unicode_line_separator_inside_a_comment_adds_no_point(tmp_path, separator):
    # str.splitlines broke the comment there: "9 9 9" became a point; in the first
    # 4 KiB the file was taken for binary data.
    text = f"# note{separator} 9 9 9\n1 2 3\n4 5 6\n"
    (tmp_path / "sep.xyz").write_bytes(text.encode("utf-8"))
    assert read_points(tmp_path / "sep.xyz").points.tolist() == [[1, 2, 3], [4, 5, 6]]


def test_non_ascii_column_names_are_not_taken(tmp_path):
    # "Höhe" became a field that no writer can write back: it failed after the work.
    (tmp_path / "h.xyz").write_bytes("# x y z Höhe\n1 2 3 4\n5 6 7 8\n".encode())
    assert list(read_points(tmp_path / "h.xyz").fields) == ["column_4"]


@pytest.mark.parametrize("cut", [1, 3, 6, 7])
@pytest.mark.parametrize("encoding", ["ascii", "binary"])
def test_pcd_keywords_at_the_end_of_the_first_4_kib(tmp_path, cut, encoding):
    # A keyword line cut by the format check's 4,096 bytes ("VER") was taken for data;
    # a UTF-8 comment in a binary file's header for binary data.
    write_pcd(tmp_path / "plain.pcd", POINTS, encoding=encoding)
    body = (tmp_path / "plain.pcd").read_bytes()
    start = body.index(b"VERSION")
    notes = "# Höhe über NN\n".encode()
    filler = b"#" + b"x" * (4096 - cut - len(notes) - 2) + b"\n"
    (tmp_path / "cut.pcd").write_bytes(notes + filler + body[start:])
    assert np.array_equal(read_points(tmp_path / "cut.pcd").points, POINTS)


@pytest.mark.parametrize("ext", ["xyz", "las", "pcd"])
def test_an_existing_fifo_is_not_replaced_by_the_output(tmp_path, ext):
    # The atomic rename replaced it by a regular file; so would a device node be, for
    # a root user writing to a link to /dev/null.
    path = tmp_path / f"pipe.{ext}"
    os.mkfifo(path)
    with pytest.raises(FileExistsError, match="not a regular file"):
        write_points(path, POINTS)
    assert not path.is_file() and path.exists()
    assert os.listdir(tmp_path) == [path.name]  # no temporary file left


def test_an_ascii_ply_list_counted_by_floats(tmp_path):
    # A float count type is legal: "3.0 0 1 2" is one face, read past like any other.
    (tmp_path / "f.ply").write_bytes(
        b"ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\n"
        b"property float z\nelement face 1\nproperty list float int vertex_indices\n"
        b"end_header\n0 0 0\n1 0 0\n0 1 0\n3.0 0 1 2\n"
    )
    assert len(read_points(tmp_path / "f.ply")) == 3


def test_wide_xyz_rows_of_whole_numbers_are_read_in_one_scan(tmp_path):
    # 3 + 20,000 columns of whole numbers: each column looked for an integer in every
    # row, splitting the whole row again each time, so ten such rows took minutes
    # (quadratic in the width). One column written as an integer in the last row only
    # must still come back int64, and the others float64, as before.
    rows = [" ".join(["1."] * 20_003) for _ in range(10)]  # 60 kB, within the line limit
    rows[-1] = rows[-1][: -len("1.")] + "7"
    (tmp_path / "wide.xyz").write_text("\n".join(rows) + "\n")
    fields = read_points(tmp_path / "wide.xyz").fields
    assert len(fields) == 20_000 and fields["column_20003"].dtype == np.int64
    assert fields["column_20003"].tolist() == [1] * 9 + [7]
    assert all(fields[f"column_{i}"].dtype == np.float64 for i in range(4, 20_003))


@pytest.mark.parametrize("name", ["x", "y", "synthetic", "return_number", "pt_src_id"])
def test_an_extra_bytes_field_named_as_a_standard_one_is_refused(tmp_path, name):
    # laspy reads such a name as the standard field (the coordinate, a flag packed in a
    # byte, an old alias): the file's own values, 42 and 43, came back as x's 1 and 2.
    # laspy writes no such file, so the name is put in the Extra Bytes record after.
    header = laspy.LasHeader(point_format=3, version="1.2")
    header.add_extra_dims([laspy.ExtraBytesParams(name="placeholder_name", type=np.float32)])
    las = laspy.LasData(header)
    las.x, las.y, las.z = [1.0, 2.0], [3.0, 4.0], [5.0, 6.0]
    las["placeholder_name"] = [42.0, 43.0]
    buffer = io.BytesIO()
    las.write(buffer)
    data = bytearray(buffer.getvalue())
    at = data.index(b"placeholder_name")
    data[at : at + 32] = name.encode().ljust(32, b"\0")
    (tmp_path / "a.las").write_bytes(bytes(data))
    with pytest.raises(ValueError, match=f"extra bytes dimension '{name}' has the name of a"):
        read_points(tmp_path / "a.las")
    if name == "pt_src_id":  # nor can write_points write such a field
        with pytest.raises(ValueError, match="laspy reads this name as another"):
            write_points(tmp_path / "b.las", np.zeros((2, 3)), fields={name: np.ones(2)})


def test_an_unknown_extra_bytes_type_is_named(tmp_path):
    # laspy's complaint was the bare type number: "invalid LAS/LAZ file '…': 31".
    header = laspy.LasHeader(point_format=3, version="1.2")
    header.add_extra_dims([laspy.ExtraBytesParams(name="placeholder_name", type=np.float32)])
    las = laspy.LasData(header)
    las.x, las.y, las.z = [1.0, 2.0], [3.0, 4.0], [5.0, 6.0]
    buffer = io.BytesIO()
    las.write(buffer)
    data = bytearray(buffer.getvalue())
    data[data.index(b"placeholder_name") - 2] = 31  # the record's data_type
    (tmp_path / "a.las").write_bytes(bytes(data))
    with pytest.raises(ValueError, match=r"UnknownExtraType 31 \(a value the LAS format does not"):
        read_points(tmp_path / "a.las")
