"""Many images: a turntable (one task per view) and a density sweep on a Dask cluster.

    python examples/turntable.py [SCHEDULER]     # writes out/turntable-*.png, out/sweep-*.png
"""

import sys

import distributed
import numpy as np

import vkengine
from vkengine import distributed as vd

if __name__ == "__main__":
    client = distributed.Client(sys.argv[1]) if len(sys.argv) > 1 else distributed.Client(
        distributed.LocalCluster(n_workers=2, threads_per_worker=1, dashboard_address=None))
    base = vd.Job(size=(192, 192), settings={"renderer": "mcs", "n": 64}, validation=False)
    views = vd.render_many(client, vd.turntable(base, views=12), frames=8,
                           progress=lambda d, n: print(f"view {d}/{n}"))
    for i, img in enumerate(views):
        vkengine.write_image(f"out/turntable-{i:02}.exr", img)
    sweep = [vd.Job(size=(192, 192), settings={"renderer": "mcs", "n": 64, "density": d}, validation=False)
             for d in (0.5, 1, 2, 4)]
    for d, img in zip((0.5, 1, 2, 4), vd.render_many(client, sweep, frames=8)):
        srgb = (np.clip(img[..., :3] / (1 + img[..., :3]), 0, 1) ** (1 / 2.2) * 255).astype(np.uint8)
        vkengine.write_image(f"out/sweep-density-{d}.png", np.dstack([srgb, np.full(srgb.shape[:2], 255, np.uint8)]))
    client.close()
