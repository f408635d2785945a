"""pcl_rg.io's PCD reader and writer on corrupt files and bad arguments, and its
atomic writes."""

from __future__ import annotations

import os
import re
import struct
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from pcd_helpers import ENCODINGS, bits, data_offset, synthetic_cloud

import pcl_rg.io._atomic as atomic_io
import pcl_rg.io._pcd as pcd_io
from pcl_rg._core import lzf_compress, lzf_decompress
from pcl_rg.io import read_pcd, write_pcd

# ------------------------------------------------------------------- corrupt files


def write_sample(folder: Path, encoding: str, name: str = "sample.pcd", n: int = 50) -> Path:
    rng = np.random.default_rng(11)
    points = rng.uniform(1.0, 2.0, (n, 3))  # no zero bytes at the end of the data
    fields = {
        "intensity": rng.integers(1, 2**16, n, dtype=np.uint16),
        "hist": rng.integers(1, 256, (n, 3), dtype=np.uint8),
    }
    path = folder / name
    write_pcd(path, points, fields, encoding=encoding)
    return path


def expect_invalid(path: Path, match: str = "") -> None:
    with pytest.raises(ValueError, match=re.escape(str(path))) as info:
        read_pcd(path)
    assert re.search(match, str(info.value)), str(info.value)


@pytest.mark.parametrize("encoding", ENCODINGS)
def test_truncated_files(tmp_path, encoding):
    sample = write_sample(tmp_path, encoding)
    raw = sample.read_bytes()
    start = data_offset(raw)
    last_line = raw.rindex(b"\n", 0, len(raw) - 1) + 1
    cuts = {
        0: "empty",
        12: "not a PCD file",  # inside the first comment line
        start // 2: "truncated",
        start - 1: "truncated",
        start: "no rows" if encoding == "ascii" else "truncated",
        start + 3: "",
        (start + len(raw)) // 2: "",
        last_line - 1: "",
    }
    if encoding != "ascii":  # ascii cut inside the last number is still a valid file
        cuts[len(raw) - 1] = ""
    for cut, match in cuts.items():
        path = tmp_path / f"cut{cut}.pcd"
        path.write_bytes(raw[:cut])
        expect_invalid(path, match)


@pytest.mark.parametrize("encoding", ENCODINGS)
@pytest.mark.parametrize("points", [49, 51])
def test_header_points_disagree_with_data(tmp_path, encoding, points):
    raw = write_sample(tmp_path, encoding).read_bytes()
    path = tmp_path / "lie.pcd"
    path.write_bytes(
        raw.replace(b"WIDTH 50\n", f"WIDTH {points}\n".encode()).replace(
            b"POINTS 50\n", f"POINTS {points}\n".encode()
        )
    )
    expect_invalid(path, "POINTS|truncated|padding")


@pytest.mark.parametrize("encoding", ENCODINGS)
def test_points_not_width_times_height(tmp_path, encoding):
    raw = write_sample(tmp_path, encoding).read_bytes()
    path = tmp_path / "wh.pcd"
    path.write_bytes(raw.replace(b"HEIGHT 1\n", b"HEIGHT 2\n"))
    expect_invalid(path, r"WIDTH 50 x HEIGHT 2 = 100 does not equal POINTS 50")


def test_garbage_lzf_payload(tmp_path):
    raw = write_sample(tmp_path, "binary_compressed").read_bytes()
    start = data_offset(raw) + 8
    garbage = np.random.default_rng(5).integers(0, 256, len(raw) - start, np.uint8).tobytes()
    path = tmp_path / "garbage.pcd"
    path.write_bytes(raw[:start] + garbage)
    expect_invalid(path, "does not decompress")


def test_bad_lzf_size_words(tmp_path):
    raw = write_sample(tmp_path, "binary_compressed").read_bytes()
    start = data_offset(raw)
    compressed, full = struct.unpack_from("<II", raw, start)
    cases = {
        "flipped": (full, compressed),
        "compressed too big": (compressed + 1000, full),
        "compressed too small": (compressed - 10, full),
        "uncompressed wrong": (compressed, full + 4),
    }
    for label, words in cases.items():
        path = tmp_path / f"{label.replace(' ', '_')}.pcd"
        path.write_bytes(raw[:start] + struct.pack("<II", *words) + raw[start + 8 :])
        expect_invalid(path, "uncompressed size|truncated|padding|decompress")


