"""pcl_rg.io.read_points / write_points on PLY, PCD and XYZ text: round trips, layouts
kept from a template, format dispatch, magic-byte checks, corrupt files and atomic
writes (LAS/LAZ: test_io_las.py)."""

from __future__ import annotations

import errno
import os
import stat
import struct

import numpy as np
import pytest
from conftest import fail_writes, shared_data

import pcl_rg.io as pio
from pcl_rg import datasets
from pcl_rg.io import PointFile, read_pcd, read_points, write_pcd, write_points

# ------------------------------------------------------------------------ PLY

PLY_DTYPES = ["i1", "u1", "i2", "u2", "i4", "u4", "f4", "f8"]


@pytest.mark.parametrize("encoding", ["ascii", "binary_little_endian", "binary_big_endian"])
def test_ply_round_trip(tmp_path, encoding):
    rng = np.random.default_rng(21)
    n = 200
    xyz = rng.uniform(-1e3, 1e3, (n, 3))
    fields = {}
    for code in PLY_DTYPES:
        dtype = np.dtype(code)
        if dtype.kind == "f":
            fields[f"f_{code}"] = rng.normal(size=n).astype(dtype)
        else:
            info = np.iinfo(dtype)
            fields[f"f_{code}"] = rng.integers(info.min, info.max, n, endpoint=True).astype(dtype)
    template = PointFile(xyz, fields, "ply", pio.PlyLayout(encoding, np.dtype("f8"), ("a note",)))
    write_points(tmp_path / "a.ply", xyz, fields, template=template)
    head = (tmp_path / "a.ply").read_bytes()[:300]
    assert f"format {encoding} 1.0".encode() in head and b"comment a note" in head
    back = read_points(tmp_path / "a.ply")
    np.testing.assert_array_equal(back.points, xyz)
    assert list(back.fields) == list(fields)
    for name, values in fields.items():
        assert back.fields[name].dtype == values.dtype, name
        np.testing.assert_array_equal(back.fields[name], values, err_msg=name)
    assert back.header.encoding == encoding and back.header.comments == ("a note",)


def test_ply_types_without_template(tmp_path):
    rng = np.random.default_rng(22)
    exact = rng.integers(-1000, 1000, (50, 3)).astype(np.float64) / 4  # float32-exact
    write_points(
        tmp_path / "a.ply",
        exact,
        {
            "big": np.arange(50, dtype=np.int64),
            "huge": np.arange(50, dtype=np.int64) * 2**40,
            "pair": rng.normal(size=(50, 2)),
        },
    )
    back = read_points(tmp_path / "a.ply")
    assert back.header.xyz_dtype == np.float32
    np.testing.assert_array_equal(back.points, exact)
    assert back.fields["big"].dtype == np.int32
    assert back.fields["huge"].dtype == np.float64
    np.testing.assert_array_equal(back.fields["huge"], np.arange(50) * 2.0**40)
    assert {"pair_0", "pair_1"} <= set(back.fields)
    # Beyond 2**53 double rounds integers: refused rather than rounded.
    with pytest.raises(ValueError, match=r"field 'id': PLY has no 64-bit integers"):
        write_points(tmp_path / "c.ply", exact[:1], {"id": np.array([2**53 + 1])})
    write_points(tmp_path / "c.ply", exact[:1], {"id": np.array([2**32 - 1], np.int64)})
    assert read_points(tmp_path / "c.ply").fields["id"].dtype == np.uint32
    utm = exact + [5e5 + 0.001, 5e6, 0]
    write_points(tmp_path / "b.ply", utm)
    back = read_points(tmp_path / "b.ply")
    assert back.header.xyz_dtype == np.float64
    np.testing.assert_array_equal(back.points, utm)


