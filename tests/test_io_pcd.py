"""Tests of pcl_rg.io's PCD reader and writer: round trips, PCL's real files,
corrupt input and atomic writes."""

from __future__ import annotations

import os
import re
import struct
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

import numpy as np
import pytest

import pcl_rg.io._atomic as atomic_io
import pcl_rg.io._pcd as pcd_io
from pcl_rg._core import lzf_compress, lzf_decompress
from pcl_rg.io import PcdLayout, PointFile, read_pcd, write_pcd

ENCODINGS = ("ascii", "binary", "binary_compressed")
ISPRS = [
    f"samp{site}-utm{part}.pcd"
    for site in ("11", "21", "31", "41", "51", "52", "61")
    for part in ("", "-ground")
]
MOSD = [f"learn{i}.pcd" for i in (0, 5, 17, 20, 25, 33, 40)]


def shared_data(*parts: str) -> Path:
    """A file under the shared data folder beside the repo; fail (not skip) if missing."""
    path = Path(__file__).resolve().parents[2] / "shared" / "data" / Path(*parts)
    if not path.is_file():
        pytest.fail(
            f"shared test data missing: {path} (the repo's parent folder must hold "
            "shared/data; these tests never skip)",
            pytrace=False,
        )
    return path


def header_values(path: Path) -> dict[str, list[str]]:
    """The header of a PCD file as keyword -> tokens, parsed independently of pcl_rg."""
    raw = path.read_bytes()
    end = raw.index(b"\nDATA ")
    end = raw.index(b"\n", end + 1)
    values = {}
    for line in raw[:end].decode("ascii").splitlines():
        if line and not line.startswith("#"):
            key, *tokens = line.split()
            values[key] = tokens
    return values


def data_offset(raw: bytes) -> int:
    """Offset of the first byte after the DATA line."""
    return raw.index(b"\n", raw.index(b"\nDATA ") + 1) + 1


def bits(array: np.ndarray) -> np.ndarray:
    """The raw bits of an array, so that comparisons are exact for NaN and -0.0."""
    array = np.ascontiguousarray(array)
    return array.view(f"u{array.dtype.itemsize}")


def assert_same_cloud(a: PointFile, b: PointFile) -> None:
    assert a.points.dtype == b.points.dtype == np.float64
    np.testing.assert_array_equal(bits(a.points), bits(b.points))
    assert list(a.fields) == list(b.fields)
    for name in a.fields:
        assert a.fields[name].dtype == b.fields[name].dtype, name
        assert a.fields[name].shape == b.fields[name].shape, name
        np.testing.assert_array_equal(bits(a.fields[name]), bits(b.fields[name]), err_msg=name)
    assert a.format == b.format == "pcd"
    assert a.header[2:] == b.header[2:]  # width, height, viewpoint (not encoding or xyz_dtype)


def synthetic_cloud(n: int, seed: int = 7) -> tuple[np.ndarray, dict[str, np.ndarray]]:
    """UTM-sized points with NaN rows and extra fields of every storable dtype."""
    rng = np.random.default_rng(seed)
    points = rng.uniform([5e5, 5.4e6, 200.0], [5.01e5, 5.401e6, 400.0], size=(n, 3))
    points[rng.random(n) < 0.2] = np.nan
    normals = rng.normal(size=(n, 3))
    normals[::7] = np.nan
    curvature = rng.random(n).astype(np.float32)
    tiny, big = np.finfo(np.float32).smallest_subnormal, np.finfo(np.float32).max
    specials = np.array([np.inf, -np.inf, -0.0, tiny, big, -big, np.nan], dtype=np.float32)
    curvature[: min(n, specials.size)] = specials[: min(n, specials.size)]
    fields = {
        "intensity": rng.integers(0, 2**16, n, dtype=np.uint16),
        "label": rng.integers(-(2**31), 2**31, n, dtype=np.int32),
        "offset": rng.integers(-(2**63), 2**63 - 1, n, dtype=np.int64, endpoint=True),
        "gps": rng.integers(0, 2**64 - 1, n, dtype=np.uint64, endpoint=True),
        "class": rng.integers(-128, 128, n, dtype=np.int8),
        "rgb": rng.integers(0, 2**24, n, dtype=np.uint32).view(np.float32),  # PCL packing
        "normal": normals,
        "curvature": curvature,
        "hist": rng.integers(0, 256, (n, 33), dtype=np.uint8),
        "ring": rng.integers(0, 2**16, (n, 2), dtype=np.uint16).astype(">u2"),  # big-endian in
    }
    return points, fields


