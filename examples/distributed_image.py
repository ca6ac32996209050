"""One image from many workers: disjoint frame ranges rendered on a Dask cluster, merged exactly.

    python examples/distributed_image.py                      # a local cluster of 2 workers
    python examples/distributed_image.py tcp://HOST:8786      # an existing scheduler
"""

import sys
import time

import distributed
import numpy as np

import vkengine
from vkengine import distributed as vd

if __name__ == "__main__":
    if len(sys.argv) > 1:
        client = distributed.Client(sys.argv[1])
    else:
        # One process per worker: each opens its own Vulkan device, as separate machines do.
        client = distributed.Client(distributed.LocalCluster(n_workers=2, threads_per_worker=1,
                                                             dashboard_address=None))
    job = vd.Job(size=(256, 256), settings={"renderer": "mcm", "n": 96, "density": 2}, seed=1, validation=False)
    t0 = time.perf_counter()
    acc = vd.render_image(client, job, frames=32, chunks=8, timeout=600,
                          progress=lambda done, total, rng, who: print(f"{done}/{total} frames ({rng} on {who})"))
    print(f"{acc.count} frames in {time.perf_counter() - t0:.1f} s; ranges {acc.ranges}")
    vkengine.write_image("out/distributed.exr", acc.image())
    np.save("out/distributed-sum.npy", acc.sum)  # merge with more ranges later: vkengine.merge
    client.close()
