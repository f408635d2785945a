"""pcl-rg evaluate end to end, in-process (pcl_rg.cli.main): ISPRS samples, a LAS truth,
and the clouds it refuses to compare."""

from __future__ import annotations

import numpy as np
import pytest
from cli_helpers import assert_one_error_line, run, run_json
from conftest import shared_data

import pcl_rg
from pcl_rg.datasets import load_isprs
from pcl_rg.evaluation import ground_errors
from pcl_rg.io import read_points, write_points


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


@pytest.mark.parametrize("ext", ["las", "pcd"])
def test_evaluate_leaves_out_rows_no_command_classified(capsys, tmp_path, scene_las, ext):
    # Withheld rows (and NaN ones) keep the class they came with, the truth's own here:
    # they were scored, and counted as right. A PCD prediction has no withheld flag:
    # the truth's tells.
    source = read_points(scene_las)
    withheld = np.zeros(len(source), bool)
    withheld[::7] = True
    fields = dict(source.fields, withheld=withheld.astype(np.uint8))
    write_points(tmp_path / "truth.las", source.points, fields, template=source)
    pred = tmp_path / f"pred.{ext}"
    run_json(capsys, "ground", tmp_path / "truth.las", pred, "--cell-size", "1")
    truth = read_points(tmp_path / "truth.las").classification
    predicted = read_points(pred).classification
    scored = (truth != 7) & ~withheld
    report = run_json(capsys, "evaluate", pred, "--truth", tmp_path / "truth.las")
    assert report["excluded_unprocessed"] == int(((truth != 7) & withheld).sum()) > 0
    assert report["scored"] == int(scored.sum())
    expected = ground_errors(truth[scored] == 2, predicted[scored] == 2)
    assert report["total"] == pytest.approx(expected.total)
    code, out, _ = run(capsys, "evaluate", pred, "--truth", tmp_path / "truth.las")
    assert code == 0 and "NaN or withheld points excluded" in out


@pytest.mark.parametrize("ids", [[0.0, 0.4, 0.9, 1.0, 1.0, 1.0], [0.0, 0.0, 0.0, np.nan, 1, 1]])
def test_evaluate_segments_refuses_predicted_ids_that_are_not_whole(capsys, tmp_path, ids):
    # 0.4 and 0.9 were cast to segment 0, NaN to "unassigned", without a word.
    points = np.random.default_rng(0).uniform(0.0, 1.0, (6, 3))
    write_points(tmp_path / "truth.pcd", points, {"label": np.array([1, 1, 1, 2, 2, 2], np.int32)})
    write_points(tmp_path / "pred.pcd", points, {"segment_id": np.array(ids, np.float32)})
    code, _, err = run(
        capsys, "evaluate", tmp_path / "pred.pcd", "--truth", tmp_path / "truth.pcd", "--segments"
    )
    assert code == 2
    assert_one_error_line(err, "PREDICTION's segment_id holds", "not whole numbers")


def test_evaluate_segments_takes_rows_with_nan_coordinates_as_unassigned(capsys, tmp_path):
    # An organized PCD's invalid points are NaN in every field: no command segments them,
    # and their NaN ids are no error.
    points = np.random.default_rng(0).uniform(0.0, 1.0, (6, 3))
    points[5] = np.nan
    ids = np.array([0.0, 0.0, 0.0, 1.0, 1.0, np.nan], np.float32)
    write_points(tmp_path / "truth.pcd", points, {"label": np.array([1, 1, 1, 2, 2, 0], np.int32)})
    write_points(tmp_path / "pred.pcd", points, {"segment_id": ids})
    report = run_json(
        capsys, "evaluate", tmp_path / "pred.pcd", "--truth", tmp_path / "truth.pcd", "--segments"
    )
    assert report["mean_iou"] == 1.0


@pytest.mark.parametrize(
    "flags, fragment",
    [
        (["--isprs", "ALL", "GROUND", "--include-noise"], "--include-noise has no effect with"),
        (["--truth", "T", "--segments", "--include-noise"], "--include-noise has no effect with"),
        (["--truth", "T", "--truth-field", "label"], "--truth-field names the truth's"),
    ],
)
def test_evaluate_refuses_flags_its_scoring_would_ignore(capsys, tmp_path, flags, fragment):
    # Each was ignored without a word: an ISPRS sample has no noise class, and segments
    # have no noise rule; a truth field means nothing to the ground scores.
    code, _, err = run(capsys, "evaluate", tmp_path / "pred.pcd", *flags)
    assert code == 2
    assert_one_error_line(err, fragment)


def test_evaluate_segments_writes_undefined_scores_as_a_dash(capsys, tmp_path):
    # A truth with no segment (every label 0) has no mean IoU: "-" as the ground report
    # writes an undefined kappa, not "nan".
    points = np.random.default_rng(0).uniform(0.0, 1.0, (6, 3))
    write_points(tmp_path / "truth.pcd", points, {"label": np.zeros(6, np.int32)})
    write_points(tmp_path / "pred.pcd", points, {"segment_id": np.zeros(6, np.int32)})
    argv = ["evaluate", tmp_path / "pred.pcd", "--truth", tmp_path / "truth.pcd", "--segments"]
    assert run_json(capsys, *argv)["mean_iou"] is None  # JSON has no NaN
    code, out, _ = run(capsys, *argv)
    assert code == 0
    assert "nan" not in out.lower()
    assert any(line.startswith("mean IoU") and line.split()[-1] == "-" for line in out.splitlines())
