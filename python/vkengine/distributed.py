"""Rendering on a Dask cluster: one image from many workers, and many images at once.

A ``Job`` describes a render (volume, settings, size, camera). Its volume array is scattered to
the workers once per call (broadcast when every worker needs it), never sent with each task; the
job's key, a hash of the volume's bytes and every setting's full value, is computed once on the
client and names the ``Renderer`` each worker process keeps for it (device creation and volume
upload paid once per worker).

* ``render_image``: frames ``0..frames`` split into disjoint ranges, one task each; every task
  returns its range's exact float64 sum (``Renderer.accumulate``) and the ranges merge in a
  fixed order, so the image is the same bit for bit whichever worker rendered what.
* ``render_many``: one task per job (a turntable's views, a parameter sweep), each the image
  ``volume --frames N`` would write.

GPUs: ``pin_gpus(client)`` (or ``dask worker --preload vkengine.distributed``) gives each worker
process its own device (``vkengine.gpus``) and the resource ``GPU=1``; render tasks then ask for
``resources={"GPU": 1}``, so a worker runs one render at a time whatever its thread count and
CPU-only workers get none. A process-wide lock also keeps two tasks of one worker from sharing
its renderer at once where no worker advertises GPUs.

A task whose worker dies is run again elsewhere (Dask reschedules it; a task that still fails
is resubmitted up to ``retries`` times); a task that runs past ``timeout`` seconds is
submitted once more and the first result wins. Results are keyed by frame range, so a range is
never counted twice, however many copies of it ran.
"""

from __future__ import annotations

import asyncio
import hashlib
import math
import os
import signal
import tempfile
import threading
import time
from concurrent.futures import CancelledError
from dataclasses import dataclass, field, replace
from functools import cached_property
from typing import Any, Callable, Dict, List, Optional, Sequence, Tuple

import numpy as np

from . import gpus
from .accumulation import Accumulation, merge

try:
    from distributed.diagnostics.plugin import WorkerPlugin
except ImportError:  # Dask is optional: the plugin needs it, the rest of the package does not
    WorkerPlugin = object  # type: ignore[assignment,misc]

Range = Tuple[int, int]
Progress = Callable[[int, int, Range, str], None]
GPU = {"GPU": 1}
"""The resources a render task asks for."""


def _digest(h, obj) -> None:
    """Feeds ``obj``'s full value to ``h``: arrays by dtype, shape and bytes (never their
    ``repr``, which numpy shortens with "..."), containers item by item, volumes and transfer
    functions by content, anything else by ``repr``."""
    from . import TransferFunction, Volume

    if isinstance(obj, np.ndarray):
        h.update(f"ndarray{obj.dtype.str}{obj.shape}".encode())
        h.update(np.ascontiguousarray(obj).tobytes())
    elif isinstance(obj, Volume):
        h.update(f"Volume{obj.spacing}{obj.origin}{obj.source!r}".encode())
        _digest(h, obj.to_numpy())
    elif isinstance(obj, TransferFunction):
        h.update(b"TransferFunction" + obj.to_json().encode())
    elif isinstance(obj, dict):
        h.update(f"dict{len(obj)}".encode())
        for k in sorted(obj, key=repr):
            _digest(h, k)
            _digest(h, obj[k])
    elif isinstance(obj, (list, tuple)):
        h.update(f"{type(obj).__name__}{len(obj)}".encode())
        for x in obj:
            _digest(h, x)
    else:
        h.update(f"{type(obj).__name__}:{obj!r};".encode())


