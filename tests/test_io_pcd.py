"""pcl_rg.io's PCD reader and writer: round trips, PCL's real files and other
writers' headers."""

from __future__ import annotations

import os
import struct
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

import numpy as np
import pytest
from conftest import ISPRS_SAMPLES, MOSD_SCENES, shared_data
from pcd_helpers import ENCODINGS, assert_same_cloud, bits, data_offset, synthetic_cloud

from pcl_rg._core import lzf_compress, lzf_decompress
from pcl_rg.io import PcdLayout, PointFile, read_pcd, write_pcd

ISPRS = [f"{sample}-utm{part}.pcd" for sample in ISPRS_SAMPLES for part in ("", "-ground")]
MOSD = [f"{scene}.pcd" for scene in MOSD_SCENES]


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
        path,
        points,
        fields,
        encoding=encoding,
        width=width,
        height=height,
        viewpoint=viewpoint,
        xyz_dtype=xyz_dtype,
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
    write_pcd(
        path,
        np.empty((0, 3)),
        {"i": np.empty(0, np.uint8), "h": np.empty((0, 4))},
        encoding=encoding,
    )
    cloud = read_pcd(path)
    assert cloud.points.shape == (0, 3)
    assert cloud.fields["i"].shape == (0,) and cloud.fields["i"].dtype == np.uint8
    assert cloud.fields["h"].shape == (0, 4) and cloud.fields["h"].dtype == np.float64
    assert (cloud.header.width, cloud.header.height) == (0, 1)


@pytest.mark.parametrize("encoding", ENCODINGS)
def test_header_matches_pcl_writer(tmp_path, encoding):
    path = tmp_path / "h.pcd"
    write_pcd(path, np.zeros((4, 3)), {"rgba": np.zeros(4, np.uint32)}, encoding=encoding, width=2)
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
    [
        ("region_growing_tutorial.pcd", False, False),
        ("table_scene_mug_stereo_textured.pcd", True, True),
    ],
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
    write_pcd(
        path,
        original.points,
        original.fields,
        encoding=encoding,
        width=layout.width,
        height=layout.height,
        viewpoint=layout.viewpoint,
    )
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
    head = (
        "VERSION 0.7\nFIELDS x y z _ intensity\nSIZE 4 4 4 1 4\nTYPE F F F U U\n"
        f"COUNT 1 1 1 4 1\nWIDTH {n}\nHEIGHT 1\nVIEWPOINT 0 0 0 1 0 0 0\nPOINTS {n}\n"
    )
    # binary: records include the padding bytes
    record = np.dtype([("xyz", "<f4", 3), ("pad", "u1", 4), ("i", "<u4")])
    table = np.zeros(n, record)
    table["xyz"], table["pad"], table["i"] = xyz, 0xAB, intensity
    (tmp_path / "b.pcd").write_bytes(head.encode() + b"DATA binary\n" + table.tobytes())
    # binary_compressed: PCL leaves the padding out of the columns
    raw = xyz.T.tobytes() + intensity.astype("<u4").tobytes()
    (tmp_path / "c.pcd").write_bytes(
        head.encode()
        + b"DATA binary_compressed\n"
        + struct.pack("<II", len(lzf_compress(raw)), len(raw))
        + lzf_compress(raw)
    )
    # ascii: PCL's reader skips COUNT tokens for the padding field
    rows = "".join(
        f"{a!r} {b!r} {c!r} 0 0 0 0 {i}\n" for (a, b, c), i in zip(xyz.tolist(), intensity.tolist())
    )
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
    v5.write_bytes(
        b"# .PCD v.5\nVERSION .5\nCOLUMNS x y z i\nPOINTS 2\nDATA ascii\n1 2 3 4\n5 6 7 8\n"
    )
    cloud = read_pcd(v5)
    np.testing.assert_array_equal(cloud.points, [[1, 2, 3], [5, 6, 7]])
    assert cloud.fields["i"].dtype == np.float32 and cloud.fields["i"].tolist() == [4, 8]
    assert cloud.header == PcdLayout("ascii", np.dtype(np.float32), 2, 1, (0, 0, 0, 1, 0, 0, 0))

    v6 = tmp_path / "v6.pcd"
    v6.write_bytes(
        b"VERSION .6\r\nFIELDS x y z c\r\nSIZE 4 4 4 1\r\nTYPE F F F U\r\n"
        b"WIDTH 1\r\nHEIGHT 2\r\nPOINTS 2\r\nDATA ascii\r\n1 2 3 4\r\n5 6 7 255\r\n"
    )
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
