"""Files and names at the edges of what the formats hold: header lines that are all
comments, the word end_header inside a PLY header, values beyond float32 in ascii
data, field names a format cannot write back, long output names, LAZ wave packets,
and Ctrl-C while lazrs writes."""

from __future__ import annotations

import os
import signal

import laspy
import numpy as np
import pytest

from pcl_rg.io import read_points, write_pcd, write_points
from pcl_rg.io._columns import split_columns
from pcl_rg.io._las import _RecordingStream

POINTS = np.array([[1.0, 2.0, 3.0], [4.0, 5.0, 6.0]])


def test_pcd_errors_name_the_line_after_comment_lines(tmp_path):
    # Line numbers are counted as the parser goes (recounting them from the start of
    # the file made a header of many comment lines quadratic).
    path = tmp_path / "c.pcd"
    path.write_bytes(b"# .PCD v0.7\n" + b"#\n" * 5000 + b"\nVERSION 0.7\nFIELDS x y z\nBOGUS 1\n")
    with pytest.raises(ValueError, match="unknown header keyword 'BOGUS' on line 5005"):
        read_points(path)
    path.write_bytes(
        b"# .PCD v0.7\n" + b"# a comment\n" * 20000 + b"VERSION 0.7\nFIELDS x y z\n"
        b"SIZE 4 4 4\nTYPE F F F\nCOUNT 1 1 1\nWIDTH 1\nHEIGHT 1\nPOINTS 1\nDATA ascii\n1 2 3\n"
    )
    np.testing.assert_array_equal(read_points(path).points, [[1.0, 2.0, 3.0]])


@pytest.mark.parametrize("name", ["end_header", "my_end_header", "end_header_2"])
def test_ply_field_named_like_the_end_of_the_header(tmp_path, name):
    values = np.array([7, 9], np.uint8)
    for encoding in ("binary_little_endian", "ascii"):
        path = tmp_path / f"{encoding}.ply"
        write_points(path, POINTS, {name: values})
        if encoding == "ascii":  # rewrite as ascii by hand: the writer's default is binary
            head, _ = path.read_bytes().split(b"\nend_header\n", 1)
            head = head.replace(b"binary_little_endian", b"ascii")
            path.write_bytes(head + b"\nend_header\n1 2 3 7\n4 5 6 9\n")
        cloud = read_points(path)
        np.testing.assert_array_equal(cloud.points, POINTS)
        np.testing.assert_array_equal(cloud.fields[name], values)


def test_ply_comment_holding_end_header(tmp_path):
    path = tmp_path / "c.ply"
    path.write_bytes(
        b"ply\nformat ascii 1.0\ncomment stops at end_header\nelement vertex 2\n"
        b"property float x\nproperty float y\nproperty float z\nend_header\n1 2 3\n4 5 6\n"
    )
    cloud = read_points(path)
    np.testing.assert_array_equal(cloud.points, POINTS)
    assert cloud.header.comments == ("stops at end_header",)


@pytest.mark.parametrize("control", [b"\x0c", b"\x0b", b"\x1c", b"\x00"])
def test_ply_ascii_data_with_control_characters(tmp_path, control):
    # str.splitlines breaks rows at \x0b, \x0c and \x1c-\x1e: two vertices would come
    # out of one row.
    path = tmp_path / "c.ply"
    path.write_bytes(
        b"ply\nformat ascii 1.0\nelement vertex 2\nproperty float x\nproperty float y\n"
        b"property float z\nend_header\n1 2 3" + control + b"4 5 6\n"
    )
    with pytest.raises(ValueError, match="control character"):
        read_points(path)


def _ascii_file(path, rows: list[bytes], size: int = 4) -> None:
    """An ascii PCD or PLY (by the suffix) of float x, y, z with these rows."""
    n = str(len(rows)).encode()
    if path.suffix == ".pcd":
        width = str(size).encode()
        kind = b"F"
        head = (
            b"VERSION 0.7\nFIELDS x y z\nSIZE "
            + b" ".join([width] * 3)
            + b"\nTYPE "
            + b" ".join([kind] * 3)
            + b"\nCOUNT 1 1 1\nWIDTH "
            + n
            + b"\nHEIGHT 1\nPOINTS "
            + n
            + b"\nDATA ascii\n"
        )
    else:
        kind = b"float" if size == 4 else b"double"
        head = (
            b"ply\nformat ascii 1.0\nelement vertex " + n + b"\nproperty " + kind + b" x\n"
            b"property " + kind + b" y\nproperty " + kind + b" z\nend_header\n"
        )
    path.write_bytes(head + b"\n".join(rows) + b"\n")