@dataclass(frozen=True)
class Job:
    """A render a worker can rebuild: everything ``Renderer`` takes, plus the camera."""

    volume: Optional[Any] = None
    """A numpy array ``[z, y, x]``, a ``Volume``, a file path, or ``None`` for the procedural scene."""
    spacing: Optional[Tuple[float, float, float]] = None
    origin: Optional[Tuple[float, float, float]] = None
    size: Tuple[int, int] = (256, 256)
    settings: Dict[str, Any] = field(default_factory=dict)
    """``Renderer`` keywords (arrays such as ``env=`` included)."""
    tf: Optional[Any] = None
    """A ``TransferFunction``, a preset, the CLI's ``tf=`` text, or JSON (``TransferFunction.to_json()``)."""
    seed: int = 0
    orbit: Optional[Dict[str, Any]] = None
    """Keywords of ``Renderer.orbit`` (yaw, pitch, distance, target)."""
    validation: Optional[bool] = None

    def key(self) -> str:
        """Identifies the renderer this job needs (everything but the camera): a hash of the
        volume's bytes and every setting's full value. Computed once and shipped with the job,
        so workers do not hash a large volume again for every task; so a job whose array was
        changed in place afterwards keeps its old key: make a new ``Job`` (``replace(job)``)."""
        return self._key

    @cached_property
    def _volume_key(self) -> str:
        h = hashlib.sha256()
        _digest(h, self.volume)
        return h.hexdigest()

    @cached_property
    def _key(self) -> str:
        h = hashlib.sha256(self._volume_key.encode())
        _digest(h, (self.spacing, self.origin, tuple(self.size), self.settings, self.tf, self.seed, self.validation))
        return h.hexdigest()

    def _keyed_like(self, other: "Job") -> "Job":
        """This job with ``other``'s keys (its volume and settings are ``other``'s)."""
        self.__dict__["_volume_key"] = other._volume_key
        self.__dict__["_key"] = other.key()
        return self

    def renderer(self):
        """A new ``Renderer`` for this job (on the calling process's device)."""
        from . import Renderer, TransferFunction, Volume

        vol = self.volume
        if isinstance(vol, np.ndarray):
            vol = Volume(vol, spacing=self.spacing, origin=self.origin)
        elif isinstance(vol, (str, os.PathLike)):
            vol = Volume.load(os.fspath(vol), spacing=self.spacing)
        tf: Any = self.tf
        if isinstance(tf, str) and tf.lstrip().startswith("{"):
            tf = TransferFunction.from_json(tf)
        return Renderer(vol, size=tuple(self.size), tf=tf, seed=self.seed, validation=self.validation,
                        **self.settings)

    def _shipped(self) -> Tuple["Job", Any]:
        """This job without its volume data (its key kept), and the data: what travels once."""
        from . import Volume

        if not isinstance(self.volume, (np.ndarray, Volume)):
            return self, None
        return replace(self, volume=_SENT_APART)._keyed_like(self), self.volume


class _SentApart:
    """A job's volume that travels apart from it (scattered once)."""

    def __repr__(self) -> str:
        return "<volume sent apart>"

    def __reduce__(self):
        return (_sent_apart, ())


def _sent_apart() -> "_SentApart":
    return _SENT_APART


_SENT_APART = _SentApart()
_RENDERERS: Dict[str, Any] = {}
_LOCK = threading.Lock()
"""Held by a task for as long as it uses this process's renderer (camera, frames, readback)."""


def _renderer_for(job: Job, volume: Any = None):
    """This process's renderer for ``job`` (``volume``: its data, when shipped apart), built on
    first use; the camera set per call. Call with ``_LOCK`` held."""
    k = job.key()
    r = _RENDERERS.get(k)
    if r is None:
        # One volume on the device at a time: a worker moving on to another job frees the last.
        _release_renderers()
        if isinstance(job.volume, _SentApart) and volume is None:
            # Never render the procedural scene in its place.
            raise RuntimeError(f"job {k[:12]}: its volume was sent apart but did not arrive with the task")
        built = replace(job, volume=volume) if volume is not None else job
        r = _RENDERERS[k] = built.renderer()
    r.reset_camera()
    if job.orbit:
        r.orbit(**job.orbit)
    return r


def _release_renderers() -> int:
    """Closes this process's renderers (their device memory is freed at once)."""
    n = len(_RENDERERS)
    for r in _RENDERERS.values():
        r.close()
    _RENDERERS.clear()
    return n


def _release_here() -> int:
    with _LOCK:
        return _release_renderers()


def release(client) -> Dict[str, int]:
    """Frees every worker's renderers (device, volume, images) and the volumes kept on the
    cluster now; returns how many renderers each worker closed."""
    for k in [k for k in _SENT if k[0] == client.id]:
        del _SENT[k]
    return client.run(_release_here)


STALL_S = 8.0
"""How long a ``("stall", DIR)`` drill holds its worker."""


def _drill(drill: Optional[Tuple[str, str]], rng: Range, event: str) -> None:
    """Test and drill hook. ``drill = (mode, DIR)``: every attempt is logged in
    ``DIR/attempts.log``, and the first range to start anywhere in the cluster either kills its
    worker process (``"kill"``: ``SIGKILL``, no cleanup, like a crashed node) or sleeps
    ``STALL_S`` seconds (``"stall"``: a hung node, for ``timeout``)."""
    if not drill:
        return
    mode, folder = drill
    os.makedirs(folder, exist_ok=True)
    with open(os.path.join(folder, "attempts.log"), "a") as f:
        f.write(f"{event} {rng[0]} {rng[1]} {os.getpid()}\n")
    if event != "start":
        return
    try:
        # O_EXCL: exactly one attempt in the whole cluster takes the marker.
        fd = os.open(os.path.join(folder, "chosen"), os.O_CREAT | os.O_EXCL | os.O_WRONLY)
    except FileExistsError:
        return
    os.write(fd, f"{rng[0]} {rng[1]} {os.getpid()}".encode())
    os.close(fd)
    if mode == "kill":
        os.kill(os.getpid(), signal.SIGKILL)
    elif mode == "stall":
        time.sleep(STALL_S)
    else:
        raise ValueError(f"drill mode {mode!r}: expected 'kill' or 'stall'")


