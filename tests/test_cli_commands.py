"""Each pcl-rg command end to end, in-process (pcl_rg.cli.main), on a synthetic LAS scene
and on the real samples."""

from __future__ import annotations

import dataclasses
import json
import os
import sys

import laspy
import numpy as np
import pytest
from cli_helpers import assert_one_error_line, run, run_json
from conftest import run_command, shared_data
from las_helpers import random_las, raw_points
from laspy.vlrs.vlrlist import VLRList

import pcl_rg
import pcl_rg._grid_ground
import pcl_rg.cli._run as cli_run
from pcl_rg.io import read_points, write_points

# -------------------------------------------------------------- the commands


def test_ground_classifies_and_keeps_every_dimension(capsys, tmp_path, scene_las):
    out = tmp_path / "ground.laz"
    flags = ["--slope", "0.5", "--cell-size", "1", "--min-seed-component", "10"]
    result = run_json(capsys, "ground", scene_las, out, *flags)
    source = read_points(scene_las)
    noise = source.classification == 7
    expected_ground = pcl_rg.grid_ground(
        source.points[~noise], slope=0.5, cell_size=1.0, min_seed_component=10
    )
    expected = source.classification.copy()
    expected[~noise] = np.where(expected_ground, 2, 1)
    written = read_points(out)
    np.testing.assert_array_equal(written.classification, expected)
    assert result["ground"] == expected_ground.sum() and result["points_out"] == len(source)
    assert result["skipped_noise"] == noise.sum()
    before, after = raw_points(scene_las), raw_points(out)
    for name in before.dtype.names:
        if name != "raw_classification":
            np.testing.assert_array_equal(after[name], before[name], err_msg=name)
    assert written.header.point_format.id == 3 and str(written.header.version) == "1.2"
    # --drop writes exactly the ground points.
    run_json(capsys, "ground", scene_las, tmp_path / "only.las", *flags, "--drop")
    kept = np.flatnonzero(expected == 2)
    assert raw_points(tmp_path / "only.las").tobytes() == after[kept].tobytes()


def test_ground_tin_and_method_flags(capsys, tmp_path, scene_las):
    flags = "--method tin --iteration-angle 12".split()
    result = run_json(capsys, "ground", scene_las, tmp_path / "t.ply", *flags)
    source = read_points(scene_las)
    noise = source.classification == 7
    ground = pcl_rg.tin_ground(source.points[~noise], iteration_angle=12.0)
    written = read_points(tmp_path / "t.ply")
    np.testing.assert_array_equal(written.classification[~noise], np.where(ground, 2, 1))
    assert result["method"] == "tin" and result["ground"] == ground.sum()
    code, _, err = run(
        capsys, "ground", scene_las, tmp_path / "x.las", "--method", "tin", "--slope", "0.3"
    )
    assert code == 2
    assert_one_error_line(err, "--slope does not apply to --method tin")
    assert not (tmp_path / "x.las").exists()


def as_json(params: object) -> object:
    return json.loads(json.dumps(cli_run.jsonable(dataclasses.asdict(params))))


@pytest.mark.parametrize(
    ("method", "cls", "preset", "field", "value"),
    [
        ("tin", pcl_rg.TinGroundParams, "lidar360", "iteration_angle", 12.0),
        ("grid", pcl_rg.GridGroundParams, "definition", "slope", 0.4),
    ],
)
def test_ground_presets(capsys, tmp_path, scene_las, method, cls, preset, field, value):
    base = getattr(cls, preset)()
    result = run_json(
        capsys, "ground", scene_las, tmp_path / "p.las", "--method", method, "--preset", preset
    )
    assert result["preset"] == preset
    assert result["parameters"] == as_json(base)
    # An explicit flag overrides one field of the preset; the rest stay the preset's.
    assert getattr(base, field) != value
    flag = "--" + field.replace("_", "-")
    result = run_json(
        capsys, "ground", scene_las, tmp_path / "p.las", "--method", method,
        "--preset", preset, flag, str(value),
    )  # fmt: skip
    expected = dataclasses.replace(base, **{field: value})
    assert result["parameters"] == as_json(expected)
    source = read_points(scene_las)
    noise = source.classification == 7
    ground = getattr(pcl_rg, f"{method}_ground")(source.points[~noise], params=expected)
    written = read_points(tmp_path / "p.las")
    np.testing.assert_array_equal(written.classification[~noise], np.where(ground, 2, 1))
    # Without --preset: the defaults, reported as no preset.
    assert run_json(capsys, "ground", scene_las, tmp_path / "p.las")["preset"] is None


