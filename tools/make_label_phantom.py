#!/usr/bin/env python3
"""A labelled phantom for docs/labels.md: a CT-like scan (an elliptic body of soft tissue with a
bone shell, a spine, an organ and a lesion in it) as `phantom.nrrd`, and its segmentation as 3D
Slicer writes one, `phantom.seg.nrrd` (SegmentN_* keys, single layer), on the same grid.

    python3 tools/make_label_phantom.py OUT_DIR [N]

Pure Python (no numpy), N³ voxels of unsigned bytes (default 96).
"""

import os
import sys

SEGMENTS = [
    # (label value, name, colour in [0, 1])
    (1, "liver", (0.86, 0.45, 0.30)),
    (2, "lesion", (0.95, 0.85, 0.20)),
    (3, "spine", (0.90, 0.90, 0.85)),
    (4, "kidneys", (0.35, 0.55, 0.95)),
]


def region(x, y, z):
    """(scan value 0..255, label) at normalized coordinates in [-1, 1]³."""
    body = (x / 0.85) ** 2 + (y / 0.62) ** 2
    if abs(z) > 0.9 or body >= 1.0:
        return 0, 0
    # Brighter towards the middle slice, so the transfer function shows some shading.
    tex = int(8 * (1 - z * z))
    if (x + 0.0) ** 2 + (y + 0.38) ** 2 < 0.012:
        return 235, 3
    if (x - 0.3) ** 2 / 0.09 + (y + 0.05) ** 2 / 0.06 + z ** 2 / 0.5 < 1.0:
        if (x - 0.38) ** 2 + (y + 0.02) ** 2 + (z - 0.1) ** 2 < 0.012:
            return 150, 2
        return 120 + tex, 1
    for side in (-0.32, 0.32):
        if ((x - side) / 0.09) ** 2 + ((y + 0.28) / 0.12) ** 2 + (z / 0.25) ** 2 < 1.0:
            return 130 + tex, 4
    if body > 0.86:
        return 205, 0
    return 80 + tex, 0


def nrrd_header(n, extra=""):
    return (
        "NRRD0004\n# Complete NRRD file format specification at:\n# http://teem.sourceforge.net/nrrd/format.html\n"
        f"type: unsigned char\ndimension: 3\nspace: left-posterior-superior\nsizes: {n} {n} {n}\n"
        "space directions: (1,0,0) (0,1,0) (0,0,1)\nkinds: domain domain domain\nencoding: raw\n"
        f"space origin: (0,0,0)\n{extra}\n"
    ).encode()


def main():
    out = sys.argv[1] if len(sys.argv) > 1 else "out"
    n = int(sys.argv[2]) if len(sys.argv) > 2 else 96
    os.makedirs(out, exist_ok=True)
    scan = bytearray(n * n * n)
    labels = bytearray(n * n * n)
    i = 0
    for k in range(n):
        z = (k + 0.5) / n * 2 - 1
        for j in range(n):
            y = (j + 0.5) / n * 2 - 1
            for m in range(n):
                x = (m + 0.5) / n * 2 - 1
                scan[i], labels[i] = region(x, y, z)
                i += 1
    keys = ""
    for s, (value, name, (r, g, b)) in enumerate(SEGMENTS):
        keys += (
            f"Segment{s}_Color:={r} {g} {b}\nSegment{s}_ID:=Segment_{value}\nSegment{s}_LabelValue:={value}\n"
            f"Segment{s}_Layer:=0\nSegment{s}_Name:={name}\n"
        )
    keys += "Segmentation_MasterRepresentation:=Binary labelmap\n"
    with open(os.path.join(out, "phantom.nrrd"), "wb") as f:
        f.write(nrrd_header(n) + bytes(scan))
    with open(os.path.join(out, "phantom.seg.nrrd"), "wb") as f:
        f.write(nrrd_header(n, keys) + bytes(labels))
    print(f"wrote {out}/phantom.nrrd and {out}/phantom.seg.nrrd ({n}^3)")


if __name__ == "__main__":
    main()