def test_ply_skips_other_elements(tmp_path):
    text = (
        "ply\nformat ascii 1.0\ncomment made by hand\nelement camera 1\nproperty float f\n"
        "element vertex 3\nproperty float x\nproperty float y\nproperty float z\n"
        "property uchar red\nelement face 1\nproperty list uchar int vertex_indices\n"
        "end_header\n9.5\n0 0 0 10\n1 0 0 20\n0 1 0.5 30\n3 0 1 2\n"
    )
    (tmp_path / "mesh.ply").write_text(text)
    cloud = read_points(tmp_path / "mesh.ply")
    np.testing.assert_array_equal(cloud.points, [[0, 0, 0], [1, 0, 0], [0, 1, 0.5]])
    np.testing.assert_array_equal(cloud.fields["red"], [10, 20, 30])
    assert cloud.fields["red"].dtype == np.uint8
    # The same in binary, big-endian, faces after the vertices.
    head = (
        b"ply\nformat binary_big_endian 1.0\nelement camera 1\nproperty double f\n"
        b"element vertex 2\nproperty double x\nproperty double y\nproperty double z\n"
        b"element face 1\nproperty list uchar int vertex_indices\nend_header\n"
    )
    body = (
        struct.pack(">d", 9.5)
        + struct.pack(">6d", 1, 2, 3, 4, 5, 6)
        + b"\x02"
        + struct.pack(">2i", 0, 1)
    )
    (tmp_path / "b.ply").write_bytes(head + body)
    np.testing.assert_array_equal(read_points(tmp_path / "b.ply").points, [[1, 2, 3], [4, 5, 6]])


PLY_HEAD = (
    "ply\nformat binary_little_endian 1.0\nelement vertex 2\n"
    "property float x\nproperty float y\nproperty float z\nend_header\n"
)


@pytest.mark.parametrize(
    "content, message",
    [
        (b"ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\n", "no 'end_header'"),
        (b"ply\nelement vertex 1\nproperty float x\nend_header\n1\n", "no 'format' line"),
        (b"ply\nformat ascii 2.0\nend_header\n", "unsupported format"),
        (
            b"ply\nformat ascii 1.0\nelement vertex 1\nproperty float128 x\nend_header\n",
            "unknown property type",
        ),
        (b"ply\nformat ascii 1.0\nelement vertex x\nend_header\n", "not an integer"),
        (
            b"ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nproperty float y\n"
            b"end_header\n1 2\n",
            "no 'z'",
        ),
        (
            b"ply\nformat ascii 1.0\nelement face 1\nproperty float x\nend_header\n1\n",
            "no 'vertex'",
        ),
        (b"ply\nformat ascii 1.0\nbogus line\nend_header\n", "unknown header keyword"),
        (PLY_HEAD.encode() + bytes(12), "truncated"),
        (PLY_HEAD.encode() + bytes(24) + b"junk", "bytes after"),
        (PLY_HEAD.replace("binary_little_endian", "ascii").encode() + b"1 2 3\n", "truncated"),
        (
            PLY_HEAD.replace("binary_little_endian", "ascii").encode() + b"1 2 3\n4 5 6\n7 8 9\n",
            "more data rows",
        ),
        (
            PLY_HEAD.replace("binary_little_endian", "ascii").encode() + b"1 2 3\n4 5\n",
            "values per row",
        ),
        (
            b"ply\nformat ascii 1.0\nelement vertex 1\nproperty list uchar float x\nend_header\n",
            "list properties",
        ),
    ],
)
def test_ply_errors(tmp_path, content, message):
    path = tmp_path / "bad.ply"
    path.write_bytes(content)
    with pytest.raises(ValueError, match=message):
        read_points(path)


# ------------------------------------------------------------------------ XYZ