def test_ground_unknown_preset_is_a_usage_error(capsys, tmp_path, scene_las):
    code, out, err = run(
        capsys, "ground", scene_las, tmp_path / "x.las", "--method", "grid", "--preset", "lidar360"
    )
    assert code == 2 and out == ""
    assert_one_error_line(
        err, "--preset: unknown preset 'lidar360' for --method grid", "valid: isprs, definition"
    )
    assert not (tmp_path / "x.las").exists()
    code, _, err = run(capsys, "ground", scene_las, tmp_path / "x.las", "--preset", "nope")
    assert code == 2
    assert_one_error_line(err, "(valid: isprs, definition)")


def test_progress_without_tqdm_is_a_plain_line(monkeypatch):
    import argparse
    import io
    import time

    class Terminal(io.StringIO):
        def isatty(self) -> bool:
            return True

    stream = Terminal()
    monkeypatch.setitem(sys.modules, "tqdm", None)  # tqdm is the optional `progress` extra
    monkeypatch.setattr(sys, "stderr", stream)
    monkeypatch.setattr(cli_run, "PROGRESS_DELAY", 0.0)
    job = cli_run.Run(argparse.Namespace(command="test"))
    with job.stage("work", "working"):
        time.sleep(0.2)
    lines = stream.getvalue().splitlines()
    assert lines[0] == "pcl-rg: working ..." and lines[1].startswith("pcl-rg: working: done in")


LIGHT_SCRIPT = """
import sys
from pcl_rg.cli import main
code = main(sys.argv[1:])
heavy = ("pcl_rg._core", "pcl_rg._pcl", "pcl_rg._grid_ground", "pcl_rg._tin_ground",
         "pcl_rg._region_growing", "matplotlib", "scipy")
print(code, *sorted(m for m in sys.modules if m.split(".")[0] in heavy or m in heavy))
"""


@pytest.mark.parametrize("argv", [["info", "FILE"], ["--help"], ["info", "FILE", "--json"]])
def test_help_and_info_import_no_algorithm(tmp_path, scene_las, argv):
    argv = [os.fspath(scene_las) if a == "FILE" else a for a in argv]
    done = run_command(sys.executable, "-c", LIGHT_SCRIPT, *argv, cwd=tmp_path)
    assert done.returncode == 0, done.stderr
    assert done.stdout.splitlines()[-1] == "0", done.stdout


def test_denoise(capsys, tmp_path, scene_las):
    result = run_json(
        capsys, "denoise", scene_las, tmp_path / "d.laz", "--mean-k", "8", "--std-mul", "2.5"
    )
    source = read_points(scene_las)
    inlier = pcl_rg.statistical_outlier_removal(source.points, mean_k=8, std_mul=2.5)
    written = read_points(tmp_path / "d.laz")
    assert (written.classification[~inlier] == 7).all()
    original = source.classification[inlier]
    np.testing.assert_array_equal(
        written.classification[inlier], np.where(original == 7, 1, original)
    )
    assert result["noise"] == (~inlier).sum()
    flags = "--mean-k 8 --std-mul 2.5 --drop".split()
    run_json(capsys, "denoise", scene_las, tmp_path / "kept.las", *flags)
    np.testing.assert_array_equal(read_points(tmp_path / "kept.las").points, source.points[inlier])


@pytest.mark.filterwarnings("default::pcl_rg.FarPointsWarning")
def test_a_record_at_the_origin_of_a_utm_tile_is_noise_and_no_segment(capsys, tmp_path, scene_las):
    # (0, 0, 0) lies 5,000 km from the tile, beyond float32's reach of its local origin:
    # both commands refused the file. The other points come out as without it, and
    # the run says that one point was left out.
    source = read_points(scene_las)
    fields = {k: np.concatenate([v, np.zeros_like(v[:1])]) for k, v in source.fields.items()}
    stray = tmp_path / "stray.las"
    write_points(stray, np.r_[source.points, [[0.0, 0.0, 0.0]]], fields, template=source)
    cases = (
        ("denoise", "classification", 7, "statistical_outlier_removal"),
        ("segment", "segment_id", -1, "convex_segmentation"),
    )
    for command, field, expected, step in cases:
        run_json(capsys, command, scene_las, tmp_path / f"{command}.las")
        argv = (command, stray, tmp_path / f"{command}-stray.las", "--json", "-q")
        code, _, err = run(capsys, *argv)
        assert code == 0, err
        assert err.startswith(
            f"pcl-rg: warning: {step}: 1 of {len(source) + 1:,} points lie more than"
        ), err
        assert len(err.splitlines()) == 1
        clean = read_points(tmp_path / f"{command}.las").fields[field]
        beside = read_points(tmp_path / f"{command}-stray.las").fields[field]
        np.testing.assert_array_equal(beside[:-1], clean)
        assert beside[-1] == expected


