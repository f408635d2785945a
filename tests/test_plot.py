"""Tests of pcl_rg.plot: top views by class, segment and height, and vertical profiles."""

from __future__ import annotations

import matplotlib.image
import numpy as np
import pytest
from matplotlib.colors import to_rgb
from plot_helpers import read_saved_figures

from pcl_rg.plot import CLASS_COLOURS, profile, segment_colours, top_view


def pixels(path) -> np.ndarray:
    """RGB pixels of a PNG as uint8, (H*W, 3)."""
    image = matplotlib.image.imread(path)
    return np.round(image[..., :3] * 255).astype(np.uint8).reshape(-1, 3)


def has_colour(rgb: np.ndarray, colour: str, tolerance: int = 2) -> bool:
    target = np.round(np.array(to_rgb(colour)) * 255)
    return bool((np.abs(rgb.astype(int) - target).max(axis=1) <= tolerance).any())


def scene(n: int = 4000, seed: int = 0) -> tuple[np.ndarray, np.ndarray]:
    rng = np.random.default_rng(seed)
    xyz = np.column_stack([rng.uniform(0, 50, n), rng.uniform(0, 50, n), rng.uniform(0, 5, n)])
    classes = np.where(xyz[:, 0] < 25, 2, 1)
    return xyz, classes


def test_top_view_by_class(tmp_path):
    xyz, classes = scene()
    path = tmp_path / "classes.png"
    top_view(xyz + [5e5, 5e6, 0], path, classes=classes, title="two classes")
    rgb = pixels(path)
    assert has_colour(rgb, CLASS_COLOURS[2][1]) and has_colour(rgb, CLASS_COLOURS[1][1])
    # A class colour that is not in the data does not appear.
    assert not has_colour(rgb, CLASS_COLOURS[5][1])
    names = {1: ("object", "#00ff00")}
    top_view(xyz, tmp_path / "renamed.png", classes=classes, class_names=names)
    assert has_colour(pixels(tmp_path / "renamed.png"), "#00ff00")