@pytest.mark.parametrize(
    ("old", "new", "match"),
    [
        (b"1.", b"abc", r"'abc\S*' cannot be read as float64 \(data row 1, value 1\)"),
        (b"1.", b"1,", "cannot be read as float64"),
        (b" ", b"  1 ", "data row 1 holds 8 values"),  # one column too many on the first row
        (b" ", b"", "data row 1 holds 6 values"),  # one column too few on the first row
    ],
)
def test_bad_ascii_rows(tmp_path, old, new, match):
    raw = write_sample(tmp_path, "ascii").read_bytes()
    start = data_offset(raw)
    path = tmp_path / "bad.pcd"
    path.write_bytes(raw[:start] + raw[start:].replace(old, new, 1))
    expect_invalid(path, match)


def test_ascii_values_out_of_range_or_not_ascii(tmp_path):
    raw = write_sample(tmp_path, "ascii").read_bytes()
    start = data_offset(raw)
    first = raw[start:].split(b"\n")[0].split()
    for label, row in {
        "uint16 overflow": first[:3] + [b"65536"] + first[4:],
        "negative uint": first[:4] + [b"-1"] + first[5:],
        "float for int": first[:3] + [b"7.5"] + first[4:],
        "non ascii": first[:2] + ["é".encode()] + first[3:],
    }.items():
        path = tmp_path / f"{label.replace(' ', '_')}.pcd"
        body = raw[start:].split(b"\n", 1)[1]
        path.write_bytes(raw[:start] + b" ".join(row) + b"\n" + body)
        expect_invalid(path, r"cannot be read as u?int\d+ \(data row 1, value [3-5]\)|ASCII")


@pytest.mark.parametrize(
    ("old", "new", "match"),
    [
        (b"TYPE F F F U U", b"TYPE F F F X U", "unsupported TYPE 'X'"),
        (b"SIZE 4 4 4 2 1", b"SIZE 4 4 4 3 1", "SIZE 3"),
        (b"SIZE 4 4 4 2 1", b"SIZE 4 4 4 2 1 4", "SIZE has 6 values"),
        (b"SIZE 4 4 4 2 1", b"SIZE 4 4 4 2 one", "not an integer"),
        (b"COUNT 1 1 1 1 3", b"COUNT 1 1 1 1 0", "COUNT value 0"),
        (b"COUNT 1 1 1 1 3", b"COUNT 3 1 1 1 1", "'x' must have COUNT 1"),
        (b"FIELDS x y z", b"FIELDS x q z", "no 'y'"),
        (b"FIELDS x y z intensity", b"FIELDS x y z x", "'x' appears twice"),
        (b"VERSION 0.7", b"VERSION 0.8", "unsupported VERSION"),
        (b"DATA ascii", b"DATA zip", "DATA must be one of"),
        (b"VIEWPOINT 0 0 0 1 0 0 0", b"VIEWPOINT 0 0 0 1", "7 numbers"),
        (b"VIEWPOINT 0 0 0 1 0 0 0", b"VIEWPOINT nan 0 0 1 0 0 0", "VIEWPOINT has a value that"),
        (b"VIEWPOINT 0 0 0 1 0 0 0", b"VIEWPOINT 0 0 0 1 0 0 inf", "not finite"),
        (b"WIDTH 50", b"WIDTH fifty", "not an integer"),
        (b"POINTS 50", b"POINTS -50", "must be >= 0"),
        (b"HEIGHT 1", b"HEIGHT 1\nHEIGHT 1", "HEIGHT twice"),
        (b"HEIGHT 1", b"HEIGHT 1\nCOLOR red", "unknown header keyword 'COLOR'"),
        (b"HEIGHT 1", "HEIGHT 1 é".encode(), "not ASCII"),
        # A NUL in a name: read, it could never be written back (found by make fuzz).
        (b"FIELDS x y z intensity", b"FIELDS x y z inten\x00\x10sity", "not ASCII text"),
    ],
)
def test_bad_headers(tmp_path, old, new, match):
    raw = write_sample(tmp_path, "ascii").read_bytes()
    assert raw.count(old) == 1
    path = tmp_path / "bad header.pcd"
    path.write_bytes(raw.replace(old, new))
    expect_invalid(path, match)


@pytest.mark.parametrize(
    "content",
    [
        b"\x89PNG\r\n\x1a\n" + bytes(range(256)) * 4,
        b"ply\nformat ascii 1.0\nelement vertex 1\nend_header\n1 2 3\n",
        b"hello world\n",
        b"# only a comment\n",
        b"just text without newline",
        bytes(5000),
        np.random.default_rng(2).integers(0, 256, 3000, np.uint8).tobytes(),
    ],
)
def test_not_a_pcd_file(tmp_path, content):
    path = tmp_path / "other.pcd"
    path.write_bytes(content)
    expect_invalid(path, "not a PCD file|truncated")