def test_downsample_centroids_and_attributes(capsys, tmp_path, scene_las):
    result = run_json(capsys, "downsample", scene_las, tmp_path / "v.las", "--leaf-size", "2")
    source = read_points(scene_las)
    grid = pcl_rg.voxel_grid(source.points, leaf_size=2.0)
    written = read_points(tmp_path / "v.las")
    assert result["voxels"] == len(grid.centroids) == len(written)
    assert np.abs(written.points - grid.centroids).max() <= 0.005 + 1e-9  # 1 cm storage
    # Attributes, recomputed voxel by voxel: first point's class, mean intensity and time.
    for voxel in np.random.default_rng(0).choice(len(grid.centroids), 50, replace=False):
        members = np.flatnonzero(grid.voxel_of_point == voxel)
        first = members.min()
        for name in ("classification", "return_number", "point_source_id", "user_data"):
            assert written.fields[name][voxel] == source.fields[name][first], name
        for name in ("intensity", "red", "gps_time"):
            mean = source.fields[name][members].astype(np.float64).mean()
            if source.fields[name].dtype.kind in "iu":
                mean = np.round(mean)
            assert written.fields[name][voxel] == pytest.approx(mean, rel=1e-12), name
    # One number or three: the same voxels.
    run_json(capsys, "downsample", scene_las, tmp_path / "w.las", "--leaf-size", "2,2,2")
    assert raw_points(tmp_path / "w.las").tobytes() == raw_points(tmp_path / "v.las").tobytes()
    flags = "--leaf-size 4,4,1 --min-points-per-voxel 3".split()
    run_json(capsys, "downsample", scene_las, tmp_path / "a.xyz", *flags)
    grid = pcl_rg.voxel_grid(source.points, leaf_size=(4, 4, 1), min_points_per_voxel=3)
    np.testing.assert_array_equal(read_points(tmp_path / "a.xyz").points, grid.centroids)


@pytest.mark.parametrize("method", ["curvature", "pcl"])
def test_segment(capsys, tmp_path, scene_las, method):
    run_json(capsys, "downsample", scene_las, tmp_path / "v.laz", "--leaf-size", "1")
    flags = "--k 12 --min-cluster-size 30".split()
    result = run_json(
        capsys, "segment", tmp_path / "v.laz", tmp_path / "s.laz", "--method", method, *flags
    )
    source = read_points(tmp_path / "v.laz")
    function = pcl_rg.region_growing if method == "curvature" else pcl_rg.pcl.region_growing
    labels = function(source.points, k=12, min_cluster_size=30)
    written = read_points(tmp_path / "s.laz")
    assert written.fields["segment_id"].dtype == np.int32
    assert "segment_id" in written.header.point_format.extra_dimension_names
    np.testing.assert_array_equal(written.fields["segment_id"], labels)
    assert result["segments"] == len(np.unique(labels[labels >= 0]))
    flags = "--k 12 --min-cluster-size 30 --drop".split()
    run_json(
        capsys, "segment", tmp_path / "v.laz", tmp_path / "only.laz", "--method", method, *flags
    )
    np.testing.assert_array_equal(
        read_points(tmp_path / "only.laz").fields["segment_id"], labels[labels >= 0]
    )