def _where() -> Dict[str, Any]:
    """Who ran a task: process, and the device this process was pinned to (if it was)."""
    return {"pid": os.getpid(), "pinned": os.environ.get("VKENGINE_DEVICE")}


def render_range(job: Job, start: int, stop: int, drill: Optional[Tuple[str, str]] = None,
                 volume: Any = None) -> Dict[str, Any]:
    """Worker task: the exact sum of frames ``start..stop`` of ``job`` (``volume``: its data,
    when shipped apart), with the device that rendered it and the task's start and end times."""
    _drill(drill, (start, stop), "start")
    with _LOCK:
        t0 = time.perf_counter()
        began = time.time()
        r = _renderer_for(job, volume)
        s, n = r.accumulate(start, stop)
        out = {"sum": s, "count": n, "range": (start, stop), "device": r.device, "seconds": time.perf_counter() - t0,
               "began": began, "ended": time.time(), **_where()}
    _drill(drill, (start, stop), "done")
    return out


def render_view(job: Job, frames: int, volume: Any = None) -> Dict[str, Any]:
    """Worker task: ``frames`` progressive frames of ``job`` (the CLI's image) as ``image``,
    with the device that rendered it and the task's start and end times."""
    with _LOCK:
        began = time.time()
        r = _renderer_for(job, volume)
        r.reset()
        image = r.render(frames=frames)
        return {"image": image, "device": r.device, "began": began, "ended": time.time(), **_where()}


def split(frames: int, chunks: int) -> List[Range]:
    """``0..frames`` as ``chunks`` disjoint ranges of (nearly) equal length."""
    if frames < 1 or chunks < 1:
        raise ValueError(f"frames={frames}, chunks={chunks}: both must be >= 1")
    chunks = min(chunks, frames)
    edges = [round(i * frames / chunks) for i in range(chunks + 1)]
    return [(edges[i], edges[i + 1]) for i in range(chunks)]


def gpu_workers(client) -> List[str]:
    """The workers that advertise the resource ``GPU`` (``pin_gpus``, ``--resources GPU=1``)."""
    workers = client.scheduler_info(n_workers=-1).get("workers", {})
    return [a for a, w in workers.items() if (w.get("resources") or {}).get("GPU", 0) >= 1]


def _resources(client) -> Optional[Dict[str, int]]:
    """``{"GPU": 1}`` when some worker has a GPU, so render tasks go only there, one at a
    time; else nothing (every worker renders, one task at a time by ``_LOCK``)."""
    return GPU if gpu_workers(client) else None


def _run(client, tasks: Dict[Any, Tuple[Callable, Any]], timeout: Optional[float], retries: int,
         on_done: Callable[[Any, Any], None]) -> Dict[Any, Any]:
    """Runs one task per key until each has one result: resubmits failures (up to ``retries``
    times) and tasks past ``timeout`` (once); the first result per key wins, later copies are
    cancelled or ignored."""
    from distributed import wait

    results: Dict[Any, Any] = {}
    live: Dict[Any, Tuple[Any, int, float]] = {}  # future -> (key, attempt, submitted at)
    failures: Dict[Any, int] = {}
    timed_out: set = set()
    resources = _resources(client)

    def submit(key, attempt):
        fn, args = tasks[key]
        args = args() if callable(args) else args
        fut = client.submit(fn, *args, pure=False, resources=resources,
                            key=f"vkengine-{fn.__name__}-{key}-{attempt}-{time.monotonic_ns()}")
        live[fut] = (key, attempt, time.monotonic())

    for key in tasks:
        submit(key, 0)
    while len(results) < len(tasks):
        try:
            done, _ = wait(list(live), timeout=0.25 if timeout else None, return_when="FIRST_COMPLETED")
        except (Exception, CancelledError, asyncio.CancelledError):
            # `wait` raises when a future was cancelled (its data lost with a dead worker); those
            # are failures like any other, handled below.
            done = {f for f in live if f.status in ("finished", "error", "cancelled")}
            if not done:
                time.sleep(0.1)
        for fut in done:
            key, attempt, _ = live.pop(fut)
            if key in results:
                continue
            try:
                value = fut.result()
            except (Exception, CancelledError, asyncio.CancelledError) as e:  # any failure is retried
                failures[key] = failures.get(key, 0) + 1
                if failures[key] > retries:
                    raise RuntimeError(f"task {key} failed {failures[key]} times; last: {e!r}") from e
                submit(key, attempt + 1)
                continue
            results[key] = value
            on_done(key, value)
            for other, (k, _, _) in list(live.items()):
                if k == key:
                    other.cancel()
                    live.pop(other)
        if timeout:
            now = time.monotonic()
            for fut, (key, attempt, t) in list(live.items()):
                if key not in results and key not in timed_out and now - t > timeout:
                    timed_out.add(key)
                    submit(key, attempt + 1)
    return results


