"""pcl_rg.io.read_points / write_points on LAS and LAZ: every dimension, extra bytes and
VLRs kept bit for bit, templates, scales, what LAS cannot store, and damaged files."""

from __future__ import annotations

import warnings
from datetime import datetime, timezone

import laspy
import numpy as np
import pytest
from las_helpers import random_las, raw_points
from laspy.vlrs.vlrlist import VLRList

import pcl_rg
from pcl_rg.io import read_points, write_points

LAS_LAYOUTS = [("1.2", 0), ("1.2", 1), ("1.2", 3), ("1.3", 1), ("1.4", 6), ("1.4", 7), ("1.4", 8)]


# ------------------------------------------------------------------ LAS / LAZ


@pytest.mark.parametrize("ext", ["las", "laz"])
@pytest.mark.parametrize("version, point_format", LAS_LAYOUTS)
def test_las_round_trip_keeps_every_dimension_bit_for_bit(tmp_path, ext, version, point_format):
    las = random_las(version, point_format, 500, seed=point_format)
    las.header.system_identifier, las.header.generating_software = "RIEGL VQ-1560", "TerraScan"
    source = tmp_path / f"in.{ext}"
    las.write(source)
    cloud = read_points(source)
    assert cloud.format == ext
    # Coordinates are the stored integers times the scale plus the offset, in float64.
    raw = raw_points(source)
    expected = np.column_stack(
        [raw[axis] * las.header.scales[i] + las.header.offsets[i] for i, axis in enumerate("XYZ")]
    )
    np.testing.assert_array_equal(cloud.points, expected)
    assert cloud.points.dtype == np.float64
    # Every dimension, extra bytes included, is a field.
    names = [d.name for d in las.point_format.dimensions if d.name not in ("X", "Y", "Z")]
    assert list(cloud.fields) == names

    target = tmp_path / f"out.{ext}"
    date_before = datetime.now(timezone.utc).date()
    write_points(target, cloud.points, cloud.fields, template=cloud)
    assert raw_points(target).tobytes() == raw.tobytes()
    back = read_points(target)
    assert str(back.header.version) == version
    assert back.header.point_format.id == point_format
    np.testing.assert_array_equal(back.header.scales, las.header.scales)
    np.testing.assert_array_equal(back.header.offsets, las.header.offsets)
    vlr = [v for v in back.header.vlrs if getattr(v, "user_id", "") == "pcl_rg_test"]
    assert len(vlr) == 1 and vlr[0].record_data == las.header.vlrs[-1].record_data
    np.testing.assert_allclose(back.header.mins, cloud.points.min(axis=0))
    np.testing.assert_allclose(back.header.maxs, cloud.points.max(axis=0))
    # The header names the program that wrote this file and its day; the system
    # identifier (the acquiring hardware) stays the source's.
    assert back.header.generating_software == f"pcl_rg {pcl_rg.__version__}"
    assert back.header.creation_date in (date_before, datetime.now(timezone.utc).date())
    assert back.header.system_identifier == "RIEGL VQ-1560"


@pytest.mark.parametrize("other", ["ply", "pcd", "xyz"])
def test_las_fields_survive_other_formats(tmp_path, other):
    las = random_las("1.4", 7, 300, seed=3)
    las.write(tmp_path / "in.las")
    cloud = read_points(tmp_path / "in.las")
    write_points(tmp_path / f"mid.{other}", cloud.points, cloud.fields)
    middle = read_points(tmp_path / f"mid.{other}")
    np.testing.assert_array_equal(middle.points, cloud.points)
    # Back to LAS with the original as template: the very same records.
    fields = dict(middle.fields)
    if other in ("ply", "xyz"):  # (N, 3) fields come back as name_0, name_1, name_2
        fields["normal"] = np.column_stack([fields.pop(f"normal_{i}") for i in range(3)])
    write_points(tmp_path / "back.las", middle.points, fields, template=cloud)
    assert raw_points(tmp_path / "back.las").tobytes() == raw_points(tmp_path / "in.las").tobytes()