def test_segment_replaces_another_tools_unsigned_segment_id(capsys, tmp_path, scene_las):
    # An earlier tool's uint16 segment_id cannot hold -1: the int32 one replaces it.
    las = laspy.read(scene_las)
    las.add_extra_dim(laspy.ExtraBytesParams(name="segment_id", type="u2"))
    las.write(tmp_path / "u16.las")
    run_json(capsys, "segment", tmp_path / "u16.las", tmp_path / "s.las", "--method", "curvature")
    written = read_points(tmp_path / "s.las")
    assert written.fields["segment_id"].dtype == np.int32
    assert (written.fields["segment_id"] == -1).any()
    assert list(written.header.point_format.extra_dimension_names) == ["segment_id"]


def test_segment_mosd_pcd_and_evaluate(capsys, tmp_path):
    source_path = shared_data("mosd", "learn0.pcd")
    out = tmp_path / "seg.pcd"
    flags = "--method curvature --k 15 --curvature-threshold 100 --smoothness-deg 8".split()
    result = run_json(capsys, "segment", source_path, out, *flags)
    source = read_points(source_path)
    valid = np.isfinite(source.points).all(axis=1)
    labels = pcl_rg.region_growing(
        source.points[valid], k=15, curvature_threshold=100.0, smoothness_deg=8.0
    )
    written = read_points(out)
    assert (written.header.width, written.header.height) == (640, 480)  # still organized
    np.testing.assert_array_equal(written.fields["segment_id"][valid], labels)
    assert (written.fields["segment_id"][~valid] == -1).all()
    np.testing.assert_array_equal(written.fields["label"], source.fields["label"])
    assert result["segments"] == len(np.unique(labels[labels >= 0]))
    # Scored against mOSD's labels: the numbers of evaluation.segmentation_scores.
    from pcl_rg.evaluation import segmentation_scores  # evaluation re-exports it

    scores = segmentation_scores(
        source.fields["label"].astype(np.int64), written.fields["segment_id"].astype(np.int64)
    )
    report = run_json(capsys, "evaluate", out, "--segments", "--truth", source_path)
    assert report["mean_iou"] == pytest.approx(scores.mean_iou)
    assert report["over_segmented"] == scores.over_segmented
    assert report["under_segmented"] == scores.under_segmented
    # The tutorial cloud with PCL's method, as PLY.
    tutorial = shared_data("pcl", "region_growing_tutorial.pcd")
    flags = "--method pcl --k 30 --smoothness-deg 3 --curvature-threshold 1".split()
    result = run_json(capsys, "segment", tutorial, tmp_path / "tutorial.ply", *flags)
    cloud = read_points(tutorial)
    labels = pcl_rg.pcl.region_growing(
        cloud.points, k=30, smoothness_deg=3.0, curvature_threshold=1.0
    )
    np.testing.assert_array_equal(
        read_points(tmp_path / "tutorial.ply").fields["segment_id"], labels
    )


def test_pipeline(capsys, tmp_path, scene_las):
    from pcl_rg.pipeline import seed004

    flags = "--sor-mean-k 10 --voxel-leaf-size 1 --region-k 12".split()
    result = run_json(capsys, "pipeline", scene_las, tmp_path / "p.laz", *flags)
    source = read_points(scene_las)
    expected = seed004(
        source.points,
        sor=pcl_rg.StatisticalOutlierRemovalParams(mean_k=10),
        voxel=pcl_rg.VoxelGridParams(leaf_size=1.0),
        region=pcl_rg.RegionGrowingParams(k=12),
    )
    written = read_points(tmp_path / "p.laz")
    assert len(written) == len(source)
    np.testing.assert_array_equal(written.fields["segment_id"], expected.labels)
    assert (written.classification[~expected.inlier] == 7).all()
    assert result["segments"] == len(np.unique(expected.labels[expected.labels >= 0]))
    assert [s["name"] for s in result["stages"]] == [s.name for s in expected.report.stages]
    assert result["parameters"]["voxel"] == {
        "leaf_size": [1.0, 1.0, 1.0],
        "min_points_per_voxel": 1,
    }
    # Without SOR and voxel grid: region growing on every point; classes untouched.
    flags = "--no-sor --no-auto-voxel --region-k 12".split()
    run_json(capsys, "pipeline", scene_las, tmp_path / "q.laz", *flags)
    expected = seed004(
        source.points, sor=None, region=pcl_rg.RegionGrowingParams(k=12), auto_voxel=False
    )
    written = read_points(tmp_path / "q.laz")
    np.testing.assert_array_equal(written.fields["segment_id"], expected.labels)
    np.testing.assert_array_equal(written.classification, source.classification)
    # Without a leaf size the grid's leaf comes from the data, and the report says which:
    # none on this airborne tile (its trees are no sensor noise), one on a dense noisy scan.
    result = run_json(capsys, "pipeline", scene_las, tmp_path / "r.laz", "--no-sor")
    expected = seed004(source.points, sor=None)
    np.testing.assert_array_equal(
        read_points(tmp_path / "r.laz").fields["segment_id"], expected.labels
    )
    assert result["stages"][0]["name"] == "normals"
    rng = np.random.default_rng(9)
    scan = np.column_stack([rng.uniform(0, 0.5, (60000, 2)), rng.normal(0, 6e-4, 60000)])
    write_points(tmp_path / "scan.ply", scan)
    result = run_json(capsys, "pipeline", tmp_path / "scan.ply", tmp_path / "s.ply", "--no-sor")
    assert result["stages"][0]["name"].startswith("voxel grid (auto leaf ")
    code, _, err = run(
        capsys, "pipeline", scene_las, tmp_path / "x.laz", "--no-sor", "--sor-std-mul", "2"
    )
    assert code == 2
    assert_one_error_line(err, "--sor-std-mul cannot be combined with --no-sor")
    code, _, err = run(
        capsys, "pipeline", scene_las, tmp_path / "x.laz", "--voxel-min-points-per-voxel", "2"
    )
    assert code == 2
    assert_one_error_line(err, "required: --voxel-leaf-size")


