"""pcl-rg on bad files and bad parameters: one error line, exit status 2, no partial or
overwritten file, also on a full disk or an interrupt."""

from __future__ import annotations

import errno
import os
from pathlib import Path

import numpy as np
import pytest
from cli_helpers import assert_one_error_line, run
from conftest import fail_writes

import pcl_rg
import pcl_rg._grid_ground
from pcl_rg.io import write_pcd

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


@pytest.mark.parametrize("command", ["ground", "denoise", "segment", "pipeline"])
def test_an_error_about_the_points_names_their_file(capsys, tmp_path, command):
    # A file that reads fine but whose points a step cannot take (three stray points
    # 1e15 m away: the grid or float32 frame cannot hold the extent, and the k-nearest-
    # neighbour steps leave out only 1 % of the points, at least one, as strays). The
    # step's message speaks of "points"; the user must also learn which input it was
    # (found by make fuzz).
    xyz = np.random.default_rng(0).uniform(0.0, 10.0, (200, 3))
    xyz[:3, 0] = 1e15
    write_pcd(tmp_path / "stray.pcd", xyz, encoding="binary")
    code, out, err = run(capsys, command, tmp_path / "stray.pcd", tmp_path / "out.pcd")
    assert code == 2
    assert_one_error_line(err, "points")
    assert f"(input {str(tmp_path / 'stray.pcd')!r})" in err
    assert not (tmp_path / "out.pcd").exists()


@pytest.mark.parametrize("argv", [["batch", "ground", "IN", "--out"], ["demo", "--output"]])
def test_an_empty_output_folder_is_refused(capsys, tmp_path, scene_las, argv, monkeypatch):
    # "" is the working folder to os.path (an unset shell variable, most often): the
    # tiles or the demo's files were written there, replacing any of the same names.
    monkeypatch.chdir(tmp_path)
    argv = [scene_las if word == "IN" else word for word in argv]
    code, _, err = run(capsys, *argv, "")
    assert code == 2
    assert_one_error_line(err, "an empty folder name")
    assert not os.listdir(tmp_path)


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
        (
            ["segment", "--method", "curvature", "--seed-measure", "bogus"],
            "seed_measure must be one of",
        ),
        (["segment", "--method", "pcl", "--seed-measure", "mean"], "does not apply"),
        (["segment", "--k", "100000"], "k must be < the number of points"),
        (["pipeline", "--sor-mean-k", "10000000"], "argument --sor-mean-k: sor_mean_k must be <"),
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


def test_a_figure_that_cannot_be_written_leaves_no_part_of_it(
    capsys, tmp_path, scene_las, monkeypatch
):
    # OUTPUT is written first; a figure that fails afterwards (disk full half-way through
    # the PNG) is a failure (exit 1), not a usage error, and leaves no partial PNG.
    from matplotlib.figure import Figure

    def savefig_then_fail(self, stream, **kwargs):
        stream.write(b"\x89PNG half a figure")
        raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))

    monkeypatch.setattr(Figure, "savefig", savefig_then_fail)
    code, out, err = run(
        capsys, "ground", scene_las, tmp_path / "g.las", "--plot", tmp_path / "top.png"
    )
    assert code == 1
    assert_one_error_line(err, f"cannot write figure '{tmp_path / 'top.png'}'", "No space left")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["g.las"]


def test_a_format_that_cannot_hold_a_field_fails_after_the_work_with_exit_1(capsys, tmp_path):
    # PLY has no 64-bit integers: found when OUTPUT is written, after the work, so a
    # failure (1), not a usage error (2), and no file.
    from pcl_rg.io import write_points

    points = np.random.default_rng(0).random((200, 3)) * 10
    write_points(tmp_path / "big.xyz", points, {"gps_id": np.arange(200) + 2**60})
    code, out, err = run(capsys, "denoise", tmp_path / "big.xyz", tmp_path / "out.ply")
    assert code == 1
    assert_one_error_line(err, "cannot write", "PLY has no 64-bit integers")
    assert not (tmp_path / "out.ply").exists()


# ------------------------------------------------------------- float classes


def _float_classes(path: Path, codes: np.ndarray, invalid_rows: int = 0) -> np.ndarray:
    points = np.random.default_rng(3).uniform(0, 50, (len(codes), 3)) * [1, 1, 0.05]
    points[:invalid_rows] = np.nan  # PCD's invalid points: NaN in every field
    write_pcd(path, points, {"classification": codes}, encoding="ascii")
    return points