# ---------------------------------------------------------------------- round trips


@pytest.mark.parametrize("encoding", ENCODINGS)
@pytest.mark.parametrize("xyz_dtype", [np.float32, np.float64])
@pytest.mark.parametrize("shape", [(60, 1), (10, 6)])
def test_round_trip_is_bit_exact(tmp_path, encoding, xyz_dtype, shape):
    width, height = shape
    points, fields = synthetic_cloud(width * height)
    path = tmp_path / "cloud.pcd"
    viewpoint = (1.5, -2.0, 3.25, 0.0, 1.0, 0.0, 0.0)
    write_pcd(
        path, points, fields, encoding=encoding, width=width, height=height,
        viewpoint=viewpoint, xyz_dtype=xyz_dtype,
    )
    cloud = read_pcd(path)

    expected_points = points.astype(xyz_dtype).astype(np.float64)
    np.testing.assert_array_equal(bits(cloud.points), bits(expected_points))
    assert cloud.points.flags.c_contiguous and cloud.points.flags.writeable
    assert list(cloud.fields) == list(fields)
    for name, values in fields.items():
        got = cloud.fields[name]
        assert got.dtype == values.dtype.newbyteorder("="), name
        assert got.shape == values.shape, name
        assert got.flags.writeable and got.dtype.isnative, name
        np.testing.assert_array_equal(bits(got), bits(values.astype(got.dtype)), err_msg=name)
    assert cloud.header == PcdLayout(encoding, np.dtype(xyz_dtype), width, height, viewpoint)
    assert (cloud.format, cloud.path) == ("pcd", str(path))
    assert sorted(os.listdir(tmp_path)) == ["cloud.pcd"]  # no temporary file left


def test_float32_rounds_utm_coordinates_but_float64_keeps_them(tmp_path):
    points = np.array([[512700.87, 5403547.33, 295.25]])
    write_pcd(tmp_path / "f4.pcd", points)
    write_pcd(tmp_path / "f8.pcd", points, xyz_dtype=np.float64)
    assert read_pcd(tmp_path / "f4.pcd").points[0, 1] == 5403547.5  # 0.5 m float32 spacing
    np.testing.assert_array_equal(read_pcd(tmp_path / "f8.pcd").points, points)
    # The recommended fix: subtract a local origin before writing float32.
    origin = np.array([512000.0, 5403000.0, 0.0])
    write_pcd(tmp_path / "local.pcd", points - origin)
    back = read_pcd(tmp_path / "local.pcd").points + origin
    np.testing.assert_allclose(back, points, atol=1e-4, rtol=0)


@pytest.mark.parametrize("encoding", ENCODINGS)
def test_empty_cloud_round_trips(tmp_path, encoding):
    path = tmp_path / "empty.pcd"
    write_pcd(path, np.empty((0, 3)), {"i": np.empty(0, np.uint8), "h": np.empty((0, 4))},
              encoding=encoding)
    cloud = read_pcd(path)
    assert cloud.points.shape == (0, 3)
    assert cloud.fields["i"].shape == (0,) and cloud.fields["i"].dtype == np.uint8
    assert cloud.fields["h"].shape == (0, 4) and cloud.fields["h"].dtype == np.float64
    assert (cloud.header.width, cloud.header.height) == (0, 1)


@pytest.mark.parametrize("encoding", ENCODINGS)
def test_header_matches_pcl_writer(tmp_path, encoding):
    path = tmp_path / "h.pcd"
    write_pcd(path, np.zeros((4, 3)), {"rgba": np.zeros(4, np.uint32)}, encoding=encoding,
              width=2)
    header = path.read_bytes()[: data_offset(path.read_bytes())].decode("ascii")
    assert header == (
        "# .PCD v0.7 - Point Cloud Data file format\nVERSION 0.7\nFIELDS x y z rgba\n"
        "SIZE 4 4 4 4\nTYPE F F F U\nCOUNT 1 1 1 1\nWIDTH 2\nHEIGHT 2\n"
        f"VIEWPOINT 0 0 0 1 0 0 0\nPOINTS 4\nDATA {encoding}\n"
    )


