"""End-to-end tests of the pcl-rg command line, in-process (pcl_rg.cli.main) and as
real subprocesses (python -m pcl_rg and the pcl-rg console script)."""

from __future__ import annotations

import dataclasses
import errno
import inspect
import json
import os
import re
import sys
import typing
from pathlib import Path

import laspy
import numpy as np
import pytest
from conftest import fail_writes, run_command, run_pcl_rg, shared_data

import pcl_rg
import pcl_rg._grid_ground
import pcl_rg.cli as cli
import pcl_rg.cli._run as cli_run
from pcl_rg import datasets
from pcl_rg.datasets import load_isprs
from pcl_rg.evaluation import ground_errors
from pcl_rg.io import read_points, write_pcd, write_points

COMMANDS = ("ground", "denoise", "downsample", "segment", "pipeline", "evaluate", "info", "demo")


def run(capsys, *argv: object) -> tuple[int, str, str]:
    code = cli.main([os.fspath(a) if isinstance(a, Path) else str(a) for a in argv])
    captured = capsys.readouterr()
    return code, captured.out, captured.err


def run_json(capsys, *argv: object) -> dict:
    code, out, err = run(capsys, *argv, "--json", "-q")
    assert code == 0, err
    assert err == ""
    return json.loads(out)


# The lines of a stage that ran past the spinner's delay (a loaded machine): not errors.
SPINNER_LINE = re.compile(
    r"pcl-rg: .*( \.\.\.|: (done in|failed after|interrupted after) [\d.]+ s)"
)


def assert_one_error_line(err: str, *fragments: str) -> None:
    lines = [line for line in err.splitlines() if not SPINNER_LINE.fullmatch(line)]
    assert len(lines) == 1, err
    assert lines[0].startswith("pcl-rg: error: "), err
    assert "Traceback" not in err
    for fragment in fragments:
        assert fragment in lines[0], lines[0]


def raw(path) -> np.ndarray:
    with open(path, "rb") as stream:
        return laspy.read(stream, closefd=False).points.array


@pytest.fixture(scope="module")
def scene_las(tmp_path_factory) -> Path:
    """The synthetic scene as LAS 1.2 point format 3 with every dimension filled."""
    scene = datasets.synthetic_scene(seed=5, size=80.0, offset=(500_000.0, 5_000_000.0, 0.0))
    n = len(scene.points)
    rng = np.random.default_rng(8)
    header = laspy.LasHeader(version="1.2", point_format=3)
    header.scales = [0.01, 0.01, 0.01]
    header.offsets = [500_000.0, 5_000_000.0, 0.0]
    las = laspy.LasData(header)
    las.x, las.y, las.z = scene.points.T
    las.classification = scene.labels
    las.intensity = rng.integers(0, 65536, n)
    las.return_number = rng.integers(1, 4, n)
    las.number_of_returns = np.full(n, 3)
    las.gps_time = np.sort(rng.uniform(0, 1000, n))
    las.red, las.green, las.blue = rng.integers(0, 65536, (3, n))
    las.point_source_id = rng.integers(0, 10, n)
    las.user_data = rng.integers(0, 256, n)
    las.scan_angle_rank = rng.integers(-90, 91, n)
    path = tmp_path_factory.mktemp("scene") / "scene.las"
    las.write(path)
    return path


# ---------------------------------------------------------------- the surface


def test_help_lists_every_command(capsys):
    code, out, _ = run(capsys, "--help")
    assert code == 0
    for command in COMMANDS:
        assert f"\n    {command}" in out, command
    code, out, _ = run(capsys, "--version")
    assert code == 0 and pcl_rg.__version__ in out


def params_classes(command: str) -> list[type]:
    if command == "pipeline":
        return [pipeline_options()]
    return {
        "ground": [pcl_rg.GridGroundParams, pcl_rg.TinGroundParams],
        "denoise": [pcl_rg.StatisticalOutlierRemovalParams],
        "downsample": [pcl_rg.VoxelGridParams],
        "segment": [
            pcl_rg.RegionGrowingParams,
            pcl_rg.ConvexSegmentationParams,
            pcl_rg.pcl.RegionGrowingPclParams,
        ],
    }[command]


def pipeline_options() -> type:
    """seed004's keyword parameter objects (sor, voxel, region) as one dataclass."""
    from pcl_rg.pipeline import seed004

    hints = typing.get_type_hints(seed004)
    fields = []
    for name in inspect.signature(seed004).parameters:
        kinds = [t for t in typing.get_args(hints[name]) or (hints[name],) if t is not type(None)]
        if len(kinds) == 1 and dataclasses.is_dataclass(kinds[0]):
            fields.append((name, kinds[0]))
    assert [name for name, _ in fields] == ["sor", "voxel", "region"]
    return dataclasses.make_dataclass("Options", fields)


