"""The true terrain of the synthetic scenes: rolling sinusoids and a terrace."""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np
from numpy.typing import ArrayLike, NDArray

from .._docstrings import Function, fill_docstring
from .._params import check_number
from .._validation import as_real

__all__ = ["Terrain", "make_terrain", "ramp_coordinate", "terrain_height", "terrain_z"]

# Shape of the surface, in metres unless stated otherwise.
_N_WAVES = 3  # sinusoids summed for the rolling terrain
_WAVE_AMPLITUDE = (0.5, 1.5)  # per sinusoid
_WAVE_LENGTH = (80.0, 400.0)  # clip range of the wavelengths (drawn as 0.5-1.5 x size)
_RAMP_SLOPE_DEG = (15.0, 25.0)  # slope of the terrace ramp
_RAMP_MAX_WIDTH = 40.0  # horizontal width of the ramp band (0.15 x size if smaller)


class Terrain(NamedTuple):
    """Parameters of the true terrain surface, drawn from the seed."""

    amplitude: NDArray[np.float64]  # (W,) m
    kx: NDArray[np.float64]  # (W,) rad/m
    ky: NDArray[np.float64]  # (W,) rad/m
    phase: NDArray[np.float64]  # (W,) rad
    ramp_cos: float
    ramp_sin: float
    ramp_offset: float  # s at the area centre, so that the band is 0 <= s <= width
    ramp_width: float  # m
    ramp_tan: float  # rise per metre across the band
    half: float  # size / 2


def make_terrain(seed: int, size: float) -> Terrain:
    # The terrain has its own stream (spawn key 0) so that terrain_height() can
    # rebuild it from (seed, size) without replaying the scene's draws.
    rng = np.random.default_rng(np.random.SeedSequence(seed, spawn_key=(0,)))
    amplitude = rng.uniform(*_WAVE_AMPLITUDE, _N_WAVES)
    wavelength = np.clip(rng.uniform(0.5, 1.5, _N_WAVES) * size, *_WAVE_LENGTH)
    direction = rng.uniform(0.0, 2.0 * np.pi, _N_WAVES)
    phase = rng.uniform(0.0, 2.0 * np.pi, _N_WAVES)
    k = 2.0 * np.pi / wavelength
    ramp_dir = rng.uniform(0.0, 2.0 * np.pi)
    ramp_centre = rng.uniform(-0.2, 0.2) * size  # band centre, from the area centre
    ramp_slope = math.radians(rng.uniform(*_RAMP_SLOPE_DEG))
    width = min(0.15 * size, _RAMP_MAX_WIDTH)
    return Terrain(
        amplitude=amplitude,
        kx=k * np.cos(direction),
        ky=k * np.sin(direction),
        phase=phase,
        ramp_cos=math.cos(ramp_dir),
        ramp_sin=math.sin(ramp_dir),
        ramp_offset=0.5 * width - ramp_centre,
        ramp_width=width,
        ramp_tan=math.tan(ramp_slope),
        half=0.5 * size,
    )


def ramp_coordinate(t: Terrain, x: ArrayLike, y: ArrayLike) -> NDArray[np.float64]:
    """Signed distance across the ramp; the sloped band is 0 <= s <= width."""
    s = (np.asarray(x) - t.half) * t.ramp_cos
    s += (np.asarray(y) - t.half) * t.ramp_sin
    s += t.ramp_offset
    return s


def terrain_z(t: Terrain, x: ArrayLike, y: ArrayLike) -> NDArray[np.float64]:
    """Evaluate the terrain with in-place temporaries (the 10M-point path)."""
    xb, yb = np.broadcast_arrays(np.asarray(x, dtype=np.float64), np.asarray(y, dtype=np.float64))
    shape = xb.shape
    xf, yf = xb.reshape(-1), yb.reshape(-1)
    z = np.zeros(xf.shape)
    tmp = np.empty(xf.shape)
    tmp2 = np.empty(xf.shape)
    for a, kx, ky, ph in zip(t.amplitude, t.kx, t.ky, t.phase):
        np.multiply(xf, kx, out=tmp)
        np.multiply(yf, ky, out=tmp2)
        tmp += tmp2
        tmp += ph
        np.sin(tmp, out=tmp)
        tmp *= a
        z += tmp
    np.subtract(xf, t.half, out=tmp)
    tmp *= t.ramp_cos
    np.subtract(yf, t.half, out=tmp2)
    tmp2 *= t.ramp_sin
    tmp += tmp2
    tmp += t.ramp_offset  # tmp is now the ramp coordinate s
    np.clip(tmp, 0.0, t.ramp_width, out=tmp)
    tmp *= t.ramp_tan
    z += tmp
    return z.reshape(shape)