def test_info(capsys, tmp_path, scene_las):
    report = run_json(capsys, "info", scene_las)
    source = read_points(scene_las)
    assert report["format"] == "las" and report["points"] == len(source)
    np.testing.assert_allclose(report["bounds"]["min"], source.points.min(axis=0))
    np.testing.assert_allclose(report["bounds"]["max"], source.points.max(axis=0))
    codes, counts = np.unique(source.classification, return_counts=True)
    assert report["classes"] == {str(c): int(k) for c, k in zip(codes, counts)}
    assert report["las"]["point_format"] == 3 and report["las"]["version"] == "1.2"
    assert set(report["fields"]) == set(source.fields)
    las = laspy.read(scene_las)
    las.header.offsets = [512345.678, 5412345.25, -0.125]  # %g showed 512346 5.41235e+06
    las.write(tmp_path / "offsets.las")
    _, out, _ = run(capsys, "info", tmp_path / "offsets.las")
    assert "offset        512345.678 5412345.25 -0.125\n" in out and "scale         0.01 " in out
    code, out, _ = run(capsys, "info", shared_data("mosd", "learn5.pcd"))
    assert code == 0
    invalid = int(
        (~np.isfinite(read_points(shared_data("mosd", "learn5.pcd")).points).all(axis=1)).sum()
    )
    assert f"{invalid:,} with NaN or Inf coordinates" in out and "label (uint32)" in out


def test_info_lists_the_vlrs_and_evlrs(capsys, tmp_path):
    # Only the VLRs' class names were listed ("VLR"), and no EVLR: not which records,
    # by whom, nor how large (a waveform EVLR can be most of a file). The listing comes
    # from the records' headers in the file: laspy re-encodes the records it knows, and
    # one (COPC's info) it cannot encode at all.
    las = random_las("1.4", 9, 50, seed=3)
    las.header.vlrs.append(laspy.VLR("copc", 1, "copc info", bytes(160)))
    las.evlrs = VLRList(
        [
            laspy.VLR("other", 7, "PLACEHOLDER", b"x" * 17),
            laspy.VLR("LASF_Spec", 65535, "", b"y" * 1000),
        ]
    )
    las.write(tmp_path / "records.las")
    data = (tmp_path / "records.las").read_bytes()
    # A description that is not ASCII, with an escape sequence in it.
    data = data.replace(b"PLACEHOLDER", b"H\xc3\xb6he \x1b[2J!")  # as long: 11 bytes
    (tmp_path / "records.las").write_bytes(data)
    report = run_json(capsys, "info", tmp_path / "records.las")
    assert [(r["user_id"], r["record_id"], r["bytes"]) for r in report["las"]["vlrs"]] == [
        ("LASF_Spec", 4, 768),  # the extra bytes: four fields of 192 bytes
        ("pcl_rg_test", 42, 37),
        ("copc", 1, 160),
    ]
    assert report["las"]["evlrs"] == [
        {"user_id": "other", "record_id": 7, "description": "H\u00f6he \x1b[2J!", "bytes": 17},
        {"user_id": "LASF_Spec", "record_id": 65535, "description": "", "bytes": 1000},
    ]
    _, out, _ = run(capsys, "info", tmp_path / "records.las")
    assert (
        "evlr          other 7 (H\u00f6he ?[2J!, 17 bytes)\n" in out
    )  # no escape reaches a terminal
    assert "evlr          LASF_Spec 65535 (no description, 1,000 bytes)\n" in out
    # LAZ: LASzip's own VLR, which laspy hides, is in the file and in the list.
    random_las("1.4", 6, 50, seed=4).write(tmp_path / "records.laz")
    report = run_json(capsys, "info", tmp_path / "records.laz")
    assert ("laszip encoded", 22204) in [
        (r["user_id"], r["record_id"]) for r in report["las"]["vlrs"]
    ]