def test_missing_file():
    with pytest.raises(FileNotFoundError):
        read_pcd("/nonexistent/cloud.pcd")
    with pytest.raises(TypeError, match="path must be"):
        read_pcd(42)


@pytest.mark.parametrize("encoding", ENCODINGS)
def test_random_damage_gives_value_error_only(tmp_path, encoding):
    """Flipped bytes and cuts anywhere: either a cloud or a ValueError naming the file."""
    raw = bytearray(write_sample(tmp_path, encoding, n=20).read_bytes())
    rng = np.random.default_rng(13)
    path = tmp_path / "damaged.pcd"
    for _ in range(200):
        damaged = bytearray(raw)
        for pos in rng.integers(0, len(raw), rng.integers(1, 4)):
            damaged[pos] = int(rng.integers(0, 256))
        if rng.random() < 0.3:
            damaged = damaged[: rng.integers(0, len(damaged))]
        path.write_bytes(bytes(damaged))
        try:
            cloud = read_pcd(path)
        except ValueError as exc:
            assert str(path) in str(exc)
        else:
            assert cloud.points.shape[1] == 3


# ---------------------------------------------------------------- write arguments


@pytest.mark.parametrize(
    ("kwargs", "error", "match"),
    [
        ({"points": np.zeros((4, 2))}, ValueError, r"points must have shape \(N, 3\)"),
        ({"points": np.zeros(3)}, ValueError, r"points must have shape \(N, 3\)"),
        ({"points": np.zeros((4, 3), complex)}, TypeError, "points must be a real"),
        ({"points": np.zeros((4, 3), bool)}, TypeError, "points must be a real"),
        ({"points": [[1, 2, "a"]]}, TypeError, "points must be a real"),
        ({"points": [[0, 0, 1e39]]}, ValueError, r"points\[0, 2\].*xyz_dtype=np.float64"),
        ({"fields": [1, 2]}, TypeError, "fields must be a mapping"),
        ({"fields": {"i": np.zeros(3)}}, ValueError, r"fields\['i'\] must have shape \(4,\)"),
        ({"fields": {"i": np.zeros((4, 2, 2))}}, ValueError, r"fields\['i'\] must have shape"),
        ({"fields": {"i": np.zeros((4, 0))}}, ValueError, r"fields\['i'\] must have shape"),
        ({"fields": {"i": np.zeros(4, bool)}}, TypeError, r"fields\['i'\] has dtype bool"),
        ({"fields": {"i": np.zeros(4, np.float16)}}, TypeError, "float16"),
        ({"fields": {"i": np.zeros(4, complex)}}, TypeError, "complex"),
        ({"fields": {"x": np.zeros(4)}}, ValueError, "given in points"),
        ({"fields": {"_": np.zeros(4)}}, ValueError, "field name"),
        ({"fields": {"a b": np.zeros(4)}}, ValueError, "field name"),
        ({"fields": {"": np.zeros(4)}}, ValueError, "field name"),
        ({"fields": {1: np.zeros(4)}}, TypeError, "keys must be str"),
        ({"encoding": "zip"}, ValueError, "encoding must be one of"),
        ({"width": 3}, ValueError, r"width \* height must equal the number of points 4"),
        ({"width": 2, "height": 3}, ValueError, "got 2 \\* 3"),
        ({"width": -1}, ValueError, "width must be >= 0"),
        ({"height": True}, TypeError, "height must be an int"),
        ({"width": 2.0}, TypeError, "width must be an int"),
        ({"viewpoint": (0, 0, 0, 1, 0, 0)}, ValueError, "viewpoint must be 7 finite"),
        ({"viewpoint": (0, 0, np.nan, 1, 0, 0, 0)}, ValueError, "viewpoint must be 7 finite"),
        ({"viewpoint": "origin"}, TypeError, "viewpoint must be 7 numbers"),
        ({"xyz_dtype": np.int32}, ValueError, "xyz_dtype must be"),
        ({"xyz_dtype": "nonsense"}, TypeError, "xyz_dtype must be"),
        ({"path": 3.5}, TypeError, "path must be"),
    ],
)
def test_write_argument_errors(tmp_path, kwargs, error, match):
    arguments = {"path": tmp_path / "w.pcd", "points": np.zeros((4, 3))} | kwargs
    with pytest.raises(error, match=match):
        write_pcd(**arguments)
    assert os.listdir(tmp_path) == []