def test_xyz_round_trip_is_exact(tmp_path):
    rng = np.random.default_rng(31)
    xyz = rng.uniform([4e5, 5e6, 0], [5e5, 6e6, 100], (300, 3))
    fields = {
        "classification": rng.integers(0, 10, 300).astype(np.uint8),
        "intensity": rng.uniform(0, 1, 300),
    }
    for ext in ("xyz", "txt", "pts"):
        write_points(tmp_path / f"a.{ext}", xyz, fields)
        back = read_points(tmp_path / f"a.{ext}")
        assert back.format == "xyz"
        np.testing.assert_array_equal(back.points, xyz)
        assert back.fields["classification"].dtype == np.int64  # whole numbers
        np.testing.assert_array_equal(back.fields["classification"], fields["classification"])
        np.testing.assert_array_equal(back.fields["intensity"], fields["intensity"])
    # Integers beyond 2**53, which float64 rounds, come back exactly.
    ids = np.array([2**53 + 1, -(2**62) - 1, 7], np.int64)
    write_points(tmp_path / "ids.xyz", xyz[:3], {"id": ids})
    np.testing.assert_array_equal(read_points(tmp_path / "ids.xyz").fields["id"], ids)
    # Whole numbers written as floats in the same column are whole numbers too.
    for tokens, expected in [
        (["9007199254740993", "1e3"], [2**53 + 1, 1000]),
        (["9007199254740992.0", "1"], [2**53, 1]),
        (["9007199254740993", "0.5"], None),  # a fraction: the column is float64
    ]:
        (tmp_path / "mix.xyz").write_text("".join(f"0 0 0 {t}\n" for t in tokens))
        column = read_points(tmp_path / "mix.xyz").fields["column_4"]
        if expected is None:
            assert column.dtype == np.float64
        else:
            assert column.dtype == np.int64 and column.tolist() == expected


def test_xyz_column_names(tmp_path):
    (tmp_path / "plain.xyz").write_text("1 2 3 4.5 7\n2 3 4 5.5 8\n")
    cloud = read_points(tmp_path / "plain.xyz")
    assert list(cloud.fields) == ["column_4", "column_5"]
    np.testing.assert_array_equal(cloud.fields["column_4"], [4.5, 5.5])
    (tmp_path / "named.txt").write_text("// X Y Z Intensity\n\n1 2 3 4\n# a comment\n2 3 4 5\n")
    assert list(read_points(tmp_path / "named.txt").fields) == ["Intensity"]
    (tmp_path / "scan.pts").write_text("2\n1 2 3 -1200 10 20 30\n4 5 6 300 40 50 60\n")
    cloud = read_points(tmp_path / "scan.pts")
    assert list(cloud.fields) == ["intensity", "red", "green", "blue"]
    np.testing.assert_array_equal(cloud.fields["intensity"], [-1200, 300])
    # Written back in Leica's layout (the count, no names line), and read the same.
    write_points(tmp_path / "back.pts", cloud.points, cloud.fields)
    assert (tmp_path / "back.pts").read_text().startswith("2\n1.0 2.0 3.0 -1200 10 20 30\n")
    again = read_points(tmp_path / "back.pts")
    assert {k: v.tolist() for k, v in again.fields.items()} == {
        k: v.tolist() for k, v in cloud.fields.items()
    }
    write_points(tmp_path / "own.pts", cloud.points, {"scan_id": np.arange(2)})
    assert (tmp_path / "own.pts").read_text().startswith("# x y z scan_id\n")
    (tmp_path / "empty.xyz").write_text("# x y z classification\n")
    empty = read_points(tmp_path / "empty.xyz")
    assert empty.points.shape == (0, 3) and list(empty.fields) == ["classification"]


@pytest.mark.parametrize(
    "content, message",
    [
        ("1 2 3\n4 5\n", "cannot read the rows as numbers"),
        ("1 2\n3 4\n", "x y z need 3"),
        ("1 2 three\n", "cannot read the rows as numbers"),
        ("\n\n   \n", "no data rows"),
        ("5\n1 2 3\n", "announces 5 points but 1"),
    ],
)
def test_xyz_errors(tmp_path, content, message):
    (tmp_path / "bad.pts").write_text(content)
    with pytest.raises(ValueError, match=message):
        read_points(tmp_path / "bad.pts")


# ------------------------------------------------------------------------ PCD