def test_ascii_text_is_shortest_and_writes_nan(tmp_path):
    path = tmp_path / "a.pcd"
    write_pcd(path, [[0.1, np.nan, -2.0]], {"d": np.array([0.1])}, encoding="ascii")
    body = path.read_bytes()[data_offset(path.read_bytes()) :]
    assert body == b"0.1 nan -2.0 0.1\n"  # shortest text of float32 and float64 values


def test_width_or_height_alone_sets_the_other(tmp_path):
    path = tmp_path / "o.pcd"
    write_pcd(path, np.zeros((12, 3)), width=4)
    assert read_pcd(path).header[2:4] == (4, 3)  # PcdLayout: encoding, xyz_dtype, width, height
    write_pcd(path, np.zeros((12, 3)), height=6)
    assert read_pcd(path).header[2:4] == (2, 6)


# ----------------------------------------------------------------------- real files


def check_against_header(path: Path, cloud: PointFile) -> dict[str, list[str]]:
    h = header_values(path)
    n = int(h["POINTS"][0])
    assert cloud.points.shape == (n, 3)
    assert isinstance(cloud.header, PcdLayout) and cloud.header.encoding == h["DATA"][0]
    assert (cloud.header.width, cloud.header.height) == (int(h["WIDTH"][0]), int(h["HEIGHT"][0]))
    assert cloud.header.width * cloud.header.height == n
    assert cloud.header.viewpoint == tuple(float(v) for v in h["VIEWPOINT"])
    assert list(cloud.fields) == [f for f in h["FIELDS"] if f not in ("x", "y", "z", "_")]
    for name, size, typ in zip(h["FIELDS"], h["SIZE"], h["TYPE"]):
        if name in cloud.fields:
            assert cloud.fields[name].dtype == np.dtype(f"{typ.lower()}{size}")
    return h


@pytest.mark.parametrize("name", ISPRS)
def test_read_isprs(name):
    path = shared_data("isprs", name)
    cloud = read_pcd(path)
    check_against_header(path, cloud)
    assert cloud.header.height == 1 and cloud.fields == {}
    assert np.isfinite(cloud.points).all()
    # UTM zone 32U (Stuttgart): a decoding that mixed up the columns would not fit.
    assert (cloud.points[:, 0] > 4e5).all() and (cloud.points[:, 0] < 6e5).all()
    assert (cloud.points[:, 1] > 5.3e6).all() and (cloud.points[:, 1] < 5.5e6).all()
    assert (cloud.points[:, 2] > 0).all() and (cloud.points[:, 2] < 1000).all()
    # float32 storage: northings are multiples of 0.5 m.
    assert (np.mod(cloud.points[:, 1], 0.5) == 0).all()


@pytest.mark.parametrize("name", MOSD)
def test_read_mosd(name):
    path = shared_data("mosd", name)
    cloud = read_pcd(path)
    check_against_header(path, cloud)
    assert (cloud.header.width, cloud.header.height) == (640, 480)
    assert cloud.fields["label"].dtype == np.uint32 and cloud.fields["rgba"].dtype == np.uint32
    invalid = np.isnan(cloud.points[:, 2])
    assert 0 < invalid.sum() < invalid.size
    # Invalid points carry label 0 and valid ones a label >= 1 (mosd/README.md): this
    # also checks that the column-major fields were split at the right offsets.
    np.testing.assert_array_equal(cloud.fields["label"] == 0, invalid)
    assert np.isfinite(cloud.points[~invalid]).all()


@pytest.mark.parametrize(
    ("name", "organized", "has_nan"),
    [("region_growing_tutorial.pcd", False, False),
     ("table_scene_mug_stereo_textured.pcd", True, True)],
)
def test_read_pcl_tutorial_clouds(name, organized, has_nan):
    path = shared_data("pcl", name)
    cloud = read_pcd(path)
    check_against_header(path, cloud)
    assert (cloud.header.height == 480) == organized
    rgb = cloud.fields["rgb"]
    assert rgb.dtype == np.float32  # packed 0x00RRGGBB, kept as stored
    nan_rows = np.isnan(cloud.points).any(axis=1)
    assert nan_rows.any() == has_nan
    # Packed colours of valid points are small floats, never NaN.
    assert (rgb[~nan_rows].view(np.uint32) >> 24 <= 1).all()
    if has_nan:
        # Invalid points are NaN in all three coordinates, and in rgb too (0x7fc00000).
        np.testing.assert_array_equal(np.isnan(cloud.points).all(axis=1), nan_rows)
        assert (rgb[nan_rows].view(np.uint32) == 0x7FC00000).all()


