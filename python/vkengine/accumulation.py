"""Exact sums of frame ranges: what workers return and how they merge."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any, Dict, Iterable, List, Tuple

import numpy as np


@dataclass
class Accumulation:
    """The float64 sum of the HDR images of some frames, and which frames they were."""

    sum: np.ndarray
    count: int
    ranges: List[Tuple[int, int]] = field(default_factory=list)
    reports: List[Dict[str, Any]] = field(default_factory=list)
    """Per range, where a distributed render ran it: device, process, seconds."""

    def image(self) -> np.ndarray:
        """The mean image, float32 (height, width, 4)."""
        if self.count == 0:
            raise ValueError("an accumulation of no frames has no image")
        return (self.sum / self.count).astype(np.float32)


def merge(parts: Iterable[Accumulation]) -> Accumulation:
    """Adds accumulations of disjoint frame ranges, in order of their first frame.

    The fixed order makes the result independent of which worker finished first, so the same
    ranges merge bit for bit the same every time. Overlapping ranges raise ``ValueError``: a
    frame counted twice would bias the mean.
    """
    parts = sorted(parts, key=lambda p: min((r[0] for r in p.ranges), default=0))
    if not parts:
        raise ValueError("nothing to merge")
    seen: List[Tuple[int, int]] = []
    for p in parts:
        for a, b in p.ranges:
            for c, d in seen:
                if a < d and c < b:
                    raise ValueError(f"frame ranges [{a}, {b}) and [{c}, {d}) overlap: a frame would count twice")
            seen.append((a, b))
    total = np.zeros_like(parts[0].sum, dtype=np.float64)
    count = 0
    for p in parts:
        if p.sum.shape != total.shape:
            raise ValueError(f"image shapes differ: {p.sum.shape} and {total.shape}")
        total += p.sum
        count += p.count
    if count != sum(b - a for a, b in seen):
        raise ValueError("counts do not match the ranges")
    return Accumulation(total, count, sorted(seen))
