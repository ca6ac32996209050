"""One image from a local 2-worker Dask cluster: exact merges, a killed worker, many images."""

import os
import time

import numpy as np
import pytest

import vkengine
from vkengine import distributed as vd

distributed = pytest.importorskip("distributed")

# mc_budget=0: the ranges render whole paths, and `single`'s progressive mean must draw the same numbers.
JOB = vd.Job(size=(32, 32), settings={"renderer": "mcs", "n": 24, "mc_budget": 0}, seed=5)
FRAMES = 8


@pytest.fixture(scope="module")
def client():
    # Processes, not threads: each worker has its own device, as on separate machines.
    cluster = distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True, dashboard_address=None,
                                       silence_logs=40)
    c = distributed.Client(cluster)
    try:
        yield c
    finally:
        c.close()
        cluster.close()


@pytest.fixture(scope="module")
def single():
    """The same frames in this process: per range (the merge's own pieces) and whole."""
    r = JOB.renderer()
    parts = [vkengine.Accumulation(*r.accumulate(a, b), [(a, b)]) for a, b in vd.split(FRAMES, 4)]
    whole = r.accumulate(0, FRAMES)
    progressive = r.render(frames=FRAMES)
    return parts, whole, progressive


def test_four_ranges_on_two_workers_merge_exactly(client, single):
    parts, (whole, n), progressive = single
    seen = []
    acc = vd.render_image(client, JOB, FRAMES, chunks=4, progress=lambda d, t, r, w: seen.append((d, t, r)))
    assert acc.count == FRAMES and acc.ranges == vd.split(FRAMES, 4)
    # Fixed merge order: bit for bit the single process's merge of the same ranges.
    assert np.array_equal(acc.sum, vkengine.merge(parts).sum)
    # Against one pass over all frames and the GPU's float32 progressive mean: summation error.
    np.testing.assert_allclose(acc.sum, whole, rtol=1e-12, atol=0)
    np.testing.assert_allclose(acc.image(), progressive, rtol=1e-5, atol=1e-6)
    assert [d for d, _, _ in seen] == [2, 4, 6, 8] and all(t == FRAMES for _, t, _ in seen)


def test_killed_worker_range_is_rerun_once(client, single, tmp_path):
    parts, _, _ = single
    chaos = str(tmp_path / "chaos")
    acc = vd.render_image(client, JOB, FRAMES, chunks=4, drill=("kill", chaos))
    assert np.array_equal(acc.sum, vkengine.merge(parts).sum) and acc.count == FRAMES
    lines = [ln.split() for ln in open(os.path.join(chaos, "attempts.log"))]
    killed = tuple(int(x) for x in open(os.path.join(chaos, "chosen")).read().split()[:2])
    starts = [tuple(map(int, ln[1:3])) for ln in lines if ln[0] == "start"]
    dones = [tuple(map(int, ln[1:3])) for ln in lines if ln[0] == "done"]
    assert starts.count(killed) == 2, lines  # killed once, run again once
    assert sorted(dones) == vd.split(FRAMES, 4), lines  # every range completed exactly once


def test_numpy_volume_job_survives_a_killed_worker(client, tmp_path):
    job = vd.Job(volume=np.linspace(0, 1, 16**3, dtype=np.float32).reshape(16, 16, 16), size=(24, 24),
                 settings={"renderer": "mcs"}, tf="cloud", seed=2)
    r = job.renderer()
    expected = vkengine.merge(vkengine.Accumulation(*r.accumulate(a, b), [(a, b)]) for a, b in vd.split(4, 2))
    acc = vd.render_image(client, job, 4, chunks=2, drill=("kill", str(tmp_path / "chaos")))
    assert np.array_equal(acc.sum, expected.sum) and acc.count == 4


def test_stalled_range_is_resubmitted_and_counted_once(client, single, tmp_path):
    parts, _, _ = single
    chaos = str(tmp_path / "chaos")
    t0 = time.monotonic()
    acc = vd.render_image(client, JOB, FRAMES, chunks=4, timeout=2.0, drill=("stall", chaos))
    assert time.monotonic() - t0 < vd.STALL_S, "the copy must finish before the stalled attempt"
    assert np.array_equal(acc.sum, vkengine.merge(parts).sum) and acc.count == FRAMES
    stalled = tuple(int(x) for x in open(os.path.join(chaos, "chosen")).read().split()[:2])
    starts = [tuple(map(int, ln.split()[1:3])) for ln in open(os.path.join(chaos, "attempts.log")) if ln.startswith("start")]
    assert starts.count(stalled) == 2
    # The stalled attempt still holds its worker: let it end before the next test.
    time.sleep(max(0.0, vd.STALL_S - (time.monotonic() - t0)) + 0.5)