def test_las_subset_and_classification(tmp_path):
    las = random_las("1.2", 3, 400, seed=5)
    las.write(tmp_path / "in.laz")
    cloud = read_points(tmp_path / "in.laz")
    keep = np.random.default_rng(1).random(len(cloud)) < 0.3
    part = cloud.take(keep)
    codes = np.where(np.arange(len(part)) % 2 == 0, 2, 1)
    write_points(
        tmp_path / "part.laz", part.points, part.fields, classification=codes, template=cloud
    )
    raw = raw_points(tmp_path / "in.laz")[keep]
    out = raw_points(tmp_path / "part.laz")
    back = read_points(tmp_path / "part.laz")
    np.testing.assert_array_equal(back.classification, codes)
    # Everything but the class bits of the classification byte is untouched.
    for name in raw.dtype.names:
        if name != "raw_classification":
            np.testing.assert_array_equal(out[name], raw[name], err_msg=name)
    np.testing.assert_array_equal(
        out["raw_classification"] & 0xE0, raw["raw_classification"] & 0xE0
    )
    assert back.header.point_count == keep.sum()


def test_las_new_extra_dimension_on_a_template(tmp_path):
    las = random_las("1.2", 1, 200, seed=7, extra=False)
    las.write(tmp_path / "in.las")
    cloud = read_points(tmp_path / "in.las")
    segment = np.random.default_rng(2).integers(-1, 50, len(cloud)).astype(np.int32)
    write_points(
        tmp_path / "seg.las", cloud.points, dict(cloud.fields, segment_id=segment), template=cloud
    )
    back = read_points(tmp_path / "seg.las")
    assert back.fields["segment_id"].dtype == np.int32
    np.testing.assert_array_equal(back.fields["segment_id"], segment)
    assert back.header.point_format.id == 1 and str(back.header.version) == "1.2"
    for name, values in cloud.fields.items():
        np.testing.assert_array_equal(back.fields[name], values, err_msg=name)


def test_las_template_with_header_text_that_is_not_ascii(tmp_path):
    # The specification wants ASCII there, files in the wild do not always comply, and
    # such a file reads fine: writing in its layout must work too (found by make fuzz).
    random_las("1.2", 1, 50, seed=3, extra=False).write(tmp_path / "in.las")
    data = bytearray((tmp_path / "in.las").read_bytes())
    at = data.index(b"kept")  # the VLR's description
    data[at + 1] = 0xBA
    (tmp_path / "in.las").write_bytes(bytes(data))
    cloud = read_points(tmp_path / "in.las")
    write_points(tmp_path / "out.las", cloud.points, cloud.fields, template=cloud)
    back = read_points(tmp_path / "out.las")
    np.testing.assert_array_equal(back.points, cloud.points)
    description = [v.description for v in back.header.vlrs if v.record_id == 42]
    assert description == [b"k\xbapt"]  # bytes laspy could not decode go back as they were

    # A character ASCII cannot encode, set by the caller, is written as "?".
    cloud.header.system_identifier = "Zürich survey"
    write_points(tmp_path / "named.las", cloud.points, cloud.fields, template=cloud)
    assert read_points(tmp_path / "named.las").header.system_identifier == "Z?rich survey"


def test_records_are_the_files_own_and_follow_a_selection(tmp_path):
    # `records` lists the (E)VLR headers as the file holds them, read with the points
    # (pcl-rg info used to open the file a second time for them): LASzip's VLR, which
    # laspy's header hides, is among a LAZ file's; other formats have none.
    random_las("1.4", 6, 50, seed=4).write(tmp_path / "a.laz")
    cloud = read_points(tmp_path / "a.laz")
    ids = [(r.kind, r.user_id, r.record_id) for r in cloud.records]
    assert ("VLR", "laszip encoded", 22204) in ids
    assert not any("laszip" in v.user_id for v in cloud.header.vlrs)
    assert cloud.take(cloud.points[:, 0] > cloud.points[0, 0]).records == cloud.records
    write_points(tmp_path / "a.ply", cloud.points)
    assert read_points(tmp_path / "a.ply").records == ()