SHIP_ONCE = True
"""Send each volume to the workers once (``False``: with every task, as a comparison for
``python/bench/transfer.py``)."""


_SENT: Dict[Tuple[str, str], Any] = {}
"""(client id, volume key) -> the scattered volume's future: the volumes on each cluster."""
_SENT_KEPT = 4
"""Volumes kept on a cluster for later calls (the oldest is let go first)."""


class _Shipper:
    """Sends each distinct volume (by content) to a cluster once, also across calls (broadcast
    where every worker needs it); after the workers that held it died (the scheduler forgets
    such data) it is sent again."""

    def __init__(self, client, broadcast: bool):
        self.client, self.broadcast = client, broadcast

    def args(self, job: Job) -> Tuple[Job, Any]:
        """``(job without its data, the data's future or None)`` for a task."""
        stub, data = job._shipped()
        if data is None or not SHIP_ONCE:
            return (stub, data) if data is None else (job, None)
        key = (self.client.id, stub._volume_key)
        fut = _SENT.pop(key, None)
        if fut is None or fut.status != "finished":
            fut = self.client.scatter(data, broadcast=self.broadcast, hash=False)
        _SENT[key] = fut  # now the most recent
        mine = [k for k in _SENT if k[0] == self.client.id]
        for old in mine[:-_SENT_KEPT]:
            del _SENT[old]
        return stub, fut


def _n_render_workers(client) -> int:
    return max(1, len(gpu_workers(client)) or len(client.scheduler_info(n_workers=-1).get("workers", {})))


def render_image(client, job: Job, frames: int, chunks: Optional[int] = None, timeout: Optional[float] = None,
                 retries: int = 1, progress: Optional[Progress] = None,
                 drill: Optional[Tuple[str, str]] = None) -> Accumulation:
    """Renders frames ``0..frames`` of ``job`` as ``chunks`` ranges (default: one per GPU
    worker, else per worker) on ``client``'s workers and merges them exactly; ``.image()`` of
    the result is the mean, ``.reports`` says which device rendered each range.
    ``progress(done, total, range, worker)`` is called as ranges complete. ``drill`` (tests,
    fire drills): ``("kill", DIR)`` or ``("stall", DIR)``, see ``_drill``."""
    if chunks is None:
        chunks = _n_render_workers(client)
    ranges = split(frames, chunks)
    shipper = _Shipper(client, broadcast=len(ranges) > 1)

    def args(r):
        stub, data = shipper.args(job)
        return (stub, r[0], r[1], drill, data)

    tasks = {r: (render_range, lambda r=r: args(r)) for r in ranges}
    done_frames = [0]

    def on_done(rng, value):
        done_frames[0] += value["count"]
        if progress:
            progress(done_frames[0], frames, rng, f"pid {value['pid']}")

    results = _run(client, tasks, timeout, retries, on_done)
    acc = merge(Accumulation(v["sum"], v["count"], [v["range"]]) for v in results.values())
    acc.reports = [{k: v for k, v in results[r].items() if k != "sum"} for r in sorted(results)]
    return acc


def render_many(client, jobs: Sequence[Job], frames: int, timeout: Optional[float] = None, retries: int = 1,
                progress: Optional[Callable[[int, int], None]] = None,
                reports: Optional[List[Dict[str, Any]]] = None) -> List[np.ndarray]:
    """One task per job (a turntable's views, a settings sweep): each returns the float32 image
    of ``frames`` progressive frames, in the order of ``jobs``. Each distinct volume is sent to
    the workers once. ``reports``: a list to extend with each view's device, process and times."""
    shipper = _Shipper(client, broadcast=len(jobs) > 1)

    def args(job):
        stub, data = shipper.args(job)
        return (stub, frames, data)

    tasks = {i: (render_view, lambda job=job: args(job)) for i, job in enumerate(jobs)}
    count = [0]

    def on_done(_i, _v):
        count[0] += 1
        if progress:
            progress(count[0], len(jobs))

    results = _run(client, tasks, timeout, retries, on_done)
    if reports is not None:
        reports.extend({k: v for k, v in results[i].items() if k != "image"} for i in range(len(jobs)))
    return [results[i]["image"] for i in range(len(jobs))]