def test_a_float_classification_that_is_not_class_codes(tmp_path, capsys, monkeypatch):
    codes = np.ones(300, np.float32)
    codes[5:8] = 2.7
    source = tmp_path / "in.pcd"
    _float_classes(source, codes)

    def never(*args, **kwargs):
        raise AssertionError("the algorithm ran")

    for name in ("grid_ground", "statistical_outlier_removal"):  # refused before the work
        monkeypatch.setattr(pcl_rg, name, never)
    for command in (["ground"], ["denoise", "--mean-k", "8"]):
        code, _, err = run(capsys, *command, source, tmp_path / "out.pcd")
        assert code == 2
        assert_one_error_line(
            err, "classification field is not class codes", "3 value(s)", "row 5: 2.7"
        )
        assert not (tmp_path / "out.pcd").exists()
    # info describes the file instead of refusing it
    code, out, _ = run(capsys, "info", source)
    assert code == 0
    assert "classes       none: " in out and "row 5: 2.7" in out


def test_float_class_codes_stay_as_the_file_has_them(tmp_path, capsys):
    # Whole numbers in a float column are class codes, kept in the file's dtype; NaN on
    # the invalid points (which no command works on) stays NaN.
    codes = np.full(300, 5.0, np.float32)
    codes[:4] = np.nan
    source = tmp_path / "in.pcd"
    _float_classes(source, codes, invalid_rows=4)
    code, _, err = run(capsys, "ground", source, tmp_path / "out.pcd", "--keep-classes")
    assert code == 0, err
    written = pcl_rg.io.read_points(tmp_path / "out.pcd").classification
    assert written.dtype == np.float32
    assert np.isnan(written[:4]).all()
    assert set(np.unique(written[4:])) <= {2.0, 5.0} and (written[4:] == 2.0).any()
    code, out, _ = run(capsys, "info", source)
    assert code == 0 and "classes       5: 296" in out


def test_nan_points_to_las_are_refused_before_the_work(tmp_path, capsys, monkeypatch):
    source = tmp_path / "in.pcd"
    _float_classes(source, np.ones(300, np.float32), invalid_rows=5)

    def never(*args, **kwargs):
        raise AssertionError("the filter ran")

    monkeypatch.setattr(pcl_rg, "grid_ground", never)
    code, _, err = run(capsys, "ground", source, tmp_path / "out.las")
    assert code == 2
    assert_one_error_line(err, "5 point(s) with NaN or Inf coordinates", "or pass --drop")
    assert not any(p.name.startswith("out") for p in tmp_path.iterdir())
    monkeypatch.undo()
    code, _, err = run(capsys, "ground", source, tmp_path / "out.las", "--drop")
    assert code == 0, err


def test_evaluate_segments_refuses_truth_ids_it_cannot_read(capsys, tmp_path):
    xyz = np.random.default_rng(0).uniform(0, 10, (40, 3))
    segment_id = np.repeat(np.arange(4, dtype=np.int32), 10)
    write_pcd(tmp_path / "pred.pcd", xyz, {"segment_id": segment_id}, encoding="binary")
    truths = {
        "negative ids": (np.where(segment_id == 3, -1, segment_id + 1), "negative ids at 10"),
        "NaN": (np.where(segment_id == 3, np.nan, 1.0), "not whole numbers"),
        "fractions": (segment_id + 0.5, "not whole numbers"),
    }
    for what, (label, fragment) in truths.items():
        write_pcd(tmp_path / "truth.pcd", xyz, {"label": label}, encoding="binary")
        code, out, err = run(
            capsys,
            "evaluate",
            tmp_path / "pred.pcd",
            "--segments",
            "--truth",
            tmp_path / "truth.pcd",
        )
        assert code == 2, what
        assert_one_error_line(err, "--truth-field 'label'", fragment)
    # Whole-number floats are ids like any other.
    write_pcd(tmp_path / "truth.pcd", xyz, {"label": segment_id + 1.0}, encoding="binary")
    code, out, err = run(
        capsys, "evaluate", tmp_path / "pred.pcd", "--segments", "--truth", tmp_path / "truth.pcd"
    )
    assert code == 0, err


@pytest.mark.filterwarnings("default::UserWarning")
def test_a_warning_is_one_line_and_the_work_goes_on(capsys, tmp_path, scene_las):
    data = bytearray(scene_las.read_bytes())
    count = int.from_bytes(data[107:111], "little")
    data[107:111] = (count - 5).to_bytes(4, "little")  # a damaged legacy point count
    (tmp_path / "short.las").write_bytes(bytes(data))
    code, out, err = run(capsys, "info", tmp_path / "short.las")
    assert code == 0, err
    assert err.splitlines() == [
        f"pcl-rg: warning: LAS file {str(tmp_path / 'short.las')!r}: the header counts "
        f"{count - 5} points, but the file holds room for 5 more records after them; only "
        "the counted points are read (is the header's point count damaged?)"
    ]