@pytest.mark.parametrize("ext", [".las", ".laz"])
def test_las_template_with_an_evlr_text_that_is_not_ascii(tmp_path, ext):
    # The same for an extended VLR (LAS 1.4), which laspy writes with strict ASCII.
    las = random_las("1.4", 6, 30, seed=4, extra=False)
    las.evlrs = VLRList()
    las.evlrs.append(laspy.VLR("pcl_rg_test", 7, "evdesc", b"payload"))
    las.write(tmp_path / "in.las")
    data = bytearray((tmp_path / "in.las").read_bytes())
    data[data.index(b"evdesc") + 1] = 0xBA
    (tmp_path / "in.las").write_bytes(bytes(data))
    cloud = read_points(tmp_path / "in.las")
    write_points(tmp_path / f"out{ext}", cloud.points, cloud.fields, template=cloud)
    back = read_points(tmp_path / f"out{ext}")
    np.testing.assert_array_equal(back.points, cloud.points)
    assert [(v.description, v.record_data) for v in back.header.evlrs] == [
        (b"e\xbadesc", b"payload")
    ]


def test_las_template_with_integer_extra_bytes_of_several_values(tmp_path):
    # An extra-bytes dimension of 3 x int16 per point (or the 4 x uint8 laspy makes of
    # undocumented extra bytes) has a sub-array dtype: laspy's dim.min/max fail on it,
    # and writing in the file's own layout failed after the work (found by make fuzz).
    las = random_las("1.4", 6, 40, seed=5, extra=False)
    las.add_extra_dims([laspy.ExtraBytesParams(name="counts", type="3i2")])
    las.counts = np.random.default_rng(5).integers(-30000, 30000, (40, 3))
    las.write(tmp_path / "in.las")
    cloud = read_points(tmp_path / "in.las")
    write_points(tmp_path / "out.las", cloud.points, cloud.fields, template=cloud)
    back = read_points(tmp_path / "out.las")
    np.testing.assert_array_equal(back.fields["counts"], las.counts)
    too_large = dict(cloud.fields, counts=np.full((40, 3), 40000))
    with pytest.raises(ValueError, match=r"outside the range \[-32768, 32767\]"):
        write_points(tmp_path / "bad.las", cloud.points, too_large, template=cloud)


def test_las_without_template(tmp_path):
    rng = np.random.default_rng(11)
    n = 1000
    xyz = rng.uniform([4.5e5, 5.4e6, -20.0], [4.51e5, 5.401e6, 300.0], (n, 3))
    fields = {
        "intensity": rng.integers(0, 65536, n).astype(np.uint16),
        "gps_time": rng.uniform(0, 1e6, n),
        "label": rng.integers(0, 2**32, n, dtype=np.uint32),
        "weight": rng.normal(size=n).astype(np.float32),
        "flag": rng.random(n) < 0.5,
        "normal": rng.normal(size=(n, 3)),
    }
    write_points(tmp_path / "a.laz", xyz, fields, classification=rng.integers(0, 256, n))
    back = read_points(tmp_path / "a.laz")
    assert back.header.point_format.id == 6 and str(back.header.version) == "1.4"
    np.testing.assert_array_equal(back.header.scales, [0.001] * 3)
    assert np.abs(back.points - xyz).max() <= 0.0005 + 1e-9
    for name, values in fields.items():
        np.testing.assert_array_equal(back.fields[name], values, err_msg=name)
    assert back.fields["flag"].dtype == np.uint8
    # Colour picks point format 7, colour and NIR 8.
    colour = {c: rng.integers(0, 65536, n).astype(np.uint16) for c in ("red", "green", "blue")}
    write_points(tmp_path / "c.las", xyz, colour)
    assert read_points(tmp_path / "c.las").header.point_format.id == 7
    write_points(tmp_path / "n.las", xyz, dict(colour, nir=colour["red"]))
    assert read_points(tmp_path / "n.las").header.point_format.id == 8


def test_las_scale_grows_with_the_extent(tmp_path):
    xyz = np.array([[0.0, 0.0, 0.0], [5e6, 1.0, 2.0]])  # 5000 km: more than int32 at 1 mm
    write_points(tmp_path / "wide.las", xyz)
    back = read_points(tmp_path / "wide.las")
    assert back.header.scales[0] == pytest.approx(0.01)
    assert np.abs(back.points - xyz).max() <= 0.005


