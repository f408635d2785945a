"""Mutated and truncated copies of small valid point files, for the fuzz tests.

`templates(folder)` writes one small valid file of every layout we read; `mutants`
derives damaged copies from them with a seeded generator, so a run is repeatable
from its seed. tests/test_fuzz_files.py runs a few hundred in `make test`;
`make fuzz` runs many more (PCL_RG_FUZZ_CASES).
"""

from __future__ import annotations

import re
from collections.abc import Iterator
from pathlib import Path
from typing import NamedTuple

import laspy
import numpy as np

from pcl_rg.io import PlyLayout, PointFile, write_pcd, write_points


class Mutant(NamedTuple):
    name: str
    suffix: str
    data: bytes


def _cloud(n: int, seed: int) -> tuple[np.ndarray, dict[str, np.ndarray]]:
    rng = np.random.default_rng(seed)
    xyz = np.round(rng.uniform(0.0, 50.0, (n, 3)), 2) + [500_000.0, 5_400_000.0, 0.0]
    fields = {
        "intensity": rng.integers(0, 4000, n).astype(np.uint16),
        "classification": rng.integers(1, 3, n).astype(np.uint8),
    }
    return xyz, fields


def _laspy_file(path: Path, version: str, point_format: int, n: int, evlr: bool) -> None:
    xyz, fields = _cloud(n, 7)
    header = laspy.LasHeader(point_format=point_format, version=version)
    header.scales = np.array([0.01, 0.01, 0.01])
    header.offsets = np.array([500_000.0, 5_400_000.0, 0.0])
    header.add_extra_dim(laspy.ExtraBytesParams(name="height", type=np.float32))
    las = laspy.LasData(header)
    las.x, las.y, las.z = xyz.T
    las.intensity = fields["intensity"]
    las.classification = fields["classification"]
    las.height = xyz[:, 2].astype(np.float32)
    if evlr:
        las.evlrs = laspy.vlrs.vlrlist.VLRList(
            [laspy.VLR("pcl_rg_fuzz", 1, "extended record", b"x" * 40)]
        )
    las.write(str(path))


def templates(folder: Path) -> list[Path]:
    """Small valid files: LAS/LAZ 1.2 and 1.4 (EVLR, extra bytes), PLY, PCD, XYZ."""
    folder.mkdir(parents=True, exist_ok=True)
    out = []
    for version, fmt, suffix, evlr in [
        ("1.2", 3, "las", False),
        ("1.2", 1, "laz", False),
        ("1.4", 6, "las", True),
        ("1.4", 7, "laz", True),
    ]:
        path = folder / f"v{version.replace('.', '')}-f{fmt}.{suffix}"
        _laspy_file(path, version, fmt, 60, evlr)
        out.append(path)
    xyz, fields = _cloud(40, 8)
    for encoding in ("ascii", "binary", "binary_compressed"):
        path = folder / f"cloud-{encoding}.pcd"
        write_pcd(path, xyz - xyz.min(axis=0), fields, encoding=encoding)
        out.append(path)
    for encoding in ("ascii", "binary_little_endian", "binary_big_endian"):
        path = folder / f"cloud-{encoding}.ply"
        layout = PointFile(xyz, fields, "ply", PlyLayout(encoding, np.dtype("f8"), ("fuzz",)))
        write_points(path, xyz, fields, template=layout)
        out.append(path)
    path = folder / "cloud.xyz"
    write_points(path, xyz, fields)
    out.append(path)
    path = folder / "cloud.pts"
    path.write_text(f"{len(xyz)}\n" + "".join(f"{x} {y} {z} 7\n" for x, y, z in xyz))
    out.append(path)
    return out


def _header_length(data: bytes) -> int:
    if data.startswith(b"LASF"):
        return min(len(data), int.from_bytes(data[96:100], "little") + 16)
    for marker in (b"end_header\n", b"\nDATA "):
        found = data.find(marker)
        if found >= 0:
            return min(len(data), data.find(b"\n", found + 1) + 1)
    return min(len(data), 200)


_NUMBER = re.compile(rb"\d+")
_HUGE = (b"4294967295", b"1000000000000", b"99999999999999999999", b"-1", b"0")


def _mutate(data: bytes, rng: np.random.Generator) -> tuple[str, bytes]:
    kind = rng.integers(0, 6)
    head = _header_length(data)
    buf = bytearray(data)
    if kind == 0:  # truncate anywhere
        cut = int(rng.integers(0, len(data)))
        return f"cut{cut}", bytes(buf[:cut])
    if kind == 1:  # a few random bytes in the header
        for _ in range(int(rng.integers(1, 5))):
            buf[int(rng.integers(0, head))] = int(rng.integers(0, 256))
        return "header-bytes", bytes(buf)
    if kind == 2:  # a header word set to all ones or a large power of two
        at = int(rng.integers(0, max(head - 4, 1)))
        value = (0xFFFFFFFF, 0x7FFFFFFF, 1 << int(rng.integers(16, 32)))[int(rng.integers(0, 3))]
        buf[at : at + 4] = value.to_bytes(4, "little")
        return f"word{at}", bytes(buf)
    if kind == 3:  # a number in a text header made huge
        matches = list(_NUMBER.finditer(bytes(buf[:head])))
        if matches:
            m = matches[int(rng.integers(0, len(matches)))]
            huge = _HUGE[int(rng.integers(0, len(_HUGE)))]
            return f"number{m.start()}", bytes(buf[: m.start()]) + huge + bytes(buf[m.end() :])
        return "unchanged", bytes(buf)
    if kind == 4:  # random bytes anywhere
        for _ in range(int(rng.integers(1, 9))):
            buf[int(rng.integers(0, len(buf)))] = int(rng.integers(0, 256))
        return "body-bytes", bytes(buf)
    # a header cut and the body kept: a shifted layout
    at = int(rng.integers(0, head))
    return f"drop{at}", bytes(buf[:at]) + bytes(buf[at + int(rng.integers(1, 9)) :])


def mutants(files: list[Path], count: int, seed: int) -> Iterator[Mutant]:
    """`count` damaged copies, cycling over `files`, from a generator seeded by `seed`."""
    rng = np.random.default_rng(seed)
    originals = [(f, f.read_bytes()) for f in files]
    for i in range(count):
        path, data = originals[i % len(originals)]
        what, damaged = _mutate(data, rng)
        yield Mutant(f"{i:05d}-{path.stem}-{what}", path.suffix, damaged)