# ascii takes about a second per million values, so only the 38k-point cloud is
# re-written in ascii (the synthetic round trips cover ascii of every dtype).
REWRITES = [
    pytest.param(parts, encoding, id=f"{parts[1]}-{encoding}")
    for parts, encodings in [
        (("mosd", "learn0.pcd"), ENCODINGS[1:]),
        (("pcl", "table_scene_mug_stereo_textured.pcd"), ENCODINGS[1:]),
        (("pcl", "region_growing_tutorial.pcd"), ENCODINGS[1:]),
        (("isprs", "samp11-utm.pcd"), ENCODINGS),
    ]
    for encoding in encodings
]


@pytest.mark.parametrize(("parts", "encoding"), REWRITES)
def test_rewrite_real_file(tmp_path, parts, encoding):
    original = read_pcd(shared_data(*parts))
    path = tmp_path / "copy.pcd"
    layout = original.header
    write_pcd(path, original.points, original.fields, encoding=encoding,
              width=layout.width, height=layout.height, viewpoint=layout.viewpoint)
    assert_same_cloud(read_pcd(path), original)


@pytest.mark.parametrize("name", ["samp11-utm.pcd", "samp41-utm-ground.pcd"])
def test_binary_compressed_layout_equals_pcl(tmp_path, name):
    """Our header and uncompressed column-major payload are byte-identical to PCL's."""
    source = shared_data("isprs", name)
    cloud = read_pcd(source)
    path = tmp_path / name
    write_pcd(path, cloud.points, cloud.fields)

    def split(raw: bytes) -> tuple[bytes, bytes]:
        start = data_offset(raw)
        size, full = struct.unpack_from("<II", raw, start)
        return raw[:start], lzf_decompress(raw[start + 8 : start + 8 + size], full)

    ours, pcl = split(path.read_bytes()), split(source.read_bytes())
    assert ours[0] == pcl[0]
    assert ours[1] == pcl[1]


def test_concurrent_reads_equal_serial():
    path = shared_data("mosd", "learn0.pcd")
    serial = read_pcd(path)
    with ThreadPoolExecutor(4) as pool:
        for cloud in pool.map(read_pcd, [path] * 4):
            assert_same_cloud(cloud, serial)


# -------------------------------------------------------- other writers' headers


def test_padding_fields_are_skipped(tmp_path):
    rng = np.random.default_rng(3)
    n = 5
    xyz = rng.random((n, 3)).astype("<f4")
    intensity = rng.integers(0, 2**32, n, dtype=np.uint32)
    head = ("VERSION 0.7\nFIELDS x y z _ intensity\nSIZE 4 4 4 1 4\nTYPE F F F U U\n"
            f"COUNT 1 1 1 4 1\nWIDTH {n}\nHEIGHT 1\nVIEWPOINT 0 0 0 1 0 0 0\nPOINTS {n}\n")
    # binary: records include the padding bytes
    record = np.dtype([("xyz", "<f4", 3), ("pad", "u1", 4), ("i", "<u4")])
    table = np.zeros(n, record)
    table["xyz"], table["pad"], table["i"] = xyz, 0xAB, intensity
    (tmp_path / "b.pcd").write_bytes(head.encode() + b"DATA binary\n" + table.tobytes())
    # binary_compressed: PCL leaves the padding out of the columns
    raw = xyz.T.tobytes() + intensity.astype("<u4").tobytes()
    (tmp_path / "c.pcd").write_bytes(
        head.encode() + b"DATA binary_compressed\n"
        + struct.pack("<II", len(lzf_compress(raw)), len(raw)) + lzf_compress(raw)
    )
    # ascii: PCL's reader skips COUNT tokens for the padding field
    rows = "".join(f"{a!r} {b!r} {c!r} 0 0 0 0 {i}\n" for (a, b, c), i in
                   zip(xyz.tolist(), intensity.tolist()))
    (tmp_path / "a.pcd").write_bytes(head.encode() + b"DATA ascii\n" + rows.encode())
    for name in ("a.pcd", "b.pcd", "c.pcd"):
        cloud = read_pcd(tmp_path / name)
        assert list(cloud.fields) == ["intensity"], name
        np.testing.assert_array_equal(cloud.points, xyz.astype(np.float64), err_msg=name)
        np.testing.assert_array_equal(cloud.fields["intensity"], intensity, err_msg=name)