def test_las_rejects_what_it_cannot_store(tmp_path):
    las = random_las("1.2", 3, 50, seed=9)
    las.write(tmp_path / "in.las")
    cloud = read_points(tmp_path / "in.las")
    with pytest.raises(ValueError, match="classification.*outside the range"):
        write_points(
            tmp_path / "x.las",
            cloud.points,
            cloud.fields,
            classification=np.full(50, 40),
            template=cloud,
        )
    with pytest.raises(ValueError, match="intensity.*outside the range"):
        write_points(
            tmp_path / "x.las",
            cloud.points,
            dict(cloud.fields, intensity=np.full(50, -1)),
            template=cloud,
        )
    with pytest.raises(ValueError, match="fractional"):
        write_points(
            tmp_path / "x.las",
            cloud.points,
            dict(cloud.fields, user_data=np.full(50, 1.5)),
            template=cloud,
        )
    far = cloud.points + [1e8, 0, 0]  # beyond int32 at 1 cm from the template's offset
    with pytest.raises(ValueError, match="do not fit"):
        write_points(tmp_path / "x.las", far, cloud.fields, template=cloud)
    nan = cloud.points.copy()
    nan[3] = np.nan
    with pytest.raises(ValueError, match="1 row.*NaN"):
        write_points(tmp_path / "x.las", nan)
    assert not (tmp_path / "x.las").exists()


@pytest.mark.parametrize("ext", ["las", "laz"])
@pytest.mark.parametrize("cut", [0.5, 0.99, "header"])
def test_truncated_las(tmp_path, ext, cut):
    random_las("1.4", 6, 2000, seed=1).write(tmp_path / f"full.{ext}")
    data = (tmp_path / f"full.{ext}").read_bytes()
    keep = 120 if cut == "header" else int(len(data) * cut)
    (tmp_path / f"cut.{ext}").write_bytes(data[:keep])
    # A cut inside the points is named as such, whichever check meets it first.
    problem = "shorter than the 227-byte" if cut == "header" else r"\(truncated\?\)"
    with pytest.raises(ValueError, match=f"invalid LAS/LAZ file.*{problem}"):
        read_points(tmp_path / f"cut.{ext}")


def test_corrupt_las_header(tmp_path):
    random_las("1.2", 3, 100, seed=1).write(tmp_path / "a.las")
    data = bytearray((tmp_path / "a.las").read_bytes())
    data[24:26] = b"\x09\x09"  # version 9.9
    (tmp_path / "b.las").write_bytes(bytes(data))
    with pytest.raises(ValueError, match="invalid LAS/LAZ file"):
        read_points(tmp_path / "b.las")


def test_las_with_more_records_than_counted_warns(tmp_path):
    random_las("1.2", 3, 100, seed=1).write(tmp_path / "a.las")
    data = bytearray((tmp_path / "a.las").read_bytes())
    data[107:111] = (60).to_bytes(4, "little")  # the legacy point count, damaged
    (tmp_path / "b.las").write_bytes(bytes(data))
    with pytest.warns(UserWarning, match=r"counts 60 points.*holds room for 40 more") as caught:
        cloud = read_points(tmp_path / "b.las")
    assert len(cloud.points) == 60
    assert caught[0].filename == __file__  # the caller's line, not pcl_rg's
    # A few bytes after the records, less than one record, are left without a word.
    full = (tmp_path / "a.las").read_bytes()
    (tmp_path / "c.las").write_bytes(full + b"\0" * 7)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        assert len(read_points(tmp_path / "c.las").points) == 100


def test_las_13_waveform_packets_after_the_points_are_no_spare_room(tmp_path):
    random_las("1.3", 3, 100, seed=1).write(tmp_path / "a.las")
    data = bytearray((tmp_path / "a.las").read_bytes())
    counted_end = len(data)
    data += bytes(5 * 200)  # packets of a waveform, stored in the file after the points
    data[227:235] = counted_end.to_bytes(8, "little")
    (tmp_path / "b.las").write_bytes(bytes(data))
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        assert len(read_points(tmp_path / "b.las").points) == 100
    data[227:235] = bytes(8)  # no waveform: the same bytes are room for more records
    (tmp_path / "c.las").write_bytes(bytes(data))
    with pytest.warns(UserWarning, match="room for"):
        read_points(tmp_path / "c.las")