def leaves(cls: type, prefix: tuple[str, ...] = ()):
    """(path, field) of every field, the fields of nested parameter dataclasses flattened."""
    hints = typing.get_type_hints(cls)
    for f in dataclasses.fields(cls):
        if dataclasses.is_dataclass(hints[f.name]):
            yield from leaves(hints[f.name], prefix + (f.name,))
        else:
            yield prefix + (f.name,), f


@pytest.mark.parametrize("command", ["ground", "denoise", "downsample", "segment", "pipeline"])
def test_flags_come_from_the_dataclasses(capsys, command):
    code, out, _ = run(capsys, command, "--help")
    assert code == 0
    squeezed = "".join(out.split())
    expected = set()
    for cls in params_classes(command):
        for path, f in leaves(cls):
            flag = "--" + "-".join(path).replace("_", "-")
            expected.add(flag)
            assert f"{flag} " in out or f"{flag}\n" in out or f"{flag}," in out, flag
            assert "".join(f.metadata["help"].split()) in squeezed, f.name
    if command == "pipeline":
        expected.add("--no-sor")  # SOR runs by default; the switch turns it off
    # No flag without a field behind it.
    group = out.split("parameters:", 1)[1].split("\n\n", 1)[0]
    flags = {
        line.split()[0].rstrip(",") for line in group.splitlines() if line.strip().startswith("--")
    }
    assert flags == expected


def test_defaults_are_the_dataclass_defaults(capsys, tmp_path, scene_las):
    result = run_json(capsys, "denoise", scene_las, tmp_path / "d.las")
    assert result["parameters"] == dataclasses.asdict(pcl_rg.StatisticalOutlierRemovalParams())
    result = run_json(capsys, "ground", scene_las, tmp_path / "g.las", "--method", "tin")
    assert result["parameters"] == dataclasses.asdict(pcl_rg.TinGroundParams())
    result = run_json(capsys, "ground", scene_las, tmp_path / "g.las", "--block-size", "30,50")
    expected = dataclasses.asdict(pcl_rg.GridGroundParams(block_size=(30.0, 50.0)))
    assert result["parameters"] == {
        k: list(v) if isinstance(v, tuple) else v for k, v in expected.items()
    }


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
    before, after = raw(scene_las), raw(out)
    for name in before.dtype.names:
        if name != "raw_classification":
            np.testing.assert_array_equal(after[name], before[name], err_msg=name)
    assert written.header.point_format.id == 3 and str(written.header.version) == "1.2"
    # --drop writes exactly the ground points.
    run_json(capsys, "ground", scene_las, tmp_path / "only.las", *flags, "--drop")
    kept = np.flatnonzero(expected == 2)
    assert raw(tmp_path / "only.las").tobytes() == after[kept].tobytes()


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
    assert raw(tmp_path / "w.las").tobytes() == raw(tmp_path / "v.las").tobytes()
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


@pytest.mark.parametrize("sample", ["samp11", "samp51"])
@pytest.mark.parametrize("ext", ["pcd", "laz"])
def test_evaluate_isprs(capsys, tmp_path, sample, ext):
    full = shared_data("isprs", f"{sample}-utm.pcd")
    ground_only = shared_data("isprs", f"{sample}-utm-ground.pcd")
    run_json(capsys, "ground", full, tmp_path / f"pred.{ext}")
    report = run_json(capsys, "evaluate", tmp_path / f"pred.{ext}", "--isprs", full, ground_only)
    truth = load_isprs(full, ground_only)
    expected = ground_errors(truth.ground, pcl_rg.grid_ground(truth.points))
    for key in ("type_i", "type_ii", "total", "kappa"):
        assert report[key] == pytest.approx(getattr(expected, key)), key
    (a, b), (c, d) = expected.confusion.tolist()
    assert report["confusion"] == {
        "ground_as_ground": a,
        "ground_as_object": b,
        "object_as_ground": c,
        "object_as_object": d,
    }
    code, out, _ = run(capsys, "evaluate", tmp_path / f"pred.{ext}", "--isprs", full, ground_only)
    assert code == 0
    assert f"{100 * expected.type_i:.2f} %" in out and "kappa" in out


def test_evaluate_with_a_las_truth(capsys, tmp_path, scene_las):
    run_json(capsys, "ground", scene_las, tmp_path / "pred.las", "--cell-size", "1")
    truth = read_points(scene_las).classification
    predicted = read_points(tmp_path / "pred.las").classification
    scored = truth != 7
    report = run_json(capsys, "evaluate", tmp_path / "pred.las", "--truth", scene_las)
    expected = ground_errors(truth[scored] == 2, predicted[scored] == 2)
    assert report["kappa"] == pytest.approx(expected.kappa)
    assert report["excluded_noise"] == (~scored).sum()
    report = run_json(
        capsys, "evaluate", tmp_path / "pred.las", "--truth", scene_las, "--include-noise"
    )
    assert report["total"] == pytest.approx(ground_errors(truth == 2, predicted == 2).total)


