"""The demo's segmentation score: how well a region covers each building's roof."""

from __future__ import annotations

import numpy as np

from .datasets import BUILDING

__all__ = ["ROOF_BAND", "roof_ids", "roof_iou"]

ROOF_BAND = 0.25  # m below a building's highest point that still counts as its roof


def roof_ids(points: np.ndarray, labels: np.ndarray, buildings: np.ndarray) -> np.ndarray:
    """Truth roof id per point (1, 2, ... per building; 0 elsewhere)."""
    roof = np.zeros(len(points), dtype=np.int64)
    is_building = labels == BUILDING
    for i, (xmin, ymin, xmax, ymax, _) in enumerate(buildings):
        inside = (
            is_building
            & (points[:, 0] >= xmin - 0.01)
            & (points[:, 0] <= xmax + 0.01)
            & (points[:, 1] >= ymin - 0.01)
            & (points[:, 1] <= ymax + 0.01)
        )
        if inside.any():
            top = points[inside, 2].max()
            roof[inside & (points[:, 2] >= top - ROOF_BAND)] = i + 1
    return roof


def roof_iou(roof: np.ndarray, labels: np.ndarray) -> float:
    """Mean over roofs of the IoU (over all points) of the roof and its best region."""
    sizes = np.bincount(labels[labels >= 0]) if (labels >= 0).any() else np.zeros(0, np.int64)
    scores = []
    for roof_id in np.unique(roof[roof > 0]):
        members = roof == roof_id
        candidates, inter = np.unique(labels[members & (labels >= 0)], return_counts=True)
        if len(candidates) == 0:
            scores.append(0.0)
            continue
        union = sizes[candidates] + members.sum() - inter
        scores.append(float((inter / union).max()))
    return float(np.mean(scores)) if scores else float("nan")