def test_an_extra_bytes_name_over_32_bytes_is_refused_naming_the_field(tmp_path):
    # laspy's own message ("bytes too long (41, maximum length 32)") named no field.
    longest, too_long = "n" * 32, "é" * 16 + "x"  # 32 bytes; 33 bytes in UTF-8
    write_points(tmp_path / "ok.las", np.zeros((3, 3)), {longest: np.arange(3)})
    np.testing.assert_array_equal(read_points(tmp_path / "ok.las").fields[longest], np.arange(3))
    with pytest.raises(
        ValueError, match=r"fields\['é+x'\]: a LAS extra-bytes name holds at most 32"
    ):
        write_points(tmp_path / "long.las", np.zeros((3, 3)), {too_long: np.arange(3)})
    assert sorted(p.name for p in tmp_path.iterdir()) == ["ok.las"]


@pytest.mark.parametrize("ext", ["las", "laz"])
def test_a_copc_template_writes_plain_las(tmp_path, ext):
    # COPC read, but every write in its layout failed after the work ("Writing COPC is
    # not supported"), even to .las (LAS/LAZ hunt). The index would not describe the
    # points written: it is left out.
    import struct

    from laspy.vlrs.vlr import VLR

    rng = np.random.default_rng(0)
    las = laspy.create(point_format=6, file_version="1.4")
    las.x, las.y, las.z = rng.uniform(0, 50, 300), rng.uniform(0, 50, 300), rng.uniform(0, 1, 300)
    info = struct.pack("<5d2Q2d11Q", 25, 25, 25, 26, 1, 0, 32, 0, 0, *[0] * 11)
    las.header.vlrs.insert(0, VLR("copc", 1, "copc info", info))
    las.evlrs = VLRList([VLR("copc", 1000, "EPT hierarchy", bytes(32))])
    las.write(tmp_path / "tile.copc.laz")
    cloud = read_points(tmp_path / "tile.copc.laz")
    write_points(tmp_path / f"out.{ext}", cloud.points, cloud.fields, template=cloud)
    out = laspy.read(tmp_path / f"out.{ext}")
    assert not [v for v in [*out.header.vlrs, *(out.header.evlrs or [])] if v.user_id == "copc"]
    np.testing.assert_allclose(read_points(tmp_path / f"out.{ext}").points, cloud.points)


def test_extra_bytes_of_several_values_with_their_own_scales_round_trip(tmp_path):
    # laspy's range check took the largest value of all columns against each column's
    # limit: amp = (0, 1000) at scales (1, 10) was refused after the work (LAS/LAZ hunt).
    header = laspy.LasHeader(point_format=6, version="1.4")
    header.add_extra_dims(
        [
            laspy.ExtraBytesParams("amp", "2u1", scales=np.array([1.0, 10.0]), offsets=np.zeros(2)),
            laspy.ExtraBytesParams(
                "pos", "3i2", scales=np.ones(3), offsets=np.array([1.0, 2.0, 3.0])
            ),
        ]
    )
    las = laspy.LasData(header)
    las.x, las.y, las.z = np.arange(100.0) % 10, np.arange(100.0) // 10, np.zeros(100)
    las.points.array["amp"] = np.tile([[0, 100]], (100, 1)).astype(np.uint8)
    las.points.array["pos"] = np.tile([[30000, -30000, 5]], (100, 1)).astype(np.int16)
    las.write(tmp_path / "in.las")
    cloud = read_points(tmp_path / "in.las")
    write_points(tmp_path / "out.las", cloud.points, cloud.fields, template=cloud)
    out = laspy.read(tmp_path / "out.las")
    for name in ("amp", "pos"):
        np.testing.assert_array_equal(out.points.array[name], las.points.array[name])
    too_big = dict(cloud.fields, amp=cloud.fields["amp"] * [1, 3])  # 3000 / 10 > 255
    with pytest.raises(ValueError, match=r"fields\['amp'\] cannot be stored in LAS"):
        write_points(tmp_path / "big.las", cloud.points, too_big, template=cloud)


def _evlr_at(data: bytes, offset: int) -> tuple[str, int, bytes]:
    """The user id, record id and data of the EVLR whose header starts at `offset`."""
    user_id = data[offset + 2 : offset + 18].rstrip(b"\0").decode()
    record_id = int.from_bytes(data[offset + 18 : offset + 20], "little")
    length = int.from_bytes(data[offset + 20 : offset + 28], "little")
    return user_id, record_id, data[offset + 60 : offset + 60 + length]