@pytest.mark.parametrize("ext", ["pcd", "ply"])
def test_ascii_values_beyond_float32(tmp_path, ext):
    # np.loadtxt makes them inf without a word; the reader says which value it was.
    path = tmp_path / f"f.{ext}"
    _ascii_file(path, [b"1 2 3", b"1 1e39 3"])
    with pytest.raises(
        ValueError, match=r"y value 1e\+39 in data row 2 \(counting from 1\) is beyond"
    ):
        read_points(path)
    # The largest float32, a value that rounds down to it, inf and nan are in range, and
    # underflow to zero is rounding, not overflow.
    _ascii_file(path, [b"3.4028235e38 3.40282356e38 inf", b"nan -1e-50 -inf"])
    points = read_points(path).points
    assert points[0, 0] == points[0, 1] == np.finfo(np.float32).max
    assert np.isnan(points[1, 0])
    np.testing.assert_array_equal(points[:, 2], [np.inf, -np.inf])
    assert points[1, 1] == 0.0 and np.signbit(points[1, 1])
    # float64 fields take what float64 takes.
    _ascii_file(path, [b"1e300 0.1 -2.5e-300"], size=8)
    np.testing.assert_array_equal(read_points(path).points, [[1e300, 0.1, -2.5e-300]])


@pytest.mark.parametrize("ext", ["pcd", "ply"])
def test_ascii_float32_values_are_the_doubles_rounded(tmp_path, ext):
    # Read through float64 for the range check: the values are those np.loadtxt gives
    # a float32 field, the double's nearest float32.
    exponents = np.linspace(-44, 37.5, 500)  # up to 3.2e38, below float32 max
    values = np.random.default_rng(0).uniform(1, 10, 500) * 10.0**exponents
    values[::2] *= -1
    path = tmp_path / f"g.{ext}"
    _ascii_file(path, [f"{v!r} 0 0".encode() for v in values.tolist()])
    np.testing.assert_array_equal(
        read_points(path).points[:, 0], values.astype(np.float32).astype(np.float64)
    )


@pytest.mark.parametrize("ext", ["pcd", "ply", "xyz"])
def test_fields_that_would_share_a_name_are_refused(tmp_path, ext):
    fields = {"a b": np.array([1, 2]), "a_b": np.array([3, 4])}
    with pytest.raises(ValueError, match="'a b' and 'a_b' would both be written as 'a_b'"):
        write_points(tmp_path / f"d.{ext}", POINTS, fields)
    assert not any(tmp_path.iterdir())
    two = {"c": np.array([[1, 2], [3, 4]]), "c_0": np.array([5, 6])}
    if ext == "pcd":  # a field of two values stays one field (COUNT 2)
        write_points(tmp_path / "e.pcd", POINTS, two)
        back = read_points(tmp_path / "e.pcd").fields
        np.testing.assert_array_equal(back["c"], two["c"])
        np.testing.assert_array_equal(back["c_0"], two["c_0"])
    else:  # split into c_0, c_1
        with pytest.raises(ValueError, match="would both be written as 'c_0'"):
            write_points(tmp_path / f"e.{ext}", POINTS, two)
        assert not any(tmp_path.iterdir())


def test_split_columns_keeps_distinct_names():
    columns = {"a b": np.zeros(2), "c": np.zeros((2, 2)), "d": np.ones(2)}
    assert [name for name, _ in split_columns(columns)] == ["a_b", "c_0", "c_1", "d"]


@pytest.mark.parametrize(
    "ext, name, message",
    [
        ("ply", "café", "PLY property name must be printable ASCII"),
        ("xyz", "café", "XYZ column name must be printable ASCII"),
        ("xyz", "a,b", "XYZ column name must be printable ASCII"),
        ("xyz", "a;b", "XYZ column name must be printable ASCII"),
    ],
)
def test_names_a_text_header_cannot_hold(tmp_path, ext, name, message):
    with pytest.raises(ValueError, match=message):
        write_points(tmp_path / f"n.{ext}", POINTS, {name: np.array([1, 2])})
    assert not any(tmp_path.iterdir())