def test_evaluate_refuses_other_points(capsys, tmp_path, scene_las):
    run_json(capsys, "ground", scene_las, tmp_path / "drop.las", "--drop")
    code, out, err = run(capsys, "evaluate", tmp_path / "drop.las", "--truth", scene_las)
    assert code == 2
    assert_one_error_line(err, "points but the truth has")
    source = read_points(scene_las)
    shifted = source.points + [0.0, 0.0, 1.0]
    write_points(tmp_path / "moved.las", shifted, source.fields, template=source)
    code, _, err = run(capsys, "evaluate", tmp_path / "moved.las", "--truth", scene_las)
    assert code == 2
    assert_one_error_line(err, "hold different points")
    write_points(tmp_path / "plain.ply", source.points)
    code, _, err = run(capsys, "evaluate", tmp_path / "plain.ply", "--truth", scene_las)
    assert_one_error_line(err, "has no classification field")
    code, _, err = run(capsys, "evaluate", scene_las)
    assert code == 2
    assert_one_error_line(err, "--truth FILE or --isprs")


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
    code, out, _ = run(capsys, "info", shared_data("mosd", "learn5.pcd"))
    assert code == 0
    invalid = int(
        (~np.isfinite(read_points(shared_data("mosd", "learn5.pcd")).points).all(axis=1)).sum()
    )
    assert f"{invalid:,} with NaN coordinates" in out and "label (uint32)" in out


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
    ]
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


# ------------------------------------------------------------------- failures