def test_turntable_views_equal_single_process_renders(client):
    jobs = vd.turntable(vd.Job(size=(24, 24), settings={"renderer": "eam", "n": 16}), views=3)
    images = vd.render_many(client, jobs, frames=1)
    assert len(images) == 3
    for job, img in zip(jobs, images):
        r = job.renderer()
        r.orbit(**job.orbit)
        np.testing.assert_array_equal(img, r.render(frames=1))
    assert not np.array_equal(images[0], images[1])


def test_split_and_timeouts_are_checked():
    assert vd.split(10, 3) == [(0, 3), (3, 7), (7, 10)]
    assert vd.split(2, 5) == [(0, 1), (1, 2)]
    with pytest.raises(ValueError):
        vd.split(0, 2)


def _job_images(jobs):
    """Each job rendered through this process's worker path (its renderer cache), then alone."""
    via_cache = [vd.render_view(j, 1)["image"] for j in jobs]
    alone = []
    for j in jobs:
        r = j.renderer()
        alone.append(r.render(frames=1))
        r.close()
    return via_cache, alone


def test_keys_see_array_values_past_numpys_repr_cutoff():
    a = np.ones((40, 80, 3), np.float32)
    b = a.copy()
    b[4:36, 4:40] = 4.0  # a brighter block, inside the part numpy's repr leaves out ("...")
    assert repr(a) == repr(b) and repr({"env": a}) == repr({"env": b})
    jobs = [vd.Job(size=(16, 16), settings={"renderer": "mcs", "n": 16, "env": e}, seed=1) for e in (a, b)]
    assert jobs[0].key() != jobs[1].key()
    via_cache, alone = _job_images(jobs)
    for got, want in zip(via_cache, alone):
        np.testing.assert_array_equal(got, want)
    assert not np.array_equal(via_cache[0], via_cache[1])


def test_keys_hash_every_setting_and_survive_turntable_and_pickling():
    import pickle

    vol = np.linspace(0, 1, 12**3, dtype=np.float32).reshape(12, 12, 12)
    job = vd.Job(volume=vol, size=(16, 16), settings={"renderer": "eam"}, tf=vkengine.TransferFunction.preset("cloud"))
    keys = {job.key()}
    for change in ({"volume": vol[::-1]}, {"volume": vkengine.Volume(vol)}, {"spacing": (1, 1, 2)},
                   {"tf": "bone"}, {"seed": 1}, {"size": (16, 17)}, {"settings": {"renderer": "eam", "n": 3}}):
        keys.add(vd.replace(job, **change).key())
    assert len(keys) == 8
    views = vd.turntable(job, views=4)
    # The key is computed once and travels with every view and through pickle.
    assert all(v.__dict__.get("_key") == job.key() and "_volume_key" in v.__dict__ for v in views)
    back = pickle.loads(pickle.dumps(views[1]))
    assert back.key() == job.key() and back.orbit == views[1].orbit
    assert isinstance(back.tf, vkengine.TransferFunction) and back.tf.to_json() == job.tf.to_json()
    # What ships with each task: the job without its volume, key kept.
    stub, data = views[2]._shipped()
    assert data is vol and stub.key() == job.key() and "sent apart" in repr(stub.volume)
    # A task whose volume went missing fails instead of rendering the procedural scene.
    with pytest.raises(RuntimeError, match="did not arrive"):
        vd.render_view(pickle.loads(pickle.dumps(stub)), 1)


def test_thirty_six_views_send_the_volume_once_per_worker(client):
    vol = np.random.default_rng(3).random((96, 96, 96), dtype=np.float32)
    job = vd.Job(volume=vol, size=(8, 8), settings={"renderer": "eam"}, tf="cloud")
    vd.count_bytes_received(client)
    images = vd.render_many(client, vd.turntable(job, views=36), frames=1)
    received = vd.bytes_received(client)
    workers = len(received)
    assert len(images) == 36 and workers == 2
    total = sum(received.values())
    assert total <= 1.1 * vol.nbytes * workers, (total / vol.nbytes, received)
    assert total >= vol.nbytes * workers, "each worker holds the volume"
    # Another call with the same volume (another object, same values) sends it no more; new
    # values in the same array are sent again, and rendered.
    vd.count_bytes_received(client)
    vd.render_many(client, vd.turntable(vd.replace(job, volume=vol.copy(), tf="bone"), views=4), frames=1)
    assert sum(vd.bytes_received(client).values()) < 0.1 * vol.nbytes
    before = vd.render_many(client, [job], frames=1)[0]
    vol[:] = vol[::-1]
    vd.count_bytes_received(client)
    after = vd.render_many(client, [vd.replace(job)], frames=1)[0]
    assert sum(vd.bytes_received(client).values()) >= vol.nbytes
    assert not np.array_equal(before, after)
    vd.release(client)