@pytest.mark.parametrize("ext", ["pcd", "ply", "xyz", "las"])
def test_names_each_format_reads_back(tmp_path, ext):
    name = {"pcd": "#c", "ply": "#c", "xyz": "a.b-c/d", "las": "café"}[ext]
    values = np.array([5, 6], np.uint8)
    write_points(tmp_path / f"n.{ext}", POINTS, {name: values})
    np.testing.assert_array_equal(read_points(tmp_path / f"n.{ext}").fields[name], values)


def test_pcd_field_starting_with_hash(tmp_path):
    values = np.array([1.5, 2.5], np.float32)
    for encoding in ("ascii", "binary", "binary_compressed"):
        write_pcd(tmp_path / "h.pcd", POINTS, {"#c": values}, encoding=encoding)
        assert b"FIELDS x y z #c\n" in (tmp_path / "h.pcd").read_bytes()
        np.testing.assert_array_equal(read_points(tmp_path / "h.pcd").fields["#c"], values)


@pytest.mark.parametrize("ext", ["las", "laz", "pcd", "ply", "xyz"])
def test_the_longest_file_names_can_be_written(tmp_path, ext):
    # The temporary file's name keeps only the start of the target's, so that a name of
    # 255 bytes, the usual limit, can be written.
    try:
        limit = os.pathconf(tmp_path, "PC_NAME_MAX")
    except (OSError, ValueError):
        limit = 255
    for stem in ("n" * (limit - len(ext) - 1), "é" * ((limit - len(ext) - 1) // 2)):
        path = tmp_path / f"{stem}.{ext}"
        write_points(path, POINTS)
        np.testing.assert_array_equal(read_points(path).points, POINTS)
        path.unlink()
    assert not any(tmp_path.iterdir())


def _wave_packets(point_format: int, channels: np.ndarray) -> laspy.LasData:
    n = len(channels)
    rng = np.random.default_rng(point_format)
    las = laspy.LasData(laspy.LasHeader(version="1.4", point_format=point_format))
    las.x, las.y, las.z = rng.uniform(0, 100, (3, n))
    las.scanner_channel = channels
    las.wavepacket_index = rng.integers(0, 255, n)
    las.wavepacket_offset = rng.integers(0, 2**40, n)
    las.wavepacket_size = rng.integers(0, 5000, n)
    las.return_point_wave_location = rng.uniform(0, 1, n).astype(np.float32)
    return las


@pytest.mark.parametrize("point_format", [9, 10])
def test_laz_with_wave_packets_and_scanner_channels(tmp_path, point_format):
    n = 2000
    source = tmp_path / "in.las"
    _wave_packets(point_format, np.arange(n) % 2).write(source)
    cloud = read_points(source)
    # Uncompressed LAS holds them exactly.
    write_points(tmp_path / "out.las", cloud.points, cloud.fields, template=cloud)
    back = read_points(tmp_path / "out.las")
    for name in ("wavepacket_size", "wavepacket_offset", "return_point_wave_location"):
        np.testing.assert_array_equal(back.fields[name], cloud.fields[name])
    # lazrs would corrupt the wave packet fields of changing channels: refused.
    with pytest.raises(ValueError, match="more than one scanner channel.*write LAS"):
        write_points(tmp_path / "out.laz", cloud.points, cloud.fields, template=cloud)
    assert not (tmp_path / "out.laz").exists()
    # One channel throughout compresses exactly.
    _wave_packets(point_format, np.full(n, 1)).write(source)
    cloud = read_points(source)
    write_points(tmp_path / "one.laz", cloud.points, cloud.fields, template=cloud)
    back = read_points(tmp_path / "one.laz")
    for name in ("wavepacket_size", "wavepacket_offset", "return_point_wave_location"):
        np.testing.assert_array_equal(back.fields[name], cloud.fields[name])


class _Sink:
    def __init__(self) -> None:
        self.written = 0

    def write(self, data) -> int:
        self.written += len(data)
        return len(data)


def test_ctrl_c_while_lazrs_writes_is_an_interrupt_of_the_write(python_sigint_handler):
    # Python would raise the KeyboardInterrupt in whatever Python code runs next, and
    # inside a call from lazrs that turns into lazrs's own "failed to call write". The
    # signal only sets a flag; the next write raises it, where it is recorded.
    recorder = _RecordingStream(_Sink())
    with pytest.raises(KeyboardInterrupt):
        with recorder.interrupts_recorded():
            recorder.write(b"header")
            os.kill(os.getpid(), signal.SIGINT)  # no exception here
            assert recorder.error is None
            with pytest.raises(KeyboardInterrupt):
                recorder.write(b"points")
            assert isinstance(recorder.error, KeyboardInterrupt)
    assert signal.getsignal(signal.SIGINT) is signal.default_int_handler
    # A signal after the last write is raised when the writing ends.
    recorder = _RecordingStream(_Sink())
    with pytest.raises(KeyboardInterrupt):
        with recorder.interrupts_recorded():
            recorder.write(b"all")
            os.kill(os.getpid(), signal.SIGINT)
    assert recorder.error is None and signal.getsignal(signal.SIGINT) is signal.default_int_handler


def test_laz_write_stopped_by_ctrl_c_leaves_nothing(tmp_path, monkeypatch, python_sigint_handler):
    # The signal arrives while lazrs compresses (in the stream's first write after the
    # header), and the write ends in KeyboardInterrupt, not in lazrs's error.
    from pcl_rg.io import _las

    calls = {"n": 0}
    original = _RecordingStream.write

    def write(self, data):
        calls["n"] += 1
        if calls["n"] == 3:
            os.kill(os.getpid(), signal.SIGINT)
        return original(self, data)

    monkeypatch.setattr(_las._RecordingStream, "write", write)
    points = np.random.default_rng(0).uniform(0, 100, (200_000, 3))
    with pytest.raises(KeyboardInterrupt):
        write_points(tmp_path / "o.laz", points)
    assert not any(tmp_path.iterdir())


@pytest.mark.parametrize("width", [b"1_0", b"0x2", b"2.0", b"1e1"])
def test_pcd_counts_are_decimal_digits(tmp_path, width):
    path = tmp_path / "w.pcd"
    path.write_bytes(
        b"VERSION 0.7\nFIELDS x y z\nWIDTH " + width + b"\nHEIGHT 1\nDATA ascii\n1 2 3\n"
    )
    with pytest.raises(ValueError, match="invalid PCD file"):
        read_points(path)
    path.write_bytes(b"VERSION 0.7\nFIELDS x y z\nWIDTH +1\nHEIGHT 1\nDATA ascii\n1 2 3\n")
    assert len(read_points(path)) == 1


@pytest.mark.parametrize(
    "elements, message",
    [
        (b"element vertex 1_0\n", "element count '1_0' is not an integer"),
        (b"element vertex 1\nelement vertex 1\n", "a second element 'vertex'"),
    ],
)
def test_ply_element_lines(tmp_path, elements, message):
    path = tmp_path / "e.ply"
    path.write_bytes(
        b"ply\nformat ascii 1.0\n" + elements + b"property float x\nproperty float y\n"
        b"property float z\nend_header\n1 2 3\n"
    )
    with pytest.raises(ValueError, match=message):
        read_points(path)


@pytest.mark.parametrize("ext", ["pcd", "ply", "xyz", "las"])
@pytest.mark.parametrize("name", [" x", "z", "y "])
def test_fields_written_as_x_y_or_z_are_refused(tmp_path, ext, name):
    # " x" is written as x in the text formats: a second x property, unreadable.
    with pytest.raises(ValueError, match="x, y and z are given in points, not fields"):
        write_points(tmp_path / f"p.{ext}", POINTS, {name: np.array([1.0, 2.0])})
    assert not any(tmp_path.iterdir())


@pytest.mark.parametrize("name", ["X", "Z\t"])
def test_a_field_named_x_in_another_case_is_a_field_but_in_las(tmp_path, name):
    # A PLY with property X beside x was read, and its write back refused after the work.
    # The text formats read X beside x as a field; LAS's X is its stored coordinate.
    values = np.array([1.5, 2.5])
    for ext in ("pcd", "ply", "xyz"):
        write_points(tmp_path / f"p.{ext}", POINTS, {name: values})
        back = read_points(tmp_path / f"p.{ext}")
        np.testing.assert_array_equal(back.points, POINTS)
        np.testing.assert_array_equal(back.fields[name.strip()], values)
    with pytest.raises(ValueError, match="LAS names its coordinates X, Y and Z in any case"):
        write_points(tmp_path / "p.las", POINTS, {name: values})
    assert not (tmp_path / "p.las").exists()


def test_long_names_are_cut_between_characters(tmp_path, monkeypatch):
    # 63 one-byte characters and then two-byte ones: 64 bytes would end inside "é".
    from pcl_rg.io import _atomic

    name = "a" * 63 + "é" * 80 + ".pcd"
    created = []

    def recording_open(path, mode="r", *args, **kwargs):
        if "x" in mode:
            created.append(os.path.basename(os.fspath(path)))
        return open(path, mode, *args, **kwargs)

    monkeypatch.setattr(_atomic, "open", recording_open, raising=False)
    write_points(tmp_path / name, POINTS)
    np.testing.assert_array_equal(read_points(tmp_path / name).points, POINTS)
    (temp,) = created
    assert temp.startswith("." + "a" * 63 + ".")  # the cut "é" left out whole
    temp.encode("utf-8")  # no lone surrogate from half a character


@pytest.mark.parametrize("data", [b"1 2 3\n\n", b"1 2 3\n   \n4 5 6\n", b"\n1 2 3\n4 5 6\n"])
def test_ply_ascii_blank_line_within_the_counted_rows(tmp_path, data):
    # numpy skips blank lines: the first file was read as the point 1 2 3 twice.
    path = tmp_path / "b.ply"
    path.write_bytes(
        b"ply\nformat ascii 1.0\nelement vertex 2\nproperty double x\nproperty double y\n"
        b"property double z\nend_header\n" + data
    )
    with pytest.raises(ValueError, match="blank line"):
        read_points(path)


@pytest.mark.parametrize(("size", "code"), [(8, "d"), (4, "i")])
def test_pcd_template_keeps_float64_or_integer_y_and_z(tmp_path, size, code):
    # x float32, y and z not: the template's coordinate type came from x alone, so a
    # round trip rounded y to float32 (5000000.123 -> 5000000.0).
    import struct

    kind = "F" if code == "d" else "I"
    path = tmp_path / "m.pcd"
    header = (
        f"# .PCD v0.7\nVERSION 0.7\nFIELDS x y z\nSIZE 4 {size} {size}\nTYPE F {kind} {kind}\n"
        "COUNT 1 1 1\nWIDTH 1\nHEIGHT 1\nVIEWPOINT 0 0 0 1 0 0 0\nPOINTS 1\nDATA binary\n"
    )
    y, z = (5000000.123, 100.456) if code == "d" else (5000001, -7)
    path.write_bytes(header.encode() + struct.pack(f"<f{code}{code}", 1.5, y, z))
    cloud = read_points(path)
    out = tmp_path / "out.pcd"
    write_points(out, cloud.points, cloud.fields, template=cloud)
    np.testing.assert_array_equal(read_points(out).points, [[1.5, y, z]])


@pytest.mark.parametrize("ext", ["ply", "pcd", "xyz"])
def test_classification_in_another_case_is_the_classification(tmp_path, ext):
    # CloudCompare writes "Classification": read by another name, its noise class 7
    # was not skipped, and a second "classification" column was written beside it.
    path = tmp_path / f"cc.{ext}"
    write_points(path, POINTS, {"Classification": np.array([7, 2], np.uint8)})
    cloud = read_points(path)
    assert list(cloud.fields) == ["classification"]
    assert cloud.classification.tolist() == [7, 2]


def test_classification_in_two_cases_is_left_as_it_is(tmp_path):
    fields = {"Classification": np.array([7, 2]), "CLASSIFICATION": np.array([1, 1])}
    write_points(tmp_path / "two.ply", POINTS, fields)
    cloud = read_points(tmp_path / "two.ply")
    assert list(cloud.fields) == list(fields) and cloud.classification is None


def test_ply_upper_case_coordinates(tmp_path):
    path = tmp_path / "upper.ply"
    header = "ply\nformat ascii 1.0\nelement vertex 2\n" + "".join(
        f"property double {name}\n" for name in ("X", "Y", "Z", "x_origin")
    )
    path.write_text(header + "end_header\n1 2 3 9\n4 5 6 9\n")
    cloud = read_points(path)
    np.testing.assert_array_equal(cloud.points, POINTS)
    assert list(cloud.fields) == ["x_origin"]
    # Both spellings: x is the coordinate and X a field.
    path.write_text(header.replace("x_origin", "x") + "end_header\n1 2 3 7\n4 5 6 8\n")
    cloud = read_points(path)
    assert cloud.points[:, 0].tolist() == [7.0, 8.0] and cloud.fields["X"].tolist() == [1.0, 4.0]