@pytest.mark.parametrize("ext", ["las", "laz"])
def test_las_14_waveform_packets_move_with_their_evlr(tmp_path, ext):
    # Byte 227 gives where the waveform packets' EVLR begins. It was copied from the
    # source while the EVLR moved (fewer points, compression): it pointed at other bytes.
    las = random_las("1.4", 4, 200, seed=3)
    packets = bytes(range(256)) * 8
    las.evlrs = VLRList(
        [laspy.VLR("other", 7, "before", b"x" * 17), laspy.VLR("LASF_Spec", 65535, "", packets)]
    )
    las.header.global_encoding.waveform_data_packets_internal = True
    las.write(tmp_path / "in.las")
    data = bytearray((tmp_path / "in.las").read_bytes())
    first_evlr = int.from_bytes(data[235:243], "little")
    data[227:235] = (first_evlr + 60 + 17).to_bytes(8, "little")  # laspy writes 0
    (tmp_path / "in.las").write_bytes(bytes(data))
    assert _evlr_at(data, first_evlr + 60 + 17) == ("LASF_Spec", 65535, packets)

    cloud = read_points(tmp_path / "in.las")
    keep = np.arange(len(cloud.points)) % 3 != 0
    fields = {name: values[keep] for name, values in cloud.fields.items()}
    write_points(tmp_path / f"out.{ext}", cloud.points[keep], fields, template=cloud)
    out = (tmp_path / f"out.{ext}").read_bytes()
    start = int.from_bytes(out[227:235], "little")
    assert start != first_evlr + 60 + 17  # the EVLR moved
    assert _evlr_at(out, start) == ("LASF_Spec", 65535, packets)
    assert out[6] & 2  # global encoding: the packets are in the file
    back = read_points(tmp_path / f"out.{ext}")
    np.testing.assert_array_equal(back.fields["wavepacket_offset"], fields["wavepacket_offset"])


def test_las_13_waveform_packets_not_carried_are_no_longer_claimed(tmp_path):
    # laspy does not read LAS 1.3's packets after the points, so they are not written:
    # the output's header said it held them, at the source's offset.
    random_las("1.3", 4, 100, seed=1).write(tmp_path / "in.las")
    data = bytearray((tmp_path / "in.las").read_bytes())
    data[227:235] = len(data).to_bytes(8, "little")
    data[6] |= 2  # global encoding: waveform data packets internal
    data += bytes(5 * 200)
    (tmp_path / "in.las").write_bytes(bytes(data))
    cloud = read_points(tmp_path / "in.las")
    with pytest.warns(UserWarning, match="waveform data packets .* are not written"):
        write_points(tmp_path / "out.las", cloud.points, cloud.fields, template=cloud)
    out = (tmp_path / "out.las").read_bytes()
    assert int.from_bytes(out[227:235], "little") == 0 and not out[6] & 2
    back = read_points(tmp_path / "out.las")
    np.testing.assert_array_equal(
        back.fields["wavepacket_offset"], cloud.fields["wavepacket_offset"]
    )


def test_extra_bytes_no_data_survives_a_write_in_the_files_layout(tmp_path):
    # laspy reads an extra-bytes field's "no data" into the Extra Bytes VLR only and
    # rebuilds that VLR from the fields when it writes: pcl-rg ground wrote files whose
    # -9999 markers then read as real heights of -99.99 m.
    from test_cli_downsample import no_data_las

    points = np.array([[0.0, 0.0, 0.0], [1.0, 1.0, 1.0]])
    amp = np.array([[-1.0, -1.0, -1.0], [1.0, 2.0, 3.0]])
    no_data_las(tmp_path / "in.las", points, np.array([-99.99, 1.5]), amp)
    cloud = read_points(tmp_path / "in.las").take(np.array([0]))
    for ext in ("las", "laz"):
        # Nothing but "no data" in the point left: laspy 2.7 fails to take its minimum.
        write_points(tmp_path / f"out.{ext}", cloud.points, cloud.fields, template=cloud)
        (record,) = [
            r
            for v in laspy.read(tmp_path / f"out.{ext}").header.vlrs
            for r in getattr(v, "extra_bytes_structs", ())
            if r.format_name() == "height"
        ]
        assert record.no_data.tolist() == [-9999]