def test_pcd_keeps_its_layout(tmp_path):
    source = shared_data("mosd", "learn0.pcd")
    cloud = read_points(source)
    reference = read_pcd(source)
    np.testing.assert_array_equal(cloud.points, reference.points)
    assert list(cloud.fields) == list(reference.fields)
    assert cloud.header == reference.header and cloud.format == reference.format == "pcd"
    assert (cloud.header.width, cloud.header.height) == (640, 480)
    assert cloud.header.encoding == "binary_compressed" and cloud.header.xyz_dtype == np.float32
    segment = np.arange(len(cloud), dtype=np.int32)
    write_points(
        tmp_path / "same.pcd", cloud.points, dict(cloud.fields, segment_id=segment), template=cloud
    )
    back = read_pcd(tmp_path / "same.pcd")
    assert (back.header.width, back.header.height) == (640, 480)
    np.testing.assert_array_equal(back.points, cloud.points)
    np.testing.assert_array_equal(back.fields["segment_id"], segment)
    np.testing.assert_array_equal(back.fields["rgba"], cloud.fields["rgba"])
    # A subset is no longer organized.
    valid = np.isfinite(cloud.points).all(axis=1)
    part = cloud.take(valid)
    write_points(tmp_path / "part.pcd", part.points, part.fields, template=cloud)
    back = read_pcd(tmp_path / "part.pcd")
    assert (back.header.width, back.header.height) == (int(valid.sum()), 1)
    raw = (tmp_path / "part.pcd").read_bytes()[:400]
    assert b"DATA binary_compressed" in raw and b"TYPE F F F" in raw


def test_pcd_without_template_is_lossless(tmp_path):
    scene = datasets.synthetic_scene(seed=2, size=60, n_buildings=0, offset=(5e5, 5e6, 0))
    write_points(tmp_path / "utm.pcd", scene.points, classification=scene.labels)
    back = read_points(tmp_path / "utm.pcd")
    np.testing.assert_array_equal(back.points, scene.points)  # float64 since float32 is not exact
    np.testing.assert_array_equal(back.classification, scene.labels)
    small = np.array([[0.5, 1.25, 2.0]])
    write_points(tmp_path / "small.pcd", small)
    assert read_points(tmp_path / "small.pcd").header.xyz_dtype == np.float32


@pytest.mark.parametrize("sample", ["samp11", "samp52"])
def test_isprs_to_laz_and_back(tmp_path, sample):
    cloud = read_points(shared_data("isprs", f"{sample}-utm.pcd"))
    write_points(tmp_path / "s.laz", cloud.points, cloud.fields)
    back = read_points(tmp_path / "s.laz")
    assert len(back) == len(cloud)
    # Millimetre storage: every coordinate within half a millimetre.
    assert np.abs(back.points - cloud.points).max() <= 0.0005 + 1e-9


# --------------------------------------------------------- dispatch, magic bytes


def test_extension_dispatch_and_format_override(tmp_path):
    xyz = np.random.default_rng(41).uniform(0, 10, (20, 3))
    write_points(tmp_path / "cloud.dat", xyz, format="ply")
    assert read_points(tmp_path / "cloud.dat", format="ply").format == "ply"
    with pytest.raises(ValueError, match=r"unknown file extension '\.dat'"):
        read_points(tmp_path / "cloud.dat")
    with pytest.raises(ValueError, match="unknown file extension"):
        write_points(tmp_path / "cloud", xyz)
    with pytest.raises(ValueError, match="format must be one of"):
        read_points(tmp_path / "cloud.dat", format="obj")
    write_points(tmp_path / "UPPER.LAZ", xyz)
    assert read_points(tmp_path / "UPPER.LAZ").format == "laz"


def _write_each_format(folder) -> dict[str, bytes]:
    xyz = np.random.default_rng(42).uniform(0, 10, (20, 3))
    data = {}
    for ext in ("las", "ply", "pcd", "xyz"):
        write_points(folder / f"src.{ext}", xyz)
        data[ext] = (folder / f"src.{ext}").read_bytes()
    return data


MISLABELLED = [
    ("las", "ply", "PLY"),
    ("las", "xyz", "text"),
    ("laz", "pcd", "PCD"),
    ("ply", "las", "LAS"),
    ("ply", "xyz", "text"),
    ("pcd", "las", "LAS"),
    ("pcd", "ply", "PLY"),
    ("xyz", "las", "LAS"),
    ("txt", "pcd", "PCD"),
    ("pts", "ply", "PLY"),
]


