"""The steep terrain of :func:`pcl_rg.datasets.isprs_like_scene`: hills, a slope, an
embankment cut by a channel."""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ._terrain import check_terrain_query

__all__ = ["SteepTerrain", "isprs_like_terrain", "make_steep_terrain", "steep_z"]

_TERRAIN_STREAM = 10  # spawn key of the terrain's own random stream
# Shape of the surface, in metres unless stated otherwise.
_N_WAVES = 3
_WAVE_AMPLITUDE = (1.0, 3.0)  # per sinusoid
_WAVE_LENGTH = (80.0, 400.0)  # clip range of the wavelengths (drawn as 0.5-1.5 x size)
_SLOPE_DEG = (30.0, 40.0)  # the steep band
_SLOPE_MAX_WIDTH = 25.0  # horizontal width of the steep band (0.08 x size if smaller)
_ROAD_TOP_HALF = 4.0  # half-width of the embankment's crown (the road)
_ROAD_HEIGHT = (3.0, 5.0)  # embankment height
_ROAD_SIDE_DEG = (33.0, 45.0)  # embankment side slopes
_CHANNEL_DEPTH = (4.0, 6.0)
_CHANNEL_BOTTOM_HALF = (3.0, 5.0)
_CHANNEL_BANK_DEG = (35.0, 45.0)
_GAP_MARGIN = 1.0  # the embankment stops this far beyond the channel's rim


class SteepTerrain(NamedTuple):
    """Parameters of the terrain surface, drawn from the seed (local coordinates)."""

    amplitude: NDArray[np.float64]  # (W,) m
    kx: NDArray[np.float64]  # (W,) rad/m
    ky: NDArray[np.float64]  # (W,) rad/m
    phase: NDArray[np.float64]  # (W,) rad
    half: float  # size / 2: the lines below are placed relative to the area's centre
    slope_normal: tuple[float, float]
    slope_offset: float  # the band is 0 <= s <= slope_width, s = normal . (p - c) + offset
    slope_width: float
    slope_tan: float
    road_normal: tuple[float, float]
    road_offset: float  # signed distance of the road's centre line from the centre
    road_height: float
    road_run: float  # horizontal run of an embankment side, road_height / tan(side)
    channel_normal: tuple[float, float]
    channel_offset: float
    channel_depth: float
    channel_bottom_half: float
    channel_run: float  # horizontal run of a bank
    gap_half: float  # half the gap in the embankment where the channel crosses it


def make_steep_terrain(seed: int, size: float) -> SteepTerrain:
    """The terrain of ``isprs_like_scene(seed=seed, size=size)``, from its own stream."""
    rng = np.random.default_rng(np.random.SeedSequence(seed, spawn_key=(_TERRAIN_STREAM,)))
    amplitude = rng.uniform(*_WAVE_AMPLITUDE, _N_WAVES)
    wavelength = np.clip(rng.uniform(0.5, 1.5, _N_WAVES) * size, *_WAVE_LENGTH)
    direction = rng.uniform(0.0, 2.0 * np.pi, _N_WAVES)
    phase = rng.uniform(0.0, 2.0 * np.pi, _N_WAVES)
    k = 2.0 * np.pi / wavelength
    # The road runs roughly along x at 0.3 size, the steep band roughly along x at
    # 0.8 size, the channel roughly along y through the middle: three zones of
    # terrain between which the buildings stand.
    road_angle = math.radians(rng.uniform(-10.0, 10.0))
    road_offset = (-0.2 + rng.uniform(-0.03, 0.03)) * size
    road_height = rng.uniform(*_ROAD_HEIGHT)
    road_run = road_height / math.tan(math.radians(rng.uniform(*_ROAD_SIDE_DEG)))
    slope_angle = math.radians(rng.uniform(-8.0, 8.0))
    slope_width = min(0.08 * size, _SLOPE_MAX_WIDTH)
    slope_centre = (0.3 + rng.uniform(-0.02, 0.02)) * size
    slope_tan = math.tan(math.radians(rng.uniform(*_SLOPE_DEG)))
    channel_angle = math.radians(rng.uniform(-15.0, 15.0))
    channel_offset = rng.uniform(-0.08, 0.08) * size
    depth = rng.uniform(*_CHANNEL_DEPTH)
    bottom_half = rng.uniform(*_CHANNEL_BOTTOM_HALF)
    channel_run = depth / math.tan(math.radians(rng.uniform(*_CHANNEL_BANK_DEG)))
    return SteepTerrain(
        amplitude=amplitude,
        kx=k * np.cos(direction),
        ky=k * np.sin(direction),
        phase=phase,
        half=0.5 * size,
        slope_normal=(-math.sin(slope_angle), math.cos(slope_angle)),
        slope_offset=0.5 * slope_width - slope_centre,
        slope_width=slope_width,
        slope_tan=slope_tan,
        road_normal=(-math.sin(road_angle), math.cos(road_angle)),
        road_offset=road_offset,
        road_height=road_height,
        road_run=road_run,
        channel_normal=(math.cos(channel_angle), -math.sin(channel_angle)),
        channel_offset=channel_offset,
        channel_depth=depth,
        channel_bottom_half=bottom_half,
        channel_run=channel_run,
        gap_half=bottom_half + channel_run + _GAP_MARGIN,
    )