def bad_files(folder: Path, scene_las: Path) -> dict[str, tuple[Path, str]]:
    """Broken inputs and a fragment of the message each must give."""
    files = {}
    (folder / "text.las").write_text("1 2 3\n4 5 6\n")
    files["a .las that is text"] = (folder / "text.las", "not a LAS file")
    xyz = np.random.default_rng(0).uniform(0, 1, (50, 3))
    write_pcd(folder / "ok.pcd", xyz, encoding="binary")
    lying = (folder / "ok.pcd").read_bytes().replace(b"POINTS 50", b"POINTS 80")
    (folder / "lying.pcd").write_bytes(lying.replace(b"WIDTH 50", b"WIDTH 80"))
    files["a PCD whose header lies"] = (folder / "lying.pcd", "truncated")
    (folder / "bad.ply").write_bytes(b"ply\nformat ascii 1.0\nelement vertex two\nend_header\n")
    files["a PLY with a bad header"] = (folder / "bad.ply", "invalid PLY file")
    (folder / "empty.laz").write_bytes(b"")
    files["an empty file"] = (folder / "empty.laz", "file is empty")
    data = scene_las.read_bytes()
    (folder / "cut.las").write_bytes(data[: len(data) // 2])
    files["a truncated LAS"] = (folder / "cut.las", "invalid LAS/LAZ file")
    (folder / "cloud.obj").write_text("v 1 2 3\n")
    files["an unknown extension"] = (folder / "cloud.obj", "unknown extension")
    files["a missing file"] = (folder / "missing.las", "does not exist")
    (folder / "binary.xyz").write_bytes(bytes(range(200, 256)) * 10)
    files["binary data as .xyz"] = (folder / "binary.xyz", "not a XYZ text file")
    return files


@pytest.mark.parametrize("command", ["info", "ground", "denoise"])
def test_bad_files_give_one_error_line(capsys, tmp_path, scene_las, command):
    for what, (path, fragment) in bad_files(tmp_path, scene_las).items():
        argv = [command, path] + ([] if command == "info" else [tmp_path / "out.las"])
        code, out, err = run(capsys, *argv)
        assert code == 2, what
        assert_one_error_line(err, fragment)
        assert not (tmp_path / "out.las").exists(), what


@pytest.mark.parametrize(
    "argv, fragment",
    [
        (["denoise", "--mean-k", "0"], "argument --mean-k: mean_k must be >= 1, got 0"),
        (["denoise", "--mean-k", "1.5"], "argument --mean-k: invalid integer"),
        (["denoise", "--std-mul", "-1"], "std_mul must be >= 0"),
        (["downsample", "--leaf-size", "-1"], "leaf_size must be > 0"),
        (["downsample", "--leaf-size", "1,2"], "expected 1 or 3"),
        (["downsample"], "required: --leaf-size"),
        (["ground", "--slope", "steep"], "argument --slope: invalid number"),
        (["ground", "--slope", "nan"], "argument --slope: invalid number"),
        (["ground", "--method", "magic"], "invalid choice: 'magic'"),
        (["ground", "--cell-size", "50", "--block-size", "10"], "cell_size must be <= block_size"),
        (["segment", "--k", "2"], "argument --k: k must be >= 6"),
        (["segment", "--method", "curvature", "--k", "2"], "argument --k: k must be >= 3"),
        (["segment", "--smoothness-deg", "200"], "smoothness_deg must be in (0, 180)"),
        (["segment", "--method", "curvature", "--seed-measure", "bogus"],
         "seed_measure must be one of"),
        (["segment", "--method", "pcl", "--seed-measure", "mean"], "does not apply"),
        (["segment", "--k", "100000"], "k must be < the number of points"),
        (["denoise", "--unknown-flag"], "unrecognized arguments: --unknown-flag"),
    ],
)
def test_bad_parameters(capsys, tmp_path, scene_las, argv, fragment):
    command, *flags = argv
    code, out, err = run(capsys, command, scene_las, tmp_path / "out.las", *flags)
    assert code == 2
    assert_one_error_line(err, fragment)
    assert not (tmp_path / "out.las").exists()


def test_never_overwrites_the_input(capsys, tmp_path, scene_las):
    source = tmp_path / "in.las"
    source.write_bytes(scene_las.read_bytes())
    original = source.read_bytes()
    (tmp_path / "sym.las").symlink_to(source)
    os.link(source, tmp_path / "hard.las")
    os.mkdir(tmp_path / "sub")
    targets = [
        source,
        tmp_path / "sym.las",
        tmp_path / "hard.las",
        tmp_path / "sub" / ".." / "in.las",
    ]
    for target in targets:
        code, _, err = run(capsys, "ground", source, target)
        assert code == 2, target
        assert_one_error_line(err, "is the INPUT file")
    code, _, err = run(capsys, "ground", tmp_path / "sym.las", source)
    assert code == 2
    assert source.read_bytes() == original
    code, _, err = run(capsys, "ground", source, tmp_path / "nofolder" / "out.las")
    assert_one_error_line(err, "folder of OUTPUT")
    code, _, err = run(capsys, "ground", source, tmp_path / "sub")
    assert_one_error_line(err, "unknown extension")


@pytest.mark.parametrize("ext", ["las", "laz", "pcd", "ply", "xyz"])
def test_disk_full_leaves_no_partial_file(capsys, tmp_path, scene_las, monkeypatch, ext):
    target = tmp_path / f"out.{ext}"
    target.write_bytes(b"an older result")
    fail_writes(monkeypatch, 1000, OSError(errno.ENOSPC, os.strerror(errno.ENOSPC)))
    code, out, err = run(capsys, "ground", scene_las, target)
    assert code == 1
    assert_one_error_line(err, "cannot write", "No space left on device")
    assert target.read_bytes() == b"an older result"
    assert sorted(p.name for p in tmp_path.iterdir()) == [f"out.{ext}"]


def test_interrupt_leaves_no_partial_file(capsys, tmp_path, scene_las, monkeypatch):
    fail_writes(monkeypatch, 1000, KeyboardInterrupt())
    code, _, err = run(capsys, "denoise", scene_las, tmp_path / "out.laz")
    assert code == 130
    assert_one_error_line(err, "interrupted")
    assert list(tmp_path.iterdir()) == []
    monkeypatch.undo()

    def interrupted(*args, **kwargs):
        raise KeyboardInterrupt

    monkeypatch.setattr(pcl_rg, "grid_ground", interrupted)
    code, _, err = run(capsys, "ground", scene_las, tmp_path / "out.laz")
    assert code == 130 and list(tmp_path.iterdir()) == []


# ----------------------------------------------------------- real processes


def test_python_dash_m(tmp_path, scene_las):
    done = run_pcl_rg("info", scene_las, "--json")
    assert done.returncode == 0, done.stderr
    assert json.loads(done.stdout)["points"] == len(read_points(scene_las))
    done = run_pcl_rg("info", tmp_path / "none.las")
    assert done.returncode == 2
    assert_one_error_line(done.stderr, "does not exist")


def test_console_script(tmp_path, scene_las):
    script = Path(sys.executable).parent / "pcl-rg"
    assert script.exists(), f"the console script is not installed next to {sys.executable}"
    done = run_command(script, "ground", scene_las, tmp_path / "g.laz", "--drop")
    assert done.returncode == 0, done.stderr
    assert "ground" in done.stdout and "wrote" in done.stdout
    assert (read_points(tmp_path / "g.laz").classification == 2).all()
    (tmp_path / "bad.ply").write_bytes(b"ply\nformat ascii 1.0\n")
    done = run_command(script, "denoise", tmp_path / "bad.ply", tmp_path / "x.ply")
    assert done.returncode == 2
    assert_one_error_line(done.stderr, "invalid PLY file")