@pytest.mark.parametrize("encoding", ["binary", "binary_compressed"])
def test_signalling_nan_reads_as_nan_without_warning(tmp_path, encoding):
    points = np.zeros((3, 3), np.float32)
    points.view(np.uint32)[1] = [0x7F800001, 0xFF800002, 0x7FA00000]  # signalling NaNs
    path = tmp_path / "snan.pcd"
    write_pcd(path, points, {"f": points[:, 0].copy()}, encoding=encoding)
    cloud = read_pcd(path)  # warnings are errors in this suite
    assert np.isnan(cloud.points[1]).all() and not np.isnan(cloud.points[[0, 2]]).any()
    np.testing.assert_array_equal(bits(cloud.fields["f"]), bits(points[:, 0]))  # kept as is


def test_old_headers_use_pcl_defaults(tmp_path):
    v5 = tmp_path / "v5.pcd"
    v5.write_bytes(b"# .PCD v.5\nVERSION .5\nCOLUMNS x y z i\nPOINTS 2\nDATA ascii\n"
                   b"1 2 3 4\n5 6 7 8\n")
    cloud = read_pcd(v5)
    np.testing.assert_array_equal(cloud.points, [[1, 2, 3], [5, 6, 7]])
    assert cloud.fields["i"].dtype == np.float32 and cloud.fields["i"].tolist() == [4, 8]
    assert cloud.header == PcdLayout("ascii", np.dtype(np.float32), 2, 1, (0, 0, 0, 1, 0, 0, 0))

    v6 = tmp_path / "v6.pcd"
    v6.write_bytes(b"VERSION .6\r\nFIELDS x y z c\r\nSIZE 4 4 4 1\r\nTYPE F F F U\r\n"
                   b"WIDTH 1\r\nHEIGHT 2\r\nPOINTS 2\r\nDATA ascii\r\n1 2 3 4\r\n5 6 7 255\r\n")
    cloud = read_pcd(v6)
    assert cloud.fields["c"].dtype == np.uint8 and cloud.fields["c"].tolist() == [4, 255]
    assert (cloud.header.width, cloud.header.height) == (1, 2)


@pytest.mark.parametrize("encoding", ["binary", "binary_compressed"])
def test_trailing_zero_padding_is_accepted_like_pcl(tmp_path, encoding):
    path = tmp_path / "p.pcd"
    points, fields = synthetic_cloud(20)
    write_pcd(path, points, fields, encoding=encoding)
    expected = read_pcd(path)
    path.write_bytes(path.read_bytes() + bytes(4000))
    assert_same_cloud(read_pcd(path), expected)


# ------------------------------------------------------------------- corrupt files


def write_sample(folder: Path, encoding: str, name: str = "sample.pcd", n: int = 50) -> Path:
    rng = np.random.default_rng(11)
    points = rng.uniform(1.0, 2.0, (n, 3))  # no zero bytes at the end of the data
    fields = {"intensity": rng.integers(1, 2**16, n, dtype=np.uint16),
              "hist": rng.integers(1, 256, (n, 3), dtype=np.uint8)}
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
    path.write_bytes(raw.replace(b"WIDTH 50\n", f"WIDTH {points}\n".encode())
                     .replace(b"POINTS 50\n", f"POINTS {points}\n".encode()))
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
        (b"1.", b"abc", "could not convert string 'abc"),
        (b"1.", b"1,", "could not convert"),
        (b" ", b"  1 ", "columns"),  # one column too many on the first row
        (b" ", b"", "columns"),  # one column too few on the first row
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
        expect_invalid(path, "convert|ASCII")


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
        (b"WIDTH 50", b"WIDTH fifty", "not an integer"),
        (b"POINTS 50", b"POINTS -50", "must be >= 0"),
        (b"HEIGHT 1", b"HEIGHT 1\nHEIGHT 1", "HEIGHT twice"),
        (b"HEIGHT 1", b"HEIGHT 1\nCOLOR red", "unknown header keyword 'COLOR'"),
        (b"HEIGHT 1", "HEIGHT 1 é".encode(), "not ASCII"),
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
