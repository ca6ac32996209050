"""Bytes sent to the workers for a turntable: 36 views of a 256³ float32 volume on a local
2-worker Dask cluster, the volume scattered once (now) against shipped with every task (before;
fewer views, the per-task cost is the same). Counts every byte each worker reads off its TCP
connections (scheduler, client, other workers) and Dask's own worker-to-worker transfer metric.
Writes results/python/transfer.csv and .json (with machine and device).

    VKENGINE_VALIDATION=0 .venv/bin/python python/bench/transfer.py
"""

import csv
import json
import os
import platform
import time

import numpy as np

import vkengine
from vkengine import distributed as vd

OUT = os.path.join(os.path.dirname(__file__), "..", "..", "results", "python")


def _dask_outgoing(dask_worker):
    return dask_worker.transfer_outgoing_bytes_total


def run(client, vol, views, ship_once):
    vd.SHIP_ONCE = ship_once
    job = vd.Job(volume=vol, size=(16, 16), settings={"renderer": "eam"}, tf="cloud", validation=False)
    vd.release(client)
    vd.count_bytes_received(client)
    before = client.run(_dask_outgoing)  # Dask's counter is cumulative
    t0 = time.perf_counter()
    vd.render_many(client, vd.turntable(job, views=views), frames=1)
    wall = time.perf_counter() - t0
    received = vd.bytes_received(client)
    outgoing = sum(n - before[w] for w, n in client.run(_dask_outgoing).items())
    read = sum(received.values())
    return {"mode": "scattered once" if ship_once else "with every task", "views": views, "workers": len(received),
            "volume_bytes": vol.nbytes, "bytes_read_by_workers": read, "per_worker": list(received.values()),
            "dask_transfer_outgoing_bytes": outgoing,
            "ratio_to_volume_x_workers": read / (vol.nbytes * len(received)), "wall_s": wall}


def main():
    import distributed

    import warnings

    warnings.filterwarnings("ignore", message="Sending large graph")  # the "before" mode does
    vol = np.random.default_rng(0).random((256, 256, 256), dtype=np.float32)
    cluster = distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True, dashboard_address=None,
                                       silence_logs=40)
    client = distributed.Client(cluster)
    try:
        rows = [run(client, vol, 36, True), run(client, vol, 4, False)]
    finally:
        vd.SHIP_ONCE = True
        client.close()
        cluster.close()
    dev = vkengine.Renderer(size=(8, 8), n=8, validation=False).device
    machine = {"cpu": platform.processor() or platform.machine(), "cores": os.cpu_count(), "device": dev,
               "python": platform.python_version(), "dask": distributed.__version__}
    os.makedirs(OUT, exist_ok=True)
    with open(os.path.join(OUT, "transfer.json"), "w") as f:
        json.dump({"machine": machine, "runs": rows}, f, indent=1)
    with open(os.path.join(OUT, "transfer.csv"), "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=[k for k in rows[0] if k != "per_worker"], extrasaction="ignore")
        w.writeheader()
        w.writerows(rows)
    print(json.dumps(rows, indent=1))


if __name__ == "__main__":
    main()