@pytest.mark.parametrize("command", ["ground", "denoise", "segment", "pipeline"])
def test_a_fifo_as_input_is_refused_not_waited_on(tmp_path, command):
    # Opening a FIFO blocks until a writer comes: the run hung for ever. A subprocess
    # with a timeout, so that a regression fails instead of hanging the suite.
    import subprocess
    import sys

    fifo = tmp_path / "pipe.las"
    os.mkfifo(fifo)
    result = subprocess.run(
        [sys.executable, "-m", "pcl_rg", command, str(fifo), str(tmp_path / "out.las")],
        capture_output=True,
        text=True,
        timeout=60,
    )
    assert result.returncode == 2
    assert_one_error_line(result.stderr, "is not a regular file")
    assert not (tmp_path / "out.las").exists()


@pytest.mark.parametrize("which", ["PREDICTION", "--truth", "--isprs ALL", "--isprs GROUND"])
def test_evaluate_refuses_a_fifo_instead_of_waiting_on_it(tmp_path, which):
    # evaluate read PREDICTION, --truth and --isprs files without the INPUT checks: a
    # FIFO among them hung for ever. A subprocess with a timeout, as above.
    import subprocess
    import sys

    points = np.random.default_rng(1).uniform(0.0, 10.0, (50, 3))
    classes = np.where(points[:, 2] < 5.0, 2, 1).astype(np.uint8)
    files = {}
    for name in ("prediction", "truth", "all", "ground"):
        files[name] = tmp_path / f"{name}.pcd"
        write_pcd(files[name], points, {"classification": classes})
    fifo = tmp_path / "pipe.pcd"
    os.mkfifo(fifo)
    key = {"PREDICTION": "prediction", "--truth": "truth", "--isprs ALL": "all"}
    files[key.get(which, "ground")] = fifo
    truth = (
        ["--truth", files["truth"]]
        if which in ("PREDICTION", "--truth")
        else ["--isprs", files["all"], files["ground"]]
    )
    result = subprocess.run(
        [sys.executable, "-m", "pcl_rg", "evaluate", files["prediction"], *truth],
        capture_output=True,
        text=True,
        timeout=60,
    )
    assert result.returncode == 2, result.stderr
    assert_one_error_line(result.stderr, which.split()[0], "is not a regular file")


@pytest.mark.parametrize(
    "line", ["1e308,0,-1e308,0", "0,-1e308,0,1e308", "1e308,1e308,-1e308,-1e308"]
)
def test_a_profile_line_too_long_for_a_float_is_refused_before_the_work(
    capsys, tmp_path, monkeypatch, line
):
    # Its length overflowed to inf: the run wrote OUTPUT, then the figure failed with
    # raw NumPy warnings and "Axis limits cannot be NaN or Inf".
    def no_work(*args, **kwargs):
        raise AssertionError("the work ran")

    monkeypatch.setattr(pcl_rg, "grid_ground", no_work)
    source = tmp_path / "in.xyz"
    pcl_rg.io.write_points(source, np.random.default_rng(2).uniform(0.0, 10.0, (100, 3)))
    argv = ["ground", source, tmp_path / "out.xyz", "--profile", tmp_path / "p.png"]
    code, out, err = run(capsys, *argv, "--profile-line", line)
    assert code == 2
    assert_one_error_line(err, "argument --profile-line", "length", "finite")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["in.xyz"]


@pytest.mark.parametrize("command", ["info", "ground", "info missing.las"])
@pytest.mark.parametrize("options", [[], ["--json"]])
def test_a_reader_that_stops_reading_is_no_error_of_the_run(tmp_path, scene_las, command, options):
    # `pcl-rg info FILE | true`: the broken pipe was reported as "cannot access" with
    # exit 2 (bad input), and with --json the error line raised again: two tracebacks.
    # The work is done when the run speaks: its exit status is the work's.
    import subprocess
    import sys

    words = command.split()
    argv = [words[0], words[1] if len(words) > 1 else str(scene_las)]
    if words[0] == "ground":
        argv.append(str(tmp_path / "out.las"))
    with subprocess.Popen(
        [sys.executable, "-m", "pcl_rg", *argv, *options],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        cwd=tmp_path,
    ) as process:
        process.stdout.close()  # nobody reads: the first write finds the pipe broken
        err = process.stderr.read().decode()
        code = process.wait(120)
    assert "Traceback" not in err and "cannot access" not in err, err
    assert code == (2 if "missing" in command else 0), err
    assert (tmp_path / "out.las").exists() == (words[0] == "ground")
