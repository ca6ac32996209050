#!/usr/bin/env python3
"""A sparse OpenVDB cloud for the README gallery, written by OpenVDB's own Python module
(Debian: python3-openvdb; run with /usr/bin/python3): a flattened cumulus of value-noise fBm,
float grid `density`, background 0 and only the non-zero voxels active, voxel size 1/128.

usage: make_vdb_cloud.py OUT.vdb [SEED]"""
import sys

import numpy as np
import pyopenvdb as vdb


def upsample(lat, shape):
    # Periodic smoothstep-trilinear upsampling of a random lattice to `shape` (z, y, x).
    out = lat
    for axis, n in enumerate(shape):
        m = lat.shape[axis]
        c = np.arange(n) * (m / n)
        i0 = np.floor(c).astype(int) % m
        i1 = (i0 + 1) % m
        f = c - np.floor(c)
        f = f * f * (3 - 2 * f)
        sh = [1, 1, 1]
        sh[axis] = n
        out = np.take(out, i0, axis) * (1 - f).reshape(sh) + np.take(out, i1, axis) * f.reshape(sh)
    return out


def main(path, seed=7):
    rng = np.random.default_rng(seed)
    shape = (96, 80, 160)  # z, y, x: a wide, flat cloud
    noise = np.zeros(shape, np.float32)
    amp, tot = 1.0, 0.0
    for m in (3, 6, 12, 24, 48):
        noise += amp * upsample(rng.random((m, m, m)).astype(np.float32), shape)
        tot += amp
        amp *= 0.55
    noise /= tot
    z, y, x = np.meshgrid(*[(np.arange(n) + 0.5) / n - 0.5 for n in shape], indexing="ij")
    # A flat base and a rounded top: three overlapping ellipsoid puffs.
    shape_field = np.full(shape, -np.inf, np.float32)
    for cx, cy, cz, rx, ry, rz in [(-0.2, -0.05, 0, 0.28, 0.3, 0.35), (0.15, 0.0, 0.05, 0.3, 0.38, 0.35),
                                   (0.0, -0.1, -0.1, 0.45, 0.25, 0.3)]:
        d = ((x - cx) / rx) ** 2 + ((y - cy) / ry) ** 2 + ((z - cz) / rz) ** 2
        shape_field = np.maximum(shape_field, 1 - d)
    # Noise erodes the puffs' edges; a flat base cuts them below.
    density = np.clip(shape_field * 1.5 + (noise - 0.5) * 2.5, 0, None) * np.clip((y + 0.3) / 0.06, 0, 1)
    density = np.where(density > 0.02, density, 0).astype(np.float32)
    grid = vdb.FloatGrid(background=0.0)
    grid.name = "density"
    # OpenVDB indexes (i, j, k) = (x, y, z): transpose the numpy (z, y, x) array.
    grid.copyFromArray(np.ascontiguousarray(density.transpose(2, 1, 0)), ijk=(0, 0, 0), tolerance=0.0)
    grid.transform = vdb.createLinearTransform(voxelSize=1.0 / 128)
    vdb.write(path, grids=[grid])
    print(f"wrote {path}: {grid.activeVoxelCount()} active voxels of {density.size}")


if __name__ == "__main__":
    main(sys.argv[1], int(sys.argv[2]) if len(sys.argv) > 2 else 7)