def turntable(job: Job, views: int, pitch: Optional[float] = None) -> List[Job]:
    """``views`` jobs around the volume, yaw ``2πk / views`` (the framed distance kept). They
    share the job's key (the camera is not part of it), computed once here."""
    out = []
    for k in range(views):
        orbit = dict(job.orbit or {})
        orbit["yaw"] = 2 * math.pi * k / views
        if pitch is not None:
            orbit["pitch"] = pitch
        out.append(replace(job, orbit=orbit)._keyed_like(job))
    return out


def _count_received() -> None:
    import distributed.comm.tcp as tcp

    if not hasattr(tcp, "_vkengine_read"):
        tcp._vkengine_read, tcp._vkengine_bytes = tcp.read_bytes_rw, [0]

        async def counted(stream, n):
            tcp._vkengine_bytes[0] += n
            return await tcp._vkengine_read(stream, n)

        tcp.read_bytes_rw = counted
    tcp._vkengine_bytes[0] = 0


def _received() -> int:
    import distributed.comm.tcp as tcp

    return getattr(tcp, "_vkengine_bytes", [0])[0]


def count_bytes_received(client) -> None:
    """From now on, counts the bytes each worker reads off its TCP connections (from the
    scheduler, clients and other workers): what ``bytes_received`` reports."""
    client.run(_count_received)


def bytes_received(client) -> Dict[str, int]:
    """Bytes each worker has read off its TCP connections since ``count_bytes_received``."""
    return client.run(_received)


class PinGPU(WorkerPlugin):
    """A worker plugin that gives each worker process one device (``vkengine.gpus``:
    ``devices`` if given, else the worker's ``CUDA_VISIBLE_DEVICES``, else round-robin over the
    node's devices) and the resource ``GPU=1``; register it with ``pin_gpus``."""

    name = "vkengine-pin-gpu"

    def __init__(self, devices: Optional[Sequence[str]] = None):
        self.devices = list(devices) if devices else None

    def pin(self, worker) -> str:
        """Chooses this worker's device and makes it the one its renderers open."""
        # One slot folder per cluster and node: the scheduler's address names the cluster.
        cluster = hashlib.sha256(str(worker.scheduler.address).encode()).hexdigest()[:12]
        folder = os.path.join(tempfile.gettempdir(), f"vkengine-gpu-slots-{cluster}")
        choice = gpus.choose_device(self.devices, slot_folder=folder)
        with _LOCK:
            _release_renderers()  # built on another device
            os.environ["VKENGINE_DEVICE"] = choice
        worker.vkengine_device = choice
        return choice

    async def setup(self, worker):
        self.pin(worker)
        await worker.set_resources(**GPU)


def pin_gpus(client, devices: Optional[Sequence[str]] = None) -> Dict[str, str]:
    """Registers ``PinGPU`` on every worker (and every worker that joins later); returns each
    worker's device choice."""
    client.register_plugin(PinGPU(devices))
    return client.run(lambda dask_worker: dask_worker.vkengine_device)


def _preload(worker, devices: Optional[Sequence[str]] = None) -> None:
    PinGPU(devices).pin(worker)
    worker.state.total_resources.update(GPU)
    worker.state.available_resources.update(GPU)


try:
    import click

    @click.command()
    @click.option("--vk-devices", default=None,
                  help="Comma-separated device choices indexed by the worker's slot on its node, or 'cuda' for "
                       "the entries of CUDA_VISIBLE_DEVICES (default: CUDA_VISIBLE_DEVICES's first, else round-robin)")
    def dask_setup(worker, vk_devices):
        """``dask worker --preload vkengine.distributed``: ``PinGPU`` at the worker's start,
        before it registers with the scheduler (which then learns its resource ``GPU=1``)."""
        _preload(worker, vk_devices.split(",") if vk_devices else None)
except ImportError:  # no Dask, no click: nothing preloads this module either

    def dask_setup(worker) -> None:  # type: ignore[misc]
        """``dask worker --preload vkengine.distributed`` (see above)."""
        _preload(worker)