def test_a_worker_with_four_threads_renders_one_job_at_a_time():
    # Four threads of one process run worker tasks at once: the process lock takes them in turn.
    from concurrent.futures import ThreadPoolExecutor

    jobs = vd.turntable(vd.Job(size=(24, 24), settings={"renderer": "mcs", "n": 24}, seed=2), views=4)
    with ThreadPoolExecutor(4) as pool:
        out = list(pool.map(lambda j: vd.render_view(j, 2), jobs * 2))
    spans = sorted((o["began"], o["ended"]) for o in out)
    assert all(a[1] <= b[0] for a, b in zip(spans, spans[1:])), spans
    for job, o in zip(jobs * 2, out):
        r = job.renderer()
        r.orbit(**job.orbit)
        np.testing.assert_array_equal(o["image"], r.render(frames=2))


def test_recipe_cluster_pins_a_device_per_worker_and_runs_one_render_each(tmp_path):
    import shutil
    import subprocess
    import sys

    dask = shutil.which("dask", path=os.path.dirname(sys.executable)) or shutil.which("dask")
    sched_file = str(tmp_path / "scheduler.json")
    env = {**os.environ, "DASK_DISTRIBUTED__LOGGING__DISTRIBUTED": "error", "VKENGINE_VALIDATION": "0"}
    procs = [subprocess.Popen([dask, "scheduler", "--scheduler-file", sched_file, "--port", "0",
                               "--dashboard-address", ":0"], env=env, stderr=subprocess.DEVNULL)]
    try:
        while not os.path.exists(sched_file):
            time.sleep(0.2)
        # The documented recipe: one worker process per GPU, each pinned by the preload.
        procs.append(subprocess.Popen([dask, "worker", "--scheduler-file", sched_file, "--nworkers", "2",
                                       "--nthreads", "4", "--preload", "vkengine.distributed", "--no-dashboard"],
                                      env=env, stderr=subprocess.DEVNULL))
        with distributed.Client(scheduler_file=sched_file) as c:
            c.wait_for_workers(2, timeout=120)
            assert len(vd.gpu_workers(c)) == 2
            pinned = c.run(lambda dask_worker: dask_worker.vkengine_device)
            assert sorted(pinned.values()) == ["#0", "#0"], pinned  # one device here: both on it
            # An explicit list, one entry per worker slot.
            pinned = vd.pin_gpus(c, devices=["#0", "llvmpipe"])
            assert sorted(pinned.values()) == ["#0", "llvmpipe"], pinned
            reports = []
            jobs = vd.turntable(vd.Job(size=(24, 24), settings={"renderer": "mcs", "n": 24}), views=8)
            images = vd.render_many(c, jobs, frames=2, retries=0, reports=reports)
            assert len(images) == 8
            by_pid = {}
            for rep in reports:
                assert rep["pinned"] in ("#0", "llvmpipe") and rep["device"].startswith("#0 llvmpipe"), rep
                by_pid.setdefault(rep["pid"], set()).add(rep["pinned"])
                assert len(by_pid[rep["pid"]]) == 1, by_pid  # a worker keeps its device
            for pid in by_pid:
                spans = sorted((r["began"], r["ended"]) for r in reports if r["pid"] == pid)
                assert all(a[1] <= b[0] for a, b in zip(spans, spans[1:])), spans
            acc = vd.render_image(c, vd.Job(size=(16, 16), settings={"renderer": "mcs", "n": 16}), 4, retries=0)
            assert acc.ranges == [(0, 2), (2, 4)] and len(acc.reports) == 2  # one range per GPU worker
            assert sum(vd.release(c).values()) >= 1
    finally:
        for p in reversed(procs):
            p.terminate()
        for p in procs:
            try:
                p.wait(timeout=30)
            except subprocess.TimeoutExpired:
                p.kill()
