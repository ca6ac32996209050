"""Measures the Python package: call overhead per frame, readback, merge cost, and one image's
scaling over 1, 2 and 4 local Dask workers. Writes JSON to stdout.

    VKENGINE_VALIDATION=0 .venv/bin/python python/bench/measure.py > results/python/measure.json
"""

import json
import statistics
import sys
import time

import numpy as np

import vkengine
from vkengine import distributed as vd


def overhead(size=512, frames=12):
    r = vkengine.Renderer(size=(size, size), renderer="mcs", validation=False)
    r.render(frames=2)  # pipelines compiled, caches warm
    call, inside, between = [], [], []
    for _ in range(frames):
        rep = r.report()
        before, before_between = rep["wall_ms"], rep["between_frames_ms"]
        t0 = time.perf_counter()
        r.step()
        t1 = time.perf_counter()
        call.append((t1 - t0) * 1e3)
        rep = r.report()
        # The Rust loop's time less what it spent back in Python between frames (the Ctrl-C
        # check with the GIL re-taken): that part is overhead too.
        between.append(rep["between_frames_ms"] - before_between)
        inside.append(rep["wall_ms"] - before - between[-1])
    rep = r.report()
    t0 = time.perf_counter()
    for _ in range(5):
        r.image()
    readback = (time.perf_counter() - t0) / 5 * 1e3
    t0 = time.perf_counter()
    s, n = r.accumulate(0, 4)
    acc_ms = (time.perf_counter() - t0) / 4 * 1e3
    over = [c - i for c, i in zip(call, inside)]
    return {
        "size": size, "renderer": "mcs", "device": r.device,
        "call_ms_median": statistics.median(call),
        "rust_wall_ms_median": statistics.median(inside),
        "python_overhead_ms_median": statistics.median(over),
        "python_overhead_ms_max": max(over),
        "between_frames_ms_median": statistics.median(between),
        "overhead_fraction_of_frame": statistics.median(over) / statistics.median(call),
        "gpu_frame_ms_median": rep["frame_ms"],
        "image_readback_ms": readback,
        "accumulate_ms_per_frame": acc_ms,
    }


def merge_cost(size=512, parts=8):
    rng = np.random.default_rng(0)
    accs = [vkengine.Accumulation(rng.random((size, size, 4)), 2, [(2 * i, 2 * i + 2)]) for i in range(parts)]
    t0 = time.perf_counter()
    for _ in range(3):
        vkengine.merge(accs)
    ms = (time.perf_counter() - t0) / 3 * 1e3
    return {"size": size, "parts": parts, "merge_ms": ms, "bytes_per_part": accs[0].sum.nbytes}


def scaling(size=256, frames=24, workers=(1, 2, 4)):
    import distributed

    job = vd.Job(size=(size, size), settings={"renderer": "mcs", "n": 128}, validation=False, seed=1)
    out = []
    r = job.renderer()
    r.accumulate(0, 1)
    t0 = time.perf_counter()
    ref, _ = r.accumulate(0, frames)
    single = time.perf_counter() - t0
    del r
    for k in workers:
        cluster = distributed.LocalCluster(n_workers=k, threads_per_worker=1, processes=True,
                                           dashboard_address=None, silence_logs=40)
        client = distributed.Client(cluster)
        client.run(lambda: vd._renderer_for(job).accumulate(0, 1))  # device and volume on every worker
        t0 = time.perf_counter()
        acc = vd.render_image(client, job, frames, chunks=2 * k)
        wall = time.perf_counter() - t0
        tasks = None
        out.append({"workers": k, "chunks": 2 * k, "wall_s": wall, "speedup": single / wall,
                    "equals_single_process": bool(np.allclose(acc.sum, ref, rtol=1e-12, atol=0))})
        client.close()
        cluster.close()
    return {"size": size, "frames": frames, "single_process_s": single, "runs": out}


if __name__ == "__main__":
    what = sys.argv[1:] or ["overhead", "merge", "scaling"]
    res = {}
    if "overhead" in what:
        res["overhead"] = overhead()
    if "merge" in what:
        res["merge"] = merge_cost()
    if "scaling" in what:
        res["scaling"] = scaling()
    json.dump(res, sys.stdout, indent=1)
    print()
