#!/usr/bin/env python3
"""A procedural fireball written by OpenVDB's own Python module (Debian: python3-openvdb; run with
/usr/bin/python3), for demos/tests/vdb_fire.rs: a 32³ box with two float grids, `density` (a
linear radial ramp, 1 at the centre, 0 from 12 voxels out) and `temperature` (kelvin: 800 at the
rim to 3000 at the centre), active on exactly the same voxels, so they share one box.

usage: make_vdb_fireball.py DIR
Writes DIR/fireball.vdb, and the bad inputs DIR/shifted.vdb (its temperature ball two voxels
off the density's: another box) and DIR/nan.vdb (one NaN temperature).

usage: make_vdb_fireball.py --fixture OUT.vdb
Writes the fireball at 12³ (radius 5), the loader fuzzer's two-grid seed
(tests/data/formats/fireball.vdb)."""
import os
import sys

import numpy as np
import pyopenvdb as vdb

N, R = (12, 5.0) if sys.argv[1] == "--fixture" else (32, 12.0)


def ball(shift=0):
    i = np.arange(N, dtype=np.float64)
    c = (N - 1) / 2
    x, y, z = np.meshgrid(i - c - shift, i - c, i - c, indexing="ij")
    return np.clip(1.0 - np.sqrt(x * x + y * y + z * z) / R, 0.0, 1.0)


def grid(name, values):
    g = vdb.FloatGrid(background=0.0)
    # tolerance 0: exactly the non-zero voxels are active.
    g.copyFromArray(np.ascontiguousarray(values.astype(np.float32)), ijk=(0, 0, 0), tolerance=0.0)
    g.name = name
    return g


def fire(d):
    return np.where(d > 0.0, 800.0 + 2200.0 * d, 0.0)


def main():
    d = ball()
    if sys.argv[1] == "--fixture":
        vdb.write(sys.argv[2], grids=[grid("density", d), grid("temperature", fire(d))])
        return
    out = sys.argv[1]
    vdb.write(os.path.join(out, "fireball.vdb"), grids=[grid("density", d), grid("temperature", fire(d))])
    vdb.write(os.path.join(out, "shifted.vdb"), grids=[grid("density", d), grid("temperature", fire(ball(2)))])
    t = grid("temperature", fire(d))
    t.getAccessor().setValueOn((16, 16, 16), float("nan"))
    vdb.write(os.path.join(out, "nan.vdb"), grids=[grid("density", d), t])


if __name__ == "__main__":
    main()