def test_plots(capsys, tmp_path, scene_las):
    source = read_points(scene_las)
    x0, y0 = source.points[:, :2].min(axis=0)
    result = run_json(
        capsys,
        "ground",
        scene_las,
        tmp_path / "g.las",
        "--plot",
        tmp_path / "top.png",
        "--profile",
        tmp_path / "side.png",
        "--profile-line",
        f"{x0},{y0 + 40},{x0 + 80},{y0 + 40}",
        "--profile-width",
        "3",
    )
    for name in ("top.png", "side.png"):
        assert (tmp_path / name).read_bytes()[:4] == b"\x89PNG"
    along = np.abs(source.points[:, 1] - (y0 + 40)) <= 1.5
    assert result["profile_points"] == int(along.sum())
    run_json(capsys, "info", scene_las, "--plot", tmp_path / "info.png")
    assert (tmp_path / "info.png").exists()
    bad_plots = [
        (["--plot", tmp_path / "a.jpg"], ["must end in .png"]),
        (
            ["--profile", tmp_path / "a.png", "--profile-line", "1,2,3"],
            ["--profile-line", "expected 4 numbers"],
        ),
        (
            ["--profile", tmp_path / "a.png", "--profile-width", "0"],
            ["--profile-width: must be > 0"],
        ),
        (  # one would silently replace the other
            ["--plot", tmp_path / "a.png", "--profile", f"{tmp_path}/./a.png"],
            ["are the same file"],
        ),
        (  # found before any work, not after OUTPUT is written
            ["--profile", tmp_path / "a.png", "--profile-line", "1,2,1,2"],
            ["--profile-line", "must differ"],
        ),
        (["--plot", tmp_path / "folder.png"], ["is a folder"]),
    ]
    (tmp_path / "folder.png").mkdir()
    for flags, words in bad_plots:
        code, _, err = run(capsys, "ground", scene_las, tmp_path / "x.las", *flags)
        assert code == 2
        assert_one_error_line(err, *words)
    assert not (tmp_path / "x.las").exists()


def test_json_quiet_and_progress(capsys, tmp_path, scene_las, monkeypatch):
    code, out, err = run(capsys, "denoise", scene_las, tmp_path / "d.las", "--json")
    assert code == 0
    result = json.loads(out)  # exactly one JSON object on stdout
    assert result["command"] == "denoise" and result["output"] == str(tmp_path / "d.las")
    assert set(result["timings_s"]) >= {"read", "denoise", "write", "total"}
    monkeypatch.setattr(cli_run, "PROGRESS_DELAY", 0.0)
    code, out, err = run(capsys, "denoise", scene_las, tmp_path / "d.las")
    assert code == 0
    for stage in ("reading", "statistical outlier removal", "writing"):
        assert f"pcl-rg: {stage}" in err, err
    assert "wrote" in out and "noise" in out
    code, out, err = run(capsys, "denoise", scene_las, tmp_path / "d.las", "--quiet")
    assert code == 0 and err == ""
    # A failure with --json: the one error line on stderr, and a JSON object on stdout.
    code, out, err = run(
        capsys, "denoise", scene_las, tmp_path / "d.las", "--mean-k", "0", "--json"
    )
    assert code == 2
    assert_one_error_line(err, "mean_k must be >= 1")
    assert json.loads(out) == {"error": err.strip()[len("pcl-rg: error: ") :], "exit_status": 2}