def test_top_view_by_segment_and_height(tmp_path):
    xyz, _ = scene()
    segments = (xyz[:, 0] // 10).astype(np.int64) - 1  # -1 (unassigned) .. 3
    top_view(xyz, tmp_path / "segments.png", segments=segments)
    rgb = pixels(tmp_path / "segments.png")
    for colour in segment_colours(np.arange(4)):
        assert has_colour(rgb, tuple(colour[:3]), tolerance=3)
    top_view(xyz, tmp_path / "height.png", max_points=500)
    assert (tmp_path / "height.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def test_segment_colours():
    labels = np.array([0, 1, 2, 19, 20, -1, -7, 0])
    colours = segment_colours(labels)
    assert colours.shape == (8, 4)
    np.testing.assert_array_equal(colours[0], colours[7])  # same label, same colour
    np.testing.assert_array_equal(colours[0], colours[4])  # the palette repeats after 20
    np.testing.assert_array_equal(colours[5], colours[6])  # every negative label is grey
    distinct = {tuple(c) for c in segment_colours(np.arange(20))}
    assert len(distinct) == 20 and tuple(colours[5]) not in distinct
    with pytest.raises(TypeError, match="integer"):
        segment_colours([0.5, 1.0])


def test_profile_selects_the_corridor(tmp_path):
    rng = np.random.default_rng(3)
    xyz = np.column_stack(
        [rng.uniform(0, 100, 20000), rng.uniform(0, 100, 20000), rng.uniform(0, 10, 20000)]
    )
    start, end, width = (10.0, 20.0), (80.0, 70.0), 3.0
    classes = rng.integers(1, 3, 20000)
    n = profile(xyz, tmp_path / "p.png", start, end, width=width, classes=classes)
    # Independent count: distance to the segment's line and projection onto it.
    a, b = np.array(start), np.array(end)
    d = (b - a) / np.linalg.norm(b - a)
    t = (xyz[:, :2] - a) @ d
    rel = xyz[:, :2] - a
    perp = np.abs(d[0] * rel[:, 1] - d[1] * rel[:, 0])
    expected = int(((perp <= width / 2) & (t >= 0) & (t <= np.linalg.norm(b - a))).sum())
    assert n == expected
    # Uniform density: about width * length / area of the points.
    assert abs(n - 20000 * width * np.linalg.norm(b - a) / 100**2) < 0.1 * n
    rgb = pixels(tmp_path / "p.png")
    assert has_colour(rgb, CLASS_COLOURS[2][1]) and has_colour(rgb, CLASS_COLOURS[1][1])
    segments = (xyz[:, 2] > 5).astype(np.int64)
    assert profile(xyz, tmp_path / "s.png", start, end, width=width, segments=segments) == n
    # A line away from the cloud: an empty figure, 0 points.
    assert profile(xyz, tmp_path / "e.png", (200, 200), (300, 200)) == 0
    assert (tmp_path / "e.png").exists()


@pytest.mark.parametrize(
    "kwargs, error, message",
    [
        ({"start": (1, 1), "end": (1, 1)}, ValueError, "start and end must differ"),
        ({"width": 0.0}, ValueError, "width must be > 0"),
        ({"start": (1, 2, 3)}, ValueError, "start must be 2 finite numbers"),
        ({"end": (np.nan, 2)}, ValueError, "end must be 2 finite numbers"),
        ({"classes": np.zeros(3, int)}, ValueError, "one entry per point"),
        ({"segments": np.zeros(10)}, TypeError, "integer array"),
        ({"vertical_exaggeration": -1}, ValueError, "vertical_exaggeration must be > 0"),
        # Cast to float64, a complex end lost its imaginary part with only a warning.
        ({"start": np.array([1 + 1j, 5])}, TypeError, "start must be real numbers"),
        ({"end": "ab"}, TypeError, "end must be real numbers"),
        # NumPy reads (True, 5) as the integers [1, 5].
        ({"start": (True, 5)}, TypeError, "start must be real numbers.*a bool"),
        ({"end": [np.True_, 5.0]}, TypeError, "end must be real numbers.*a bool"),
        ({"end": [np.array(True), 5.0]}, TypeError, "end must be real numbers.*a bool"),
        # b - a overflows: the figure failed in matplotlib on an infinite axis.
        ({"start": (-1e308, 5), "end": (1e308, 5)}, ValueError, "too far apart"),
        ({"classes": np.full((2, 5), 2)}, ValueError, "classes must be one-dimensional"),
        ({"classes": np.full(10, 2), "class_names": {2: "ground"}}, TypeError, "class_names"),
    ],
)
def test_profile_errors(tmp_path, kwargs, error, message):
    xyz, _ = scene(10)
    arguments = {"start": (0, 0), "end": (10, 10), **kwargs}
    with pytest.raises(error, match=message):
        profile(xyz, tmp_path / "x.png", **arguments)
    assert not (tmp_path / "x.png").exists()


def test_top_view_errors(tmp_path):
    xyz, _ = scene(10)
    with pytest.raises(ValueError, match="one entry per point"):
        top_view(xyz, tmp_path / "x.png", classes=np.zeros(4, int))
    with pytest.raises(TypeError, match="integer array"):
        top_view(xyz, tmp_path / "x.png", classes=np.zeros(10))
    with pytest.raises(ValueError, match="NaN"):
        top_view(np.full((3, 3), np.nan), tmp_path / "x.png")
    # Flattened, these passed as one label per point.
    with pytest.raises(ValueError, match="classes must be one-dimensional"):
        top_view(xyz, tmp_path / "x.png", classes=np.full((2, 5), 2))
    with pytest.raises(ValueError, match="segments must be one-dimensional"):
        top_view(xyz, tmp_path / "x.png", segments=np.zeros((10, 1), int))
    # A bare label, not a (label, colour) pair: "too many values to unpack" mid-drawing.
    with pytest.raises(TypeError, match="class_names must map class codes"):
        top_view(xyz, tmp_path / "x.png", classes=np.full(10, 2), class_names={2: "ground"})
    assert not (tmp_path / "x.png").exists()
    with pytest.raises(ValueError, match="labels must be one-dimensional"):
        segment_colours(np.array([[0, 1], [2, 3]]))


def legend_of(monkeypatch, draw) -> list[str]:
    """The legend texts of the figure `draw()` saves."""
    seen = read_saved_figures(
        monkeypatch, lambda fig: [t.get_text() for t in fig.axes[0].get_legend().get_texts()]
    )
    draw()
    return [text for texts in seen for text in texts]


def test_legends_count_every_point_not_the_drawn_subsample(tmp_path, monkeypatch):
    # The counts were those of the drawn subsample: "ground (399,973)" for 999,950
    # ground points, and a rare class could drop out of the legend.
    xyz, _ = scene(20_000)
    classes = np.full(len(xyz), 2)
    classes[:3] = 7
    texts = legend_of(
        monkeypatch, lambda: top_view(xyz, tmp_path / "c.png", classes=classes, max_points=500)
    )
    assert texts == ["ground (19,997)", "noise (3)"]
    segments = np.arange(len(xyz)) % 40 - 1  # -1: unassigned, every 40th point
    line = {"start": (0.0, 25.0), "end": (50.0, 25.0), "width": 10.0}
    inside = np.abs(xyz[:, 1] - 25.0) <= 5.0
    texts = legend_of(
        monkeypatch,
        lambda: profile(xyz, tmp_path / "p.png", segments=segments, max_points=300, **line),
    )
    assert texts == [
        f"unassigned ({int((segments[inside] < 0).sum()):,})",
        f"{len(np.unique(segments[inside & (segments >= 0)]))} segments (one colour each, "
        "repeating)",
    ]


def test_every_class_in_a_legend_has_a_colour_of_its_own(tmp_path, monkeypatch):
    # Low vegetation (3) took building's blue from matplotlib's cycle, and class 17 the
    # cycle's next colour: two legend entries alike.
    xyz, _ = scene(1200)
    classes = np.repeat([1, 2, 3, 6, 17, 40, 41], [300, 300, 150, 150, 100, 100, 100])
    seen = read_saved_figures(
        monkeypatch,
        lambda fig: [to_rgb(h.get_color()) for h in fig.axes[0].get_legend().legend_handles],
    )
    top_view(xyz, tmp_path / "c.png", classes=classes)
    (colours,) = seen
    assert len(colours) == 7 and len(set(colours)) == 7


def axis_labels(monkeypatch, draw) -> list[str]:
    """The axis labels (and a colour bar's) of the figure `draw` writes, and its title."""
    seen = read_saved_figures(
        monkeypatch,
        lambda fig: [
            text for ax in fig.axes for text in (ax.get_xlabel(), ax.get_ylabel(), ax.get_title())
        ],
    )
    draw()
    return [text for texts in seen for text in texts]


def test_axes_name_the_points_units(tmp_path, monkeypatch):
    # Figures of feet data said "x (m)" and "corridor 10 m".
    xyz, _ = scene(500)
    assert axis_labels(monkeypatch, lambda: top_view(xyz, tmp_path / "t.png"))[:2] == [
        "x (m)",
        "y (m)",
    ]
    labels = axis_labels(monkeypatch, lambda: top_view(xyz, tmp_path / "t.png", units="US ft"))
    assert labels[:2] == ["x (US ft)", "y (US ft)"] and "z (US ft)" in labels  # colour bar
    labels = axis_labels(
        monkeypatch,
        lambda: profile(xyz, tmp_path / "p.png", (0, 25), (50, 25), width=10, units=("ft", "m")),
    )
    assert labels[:2] == ["distance along the line from A (ft)", "z (m)"]
    assert "corridor 10 ft" in labels[2]
    for bad in ("", ("ft",), ("ft", "m", "m"), 3, ("ft", None)):
        with pytest.raises(ValueError, match="units must be"):
            top_view(xyz, tmp_path / "t.png", units=bad)


def test_masked_labels_are_refused_and_an_empty_list_is_no_labels(tmp_path):
    # The masked rows were drawn with their hidden labels; [] was "dtype float64".
    xyz, classes = scene(10)
    masked = np.ma.array(classes, mask=np.arange(10) < 3)
    with pytest.raises(ValueError, match="classes: masked arrays are not accepted"):
        top_view(xyz, tmp_path / "t.png", classes=masked)
    with pytest.raises(ValueError, match="labels: masked arrays are not accepted"):
        segment_colours(masked)
    assert segment_colours([]).shape == (0, 4)
    top_view(np.empty((0, 3)), tmp_path / "e.png", segments=[])
    assert (tmp_path / "e.png").stat().st_size > 0