@pytest.mark.parametrize("ext, actual, named", MISLABELLED)
def test_mislabelled_files(tmp_path, ext, actual, named):
    data = _write_each_format(tmp_path)
    path = tmp_path / f"wrong.{ext}"
    path.write_bytes(data[actual])
    with pytest.raises(ValueError, match=f"not a .* file: .* look like a {named}"):
        read_points(path)


@pytest.mark.parametrize("ext", ["las", "laz", "ply", "pcd", "xyz"])
def test_empty_files(tmp_path, ext):
    (tmp_path / f"empty.{ext}").write_bytes(b"")
    with pytest.raises(ValueError, match="file is empty"):
        read_points(tmp_path / f"empty.{ext}")


def test_binary_garbage(tmp_path):
    (tmp_path / "noise.xyz").write_bytes(bytes(range(256)))
    with pytest.raises(ValueError, match="binary data"):
        read_points(tmp_path / "noise.xyz")


def test_pcd_header_lies_about_size(tmp_path):
    xyz = np.random.default_rng(3).uniform(0, 1, (100, 3))
    write_pcd(tmp_path / "a.pcd", xyz, encoding="binary")
    data = (tmp_path / "a.pcd").read_bytes().replace(b"POINTS 100", b"POINTS 200")
    data = data.replace(b"WIDTH 100", b"WIDTH 200")
    (tmp_path / "b.pcd").write_bytes(data)
    with pytest.raises(ValueError, match="truncated"):
        read_points(tmp_path / "b.pcd")


def test_missing_file_and_bad_types(tmp_path):
    with pytest.raises(FileNotFoundError):
        read_points(tmp_path / "nothing.las")
    with pytest.raises(TypeError, match="path must be"):
        read_points(42)
    with pytest.raises(ValueError, match=r"shape \(N, 3\)"):
        write_points(tmp_path / "a.ply", np.zeros((3, 2)))
    with pytest.raises(TypeError, match="real float or integer"):
        write_points(tmp_path / "a.ply", np.zeros((3, 3), dtype=complex))
    with pytest.raises(ValueError, match=r"fields\['a'\] must have shape"):
        write_points(tmp_path / "a.ply", np.zeros((3, 3)), {"a": np.zeros(4)})
    with pytest.raises(ValueError, match="x, y and z are given in points"):
        write_points(tmp_path / "a.ply", np.zeros((3, 3)), {"z": np.zeros(3)})
    with pytest.raises(ValueError, match=r"classification must be in \[0, 255\]"):
        write_points(tmp_path / "a.ply", np.zeros((3, 3)), classification=[1, 2, 300])
    with pytest.raises(TypeError, match="template must be a PointFile"):
        write_points(tmp_path / "a.ply", np.zeros((3, 3)), template="x.las")
    # Masked arrays: np.asarray would drop the mask and write the masked values.
    masked = np.ma.masked_array(np.zeros((3, 3)), mask=[[0, 0, 0], [1, 1, 1], [0, 0, 0]])
    with pytest.raises(ValueError, match="points: masked arrays are not written"):
        write_points(tmp_path / "a.ply", masked)
    values = np.ma.masked_array([1, 2, 3], mask=[0, 1, 0])
    with pytest.raises(ValueError, match=r"fields\['a'\]: masked arrays are not written"):
        write_points(tmp_path / "a.ply", np.zeros((3, 3)), {"a": values})
    assert not (tmp_path / "a.ply").exists()


def test_empty_clouds_round_trip(tmp_path):
    for ext in ("las", "laz", "ply", "pcd", "xyz"):
        write_points(tmp_path / f"e.{ext}", np.zeros((0, 3)), classification=np.zeros(0, np.uint8))
        back = read_points(tmp_path / f"e.{ext}")
        assert back.points.shape == (0, 3), ext
        assert back.classification is not None and len(back.classification) == 0, ext


# ---------------------------------------------------------------- atomic writes