def line_distance(
    t: SteepTerrain, normal: tuple[float, float], offset: float, x: ArrayLike, y: ArrayLike
) -> NDArray[np.float64]:
    """Signed distance of (x, y) from the line ``normal . (p - centre) = offset``."""
    return (np.asarray(x) - t.half) * normal[0] + (np.asarray(y) - t.half) * normal[1] - offset


def base_z(t: SteepTerrain, x: ArrayLike, y: ArrayLike) -> NDArray[np.float64]:
    """The rolling sinusoids plus the steep band: the terrain without road and channel."""
    x = np.asarray(x, dtype=np.float64)
    y = np.asarray(y, dtype=np.float64)
    z = np.zeros(np.broadcast_shapes(x.shape, y.shape))
    for a, kx, ky, ph in zip(t.amplitude, t.kx, t.ky, t.phase):
        z += a * np.sin(kx * x + ky * y + ph)
    s = line_distance(t, t.slope_normal, -t.slope_offset, x, y)
    z += t.slope_tan * np.clip(s, 0.0, t.slope_width)
    return z


def road_level(t: SteepTerrain, x: ArrayLike, y: ArrayLike) -> NDArray[np.float64]:
    """Height of the road on the embankment's crown (also the bridge deck's top)."""
    return base_z(t, x, y) + t.road_height


def steep_z(t: SteepTerrain, x: ArrayLike, y: ArrayLike) -> NDArray[np.float64]:
    """Terrain height: base, plus the embankment (planar sides, cut by the gap), minus
    the channel (flat bottom, planar banks)."""
    z = base_z(t, x, y)
    across = np.abs(line_distance(t, t.road_normal, t.road_offset, x, y))
    along = np.abs(line_distance(t, t.channel_normal, t.channel_offset, x, y))
    side = np.clip((_ROAD_TOP_HALF + t.road_run - across) / t.road_run, 0.0, 1.0)
    abutment = np.clip((along - t.gap_half) / t.road_run, 0.0, 1.0)
    z += t.road_height * np.minimum(side, abutment)
    bank = np.clip((t.channel_bottom_half + t.channel_run - along) / t.channel_run, 0.0, 1.0)
    z -= t.channel_depth * bank
    return z


def isprs_like_terrain(
    x: ArrayLike, y: ArrayLike, *, seed: int = 0, size: float = 300.0
) -> NDArray[np.float64]:
    """True terrain height of the scene made by ``isprs_like_scene(seed=seed, size=size)``.

    Parameters
    ----------
    x, y : array_like of float
        Horizontal coordinates in metres, relative to the scene's ``origin``
        (subtract ``scene.origin[:2]`` first when an offset was used).
        Broadcast against each other.
    seed : int, default 0
        The scene's seed.
    size : float, default 300.0
        The scene's side length in metres.

    Returns
    -------
    ndarray of float64
        Terrain height in metres (without the roughness of the ground points and
        without the ``origin`` z offset), of the broadcast shape of x, y. Under
        the bridge this is the channel and its banks, not the deck.

    Raises
    ------
    ValueError
        If ``seed`` is negative, ``size`` is not finite and > 0, or x, y
        contain non-finite values.
    TypeError
        If ``seed`` is not an integer or ``size`` not a real number.

    Notes
    -----
    Rolling sinusoids (wavelength 80-400 m, amplitude 1-3 m each); a band
    ``min(0.08 * size, 25)`` m wide, roughly along x at 0.8 ``size``, that rises at
    30-40 degrees; a road embankment roughly along x at 0.3 ``size``, 3-5 m high
    with an 8 m crown and 33-45 degree sides; and a channel roughly along y
    through the middle, 4-6 m deep, 6-10 m wide at the bottom, with 35-45 degree
    banks. The embankment stops 1 m beyond the channel's rims and falls at its
    side slope to the channel: the bridge of the scene spans that gap. The
    height is continuous; its slope jumps at every edge of the band, the
    embankment and the channel (the break lines).

    Examples
    --------
    >>> import numpy as np
    >>> from pcl_rg.datasets import isprs_like_terrain
    >>> z = isprs_like_terrain(np.array([10.0, 150.0]), np.array([10.0, 150.0]), seed=3)
    >>> z.shape, z.dtype
    ((2,), dtype('float64'))
    """
    seed, size, xa, ya = check_terrain_query(x, y, seed, size)
    return steep_z(make_steep_terrain(seed, size), xa, ya)
