"""Scheduler start-up and dispatch cost on this machine: a 2-worker Dask local cluster, and Ray
(`ray.init(num_cpus=2)`) when it is installed (it is not in .venv; `pip install ray` in a scratch
venv). Prints one line per scheduler."""

import subprocess
import time


def rss_mib(words):
    ps = subprocess.run(["ps", "-eo", "rss,comm"], capture_output=True, text=True).stdout
    return sum(int(ln.split()[0]) for ln in ps.splitlines()[1:] if any(w in ln for w in words)) / 1024


def dask():
    import distributed

    t0 = time.perf_counter()
    c = distributed.Client(distributed.LocalCluster(n_workers=2, threads_per_worker=1, dashboard_address=None,
                                                    silence_logs=40))
    t1 = time.perf_counter()
    c.gather([c.submit(lambda x: x + 1, i, pure=False) for i in range(100)])
    t2 = time.perf_counter()
    print(f"dask: start {t1 - t0:.2f} s, 100 tasks {t2 - t1:.3f} s, {rss_mib(['python']):.0f} MiB resident")
    c.close()


def ray():
    import ray as r

    t0 = time.perf_counter()
    r.init(num_cpus=2, include_dashboard=False, log_to_driver=False)
    t1 = time.perf_counter()
    f = r.remote(lambda x: x + 1)
    r.get([f.remote(i) for i in range(2)])
    t2 = time.perf_counter()
    r.get([f.remote(i) for i in range(100)])
    t3 = time.perf_counter()
    words = ["ray", "gcs", "raylet", "python", "default_worker"]
    print(f"ray: start {t1 - t0:.2f} s (+{t2 - t1:.2f} s first tasks), 100 tasks {t3 - t2:.3f} s, "
          f"{rss_mib(words):.0f} MiB resident")
    r.shutdown()


if __name__ == "__main__":
    dask()
    try:
        ray()
    except ImportError:
        print("ray: not installed")