@pytest.mark.parametrize("ext", ["las", "laz", "ply", "pcd", "xyz"])
@pytest.mark.parametrize(
    "error", [OSError(errno.ENOSPC, "No space left on device"), KeyboardInterrupt()]
)
def test_failed_write_leaves_nothing(tmp_path, monkeypatch, ext, error):
    xyz = np.random.default_rng(4).uniform(0, 100, (5000, 3))
    target = tmp_path / f"out.{ext}"
    target.write_bytes(b"previous content")
    seen = fail_writes(monkeypatch, 1000, error)
    with pytest.raises(type(error)):
        write_points(target, xyz, {"v": np.arange(5000.0)})
    assert len(seen) == 1 and os.path.dirname(seen[0]) == str(tmp_path)  # it did start
    assert target.read_bytes() == b"previous content"
    assert sorted(p.name for p in tmp_path.iterdir()) == [f"out.{ext}"]


@pytest.mark.parametrize("ext", ["las", "ply"])
def test_a_failed_write_names_the_callers_path_not_the_temporary_file(tmp_path, ext):
    missing = tmp_path / "no" / "such" / f"x.{ext}"
    with pytest.raises(FileNotFoundError) as error:
        write_points(missing, np.zeros((3, 3)))
    assert error.value.filename == str(missing) and ".tmp" not in str(error.value)
    folder = tmp_path / f"folder.{ext}"
    folder.mkdir()
    with pytest.raises(IsADirectoryError) as error:
        write_points(folder, np.zeros((3, 3)))
    assert error.value.filename == str(folder) and ".tmp" not in str(error.value)
    assert [p.name for p in folder.iterdir()] == [] and len(list(tmp_path.iterdir())) == 1


def test_interrupt_as_the_temporary_file_is_created_leaves_nothing(tmp_path, monkeypatch):
    # Ctrl-C handled as the creating call returns, before its result is stored (CPython
    # runs signal handlers right after a call): the file exists, nothing refers to it.
    real_open, real_os_open = open, os.open

    def create_then_interrupt(file, mode="r", *args, **kwargs):
        stream = real_open(file, mode, *args, **kwargs)
        if "x" not in mode and "w" not in mode:
            return stream
        stream.close()
        raise KeyboardInterrupt

    def os_create_then_interrupt(name, flags, *args, **kwargs):
        fd = real_os_open(name, flags, *args, **kwargs)
        if not flags & os.O_CREAT:
            return fd
        os.close(fd)
        raise KeyboardInterrupt

    monkeypatch.setattr(pio._atomic, "open", create_then_interrupt, raising=False)
    monkeypatch.setattr(pio._atomic.os, "open", os_create_then_interrupt)
    target = tmp_path / "out.ply"
    target.write_bytes(b"previous content")
    with pytest.raises(KeyboardInterrupt):
        write_points(target, np.zeros((10, 3)))
    assert [p.name for p in tmp_path.iterdir()] == ["out.ply"]
    assert target.read_bytes() == b"previous content"


@pytest.mark.parametrize("ext", ["laz", "ply", "xyz"])
def test_a_link_is_written_through_and_a_replaced_file_keeps_its_mode(tmp_path, ext):
    target = tmp_path / "results" / f"run42.{ext}"
    target.parent.mkdir()
    write_points(target, np.zeros((3, 3)))
    os.chmod(target, 0o600)  # a private survey
    link = tmp_path / f"latest.{ext}"
    link.symlink_to(target)
    write_points(link, np.ones((2, 3)))
    # The link stays a link, its target holds the new points, still private.
    assert link.is_symlink() and os.readlink(link) == str(target)
    assert read_points(target).points.tolist() == [[1.0, 1.0, 1.0]] * 2
    assert stat.S_IMODE(target.stat().st_mode) == 0o600
    assert sorted(p.name for p in target.parent.iterdir()) == [target.name]
    # A link to nothing yet is replaced by the new file, as before.
    dangling = tmp_path / f"dangling.{ext}"
    dangling.symlink_to(tmp_path / "nowhere" / f"x.{ext}")
    write_points(dangling, np.ones((2, 3)))
    assert not dangling.is_symlink() and len(read_points(dangling)) == 2
