#!/usr/bin/env python3
"""A sparse cloud over a box past 1,024 voxels on every axis, written by OpenVDB's own Python
module (Debian: python3-openvdb; run with /usr/bin/python3), for tests/vdb_cloud.rs and
`volume_bench --layout`: puffs of value-noise fBm eroding ellipsoids, float grid `density`,
background 0, only non-zero voxels active (about 0.5 % of the box).

Four puffs lie in one column along x, the first and last at the box's two x ends, so a crop
holding that column spans the whole box along x; the other puffs stay inside those x ends and
reach the box's far y and z. Each puff is scaled so its largest value is exactly 1 (and every
file has uncovered background voxels), so the whole cloud and the crop normalize alike.

usage: make_vdb_sparse_cloud.py WHOLE.vdb CROP.vdb
Writes WHOLE.vdb (every puff) and CROP.vdb (the column's puffs only, at the same positions),
and prints one JSON line: each file's active bounding box and active voxel count.

usage: make_vdb_sparse_cloud.py --bench OUT.vdb
Writes the whole cloud's puffs at 0.4 × their positions (a box about 480 voxels a side, whose
dense images fit one allocation): `volume_bench --layout --layout-vdb OUT.vdb`.

usage: make_vdb_sparse_cloud.py --far SPACING OUT.vdb
Writes eight 32³-voxel puffs at the corners of a cube SPACING voxels on a side (4,096: a box
about 4,125 voxels a side, 7 · 10¹⁰ voxels, past 2³¹), and prints its JSON line."""
import json
import sys

import numpy as np
import pyopenvdb as vdb

S = 112  # voxels of one puff's block along each axis
COLUMN = [(0, 8, 8), (320, 8, 8), (640, 8, 8), (970, 8, 8)]  # block origins (x, y, z)
OTHERS = [(200, 945, 30), (420, 400, 640), (760, 930, 945), (300, 30, 940),
          (560, 640, 200), (240, 700, 500), (700, 150, 450), (480, 940, 700)]


def upsample(lat, n):
    # Periodic smoothstep-trilinear upsampling of a random cubic lattice to n³.
    out = lat
    m = lat.shape[0]
    c = np.arange(n) * (m / n)
    i0 = np.floor(c).astype(int) % m
    i1 = (i0 + 1) % m
    f = c - np.floor(c)
    f = (f * f * (3 - 2 * f)).astype(np.float32)
    for axis in range(3):
        sh = [1, 1, 1]
        sh[axis] = n
        out = np.take(out, i0, axis) * (1 - f).reshape(sh) + np.take(out, i1, axis) * f.reshape(sh)
    return out


def puff(rng, S=S):
    noise = np.zeros((S, S, S), np.float32)
    amp, tot = 1.0, 0.0
    for m in (4, 8, 16, 32):
        noise += amp * upsample(rng.random((m, m, m)).astype(np.float32), S)
        tot += amp
        amp *= 0.55
    noise /= tot
    c = (np.arange(S, dtype=np.float32) + 0.5) / S - 0.5
    z, y, x = np.meshgrid(c, c, c, indexing="ij")
    r = rng.uniform(0.3, 0.42, 3)
    d = (x / r[0]) ** 2 + (y / r[1]) ** 2 + (z / r[2]) ** 2
    dens = np.clip((1 - d) * 1.5 + (noise - 0.5) * 2.5, 0, None)
    dens = np.where(dens > 0.05, dens, 0).astype(np.float32)
    # Largest value exactly 1 (a division of the maximum by itself).
    return (dens / dens.max()).astype(np.float32)


def write(path, blocks):
    grid = vdb.FloatGrid(background=0.0)
    grid.name = "density"
    for (ox, oy, oz), d in blocks:
        # numpy (z, y, x) → OpenVDB (i, j, k) = (x, y, z).
        grid.copyFromArray(np.ascontiguousarray(d.transpose(2, 1, 0)), ijk=(ox, oy, oz), tolerance=0.0)
    grid.transform = vdb.createLinearTransform(voxelSize=1.0 / 1024)
    vdb.write(path, grids=[grid])
    lo, hi = grid.evalActiveVoxelBoundingBox()
    return {"lo": list(lo), "hi": list(hi), "active": grid.activeVoxelCount()}


def main(whole, crop):
    rng = np.random.default_rng(40)
    column = [(o, puff(rng)) for o in COLUMN]
    others = [(o, puff(rng)) for o in OTHERS]
    info = {"whole": write(whole, column + others), "crop": write(crop, column)}
    print(json.dumps(info))


def far(spacing, path):
    rng = np.random.default_rng(4096)
    corners = [(x, y, z) for z in (0, spacing) for y in (0, spacing) for x in (0, spacing)]
    print(json.dumps({"far": write(path, [(o, puff(rng, 32)) for o in corners])}))


if __name__ == "__main__":
    if sys.argv[1] == "--bench":
        rng = np.random.default_rng(40)
        puffs = [(tuple(int(c * 0.4) for c in o), puff(rng)) for o in COLUMN + OTHERS]
        print(json.dumps({"bench": write(sys.argv[2], puffs)}))
    elif sys.argv[1] == "--far":
        far(int(sys.argv[2]), sys.argv[3])
    else:
        main(sys.argv[1], sys.argv[2])