DATASET_ENTRIES = {
    "terrain_query": """\
x, y : array_like of float
    Horizontal coordinates in metres, relative to the scene's ``origin``
    (subtract ``scene.origin[:2]`` first when an offset was used).
    Broadcast against each other.
seed : int, default 0
    The scene's seed.""",
    "terrain_height": """\
ndarray of float64
    Terrain height in metres (without the roughness of the ground points
    and without the ``origin`` z offset), of the broadcast shape of x, y.""",
    "scene_seed": """\
seed : int, default 0
    Seed of every random draw; the same arguments give identical arrays.""",
    "scene_offset": """\
offset : tuple of 3 float, optional
    Added to every point, e.g. ``(500000.0, 5000000.0, 0.0)`` for
    UTM-sized coordinates. The geometry relative to it does not depend on
    it.""",
    "terrain_raises": """\
ValueError
    If ``seed`` is negative, ``size`` is not finite and > 0, or x, y
    contain non-finite values.
TypeError
    If ``seed`` is not an integer or ``size`` not a real number.""",
}
"""Docstring entries of the scene and terrain functions (see :mod:`pcl_rg._docstrings`)."""


def fill_dataset_docstring(function: Function) -> Function:
    """:func:`pcl_rg._docstrings.fill_docstring` with :data:`DATASET_ENTRIES`."""
    return fill_docstring(function, DATASET_ENTRIES)


def check_terrain_query(
    x: ArrayLike, y: ArrayLike, seed: object, size: object
) -> tuple[int, float, np.ndarray, np.ndarray]:
    """The arguments of a terrain-height query, checked: seed, size, x and y as float64."""
    seed = check_number("seed", seed, int, minimum=0)
    size = check_number("size", size, float, above=0.0)
    xa = as_real("x", x)
    ya = as_real("y", y)
    for name, arr in (("x", xa), ("y", ya)):
        if not np.all(np.isfinite(arr)):
            raise ValueError(
                f"{name} must be finite, got {np.count_nonzero(~np.isfinite(arr))} "
                "non-finite values"
            )
    return seed, size, xa, ya


@fill_dataset_docstring
def terrain_height(
    x: ArrayLike, y: ArrayLike, *, seed: int = 0, size: float = 200.0
) -> NDArray[np.float64]:
    """True terrain height of the scene made by ``synthetic_scene(seed=seed, size=size)``.

    Parameters
    ----------
    %(terrain_query)s
    size : float, default 200.0
        The scene's side length in metres.

    Returns
    -------
    %(terrain_height)s

    Raises
    ------
    %(terrain_raises)s

    Notes
    -----
    The surface is the sum of a few low-frequency sinusoids (wavelength
    80-400 m, amplitude 0.5-1.5 m each) plus a terrace: a straight band,
    ``min(0.15 * size, 40)`` m wide across the whole area, in which the
    ground rises at 15-25 degrees. The height is continuous; its slope jumps
    at the two edges of the band (the slope breaks).

    Examples
    --------
    >>> import numpy as np
    >>> from pcl_rg.datasets import terrain_height
    >>> z = terrain_height(np.array([0.0, 100.0]), np.array([0.0, 100.0]), seed=3)
    >>> z.shape, z.dtype
    ((2,), dtype('float64'))
    """
    seed, size, xa, ya = check_terrain_query(x, y, seed, size)
    return terrain_z(make_terrain(seed, size), xa, ya)