def test_float64_xyz_accepts_values_beyond_float32(tmp_path):
    points = np.array([[0.0, 0.0, 1e39], [np.inf, -np.inf, np.nan]])
    write_pcd(tmp_path / "big.pcd", points, xyz_dtype=np.float64, encoding="ascii")
    np.testing.assert_array_equal(read_pcd(tmp_path / "big.pcd").points, points)
    write_pcd(tmp_path / "inf.pcd", points[1:])  # infinities fit float32
    np.testing.assert_array_equal(read_pcd(tmp_path / "inf.pcd").points, points[1:])


def test_inputs_are_not_modified(tmp_path):
    points, fields = synthetic_cloud(30)
    copies = (points.copy(), {k: v.copy() for k, v in fields.items()})
    for encoding in ENCODINGS:
        write_pcd(tmp_path / f"{encoding}.pcd", points, fields, encoding=encoding)
    np.testing.assert_array_equal(bits(points), bits(copies[0]))
    for name, values in fields.items():
        np.testing.assert_array_equal(bits(values), bits(copies[1][name]))
        assert values.dtype == copies[1][name].dtype


# ------------------------------------------------------------------- atomic writes


def test_failure_midway_leaves_no_file(tmp_path, monkeypatch):
    calls = []

    def failing(column):
        calls.append(1)
        if len(calls) > 8:
            raise RuntimeError("disk full")
        return column.astype(str).tolist()

    monkeypatch.setattr(atomic_io, "ASCII_CHUNK_ROWS", 10)
    monkeypatch.setattr(atomic_io, "ascii_strings", failing)
    with pytest.raises(RuntimeError, match="disk full"):
        write_pcd(tmp_path / "new.pcd", np.ones((100, 3)), encoding="ascii")
    assert len(calls) > 3  # some rows reached the temporary file before the error
    assert os.listdir(tmp_path) == []


@pytest.mark.parametrize("encoding", ENCODINGS)
@pytest.mark.parametrize("exception", [OSError("no space left"), KeyboardInterrupt()])
def test_failed_write_keeps_the_old_file(tmp_path, monkeypatch, encoding, exception):
    path = write_sample(tmp_path, "binary", name="keep.pcd")
    before = path.read_bytes()

    def half_then_fail(stream, payload):
        stream.write(bytes(payload)[: len(payload) // 2])
        raise exception

    def replace_fails(src, dst):
        raise exception

    if encoding == "ascii":
        monkeypatch.setattr(atomic_io.os, "replace", replace_fails)
    else:
        monkeypatch.setattr(pcd_io, "write_chunked", half_then_fail)
    with pytest.raises(type(exception)):
        write_pcd(path, np.zeros((7, 3)), encoding=encoding)
    monkeypatch.undo()
    assert path.read_bytes() == before
    assert os.listdir(tmp_path) == ["keep.pcd"]


def test_written_file_follows_umask(tmp_path):
    mask = os.umask(0o022)
    try:
        write_pcd(tmp_path / "m.pcd", np.zeros((1, 3)))
    finally:
        os.umask(mask)
    assert (tmp_path / "m.pcd").stat().st_mode & 0o777 == 0o644


def test_an_lzf_size_claim_is_checked_before_the_output_is_allocated():
    # The codec zero-filled the claimed size before liblzf found the payload corrupt:
    # random bytes claiming 88 times their size (what the header check allows) made a
    # 24 MiB file allocate 2.2 GB. The size now comes from the payload's control bytes
    # first: a 3 GB claim is a ValueError, and the process's peak memory does not grow
    # by it (a fresh process, whose peak is its own; an address-space limit would not
    # do under AddressSanitizer, make sanitize).
    script = (
        "import os, resource\n"
        "from pcl_rg._core import lzf_decompress\n"
        "payload = os.urandom(1 << 20)\n"
        "before = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss\n"
        "try:\n"
        "    lzf_decompress(payload, 3_000_000_000)\n"
        "except ValueError as error:\n"
        "    print('ValueError', error)\n"
        "print(resource.getrusage(resource.RUSAGE_SELF).ru_maxrss - before)\n"
    )
    result = subprocess.run(
        [sys.executable, "-c", script], capture_output=True, text=True, timeout=120
    )
    said, grown_kib = result.stdout.splitlines()
    assert said.startswith("ValueError corrupt LZF data"), result.stderr
    assert int(grown_kib) < 100_000, grown_kib  # 3 GB zero-filled: about 2,900,000
    data = np.random.default_rng(3).integers(0, 4, 100_000, dtype=np.uint8).tobytes()
    packed = lzf_compress(data)
    assert lzf_decompress(packed, len(data)) == data
    for claim, holds in ((len(data) + 1, str(len(data))), (len(data) - 1, "more")):
        with pytest.raises(ValueError, match=f"expected {claim} bytes, it holds {holds}$"):
            lzf_decompress(packed, claim)
