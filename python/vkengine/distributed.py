"""Rendering on a Dask cluster: one image from many workers, and many images at once.

A ``Job`` describes a render (volume, settings, size, camera) and is shipped to workers once;
each worker process keeps one ``Renderer`` per job (device and volume upload are paid once).

* ``render_image``: frames ``0..frames`` split into disjoint ranges, one task each; every task
  returns its range's exact float64 sum (``Renderer.accumulate``) and the ranges merge in a
  fixed order, so the image is the same bit for bit whichever worker rendered what.
* ``render_many``: one task per job (a turntable's views, a parameter sweep), each the image
  ``volume --frames N`` would write.

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
import time
from concurrent.futures import CancelledError
from dataclasses import dataclass, field, replace
from functools import cached_property
from typing import Any, Callable, Dict, List, Optional, Sequence, Tuple

import numpy as np

from .accumulation import Accumulation, merge

Range = Tuple[int, int]
Progress = Callable[[int, int, Range, str], None]


@dataclass(frozen=True)
class Job:
    """A render a worker can rebuild: everything ``Renderer`` takes, plus the camera."""

    volume: Optional[Any] = None
    """A numpy array ``[z, y, x]``, a file path, or ``None`` for the procedural scene."""
    spacing: Optional[Tuple[float, float, float]] = None
    origin: Optional[Tuple[float, float, float]] = None
    size: Tuple[int, int] = (256, 256)
    settings: Dict[str, Any] = field(default_factory=dict)
    tf: Optional[str] = None
    """A preset, the CLI's ``tf=`` text, or JSON (``TransferFunction.to_json()``)."""
    seed: int = 0
    orbit: Optional[Dict[str, Any]] = None
    """Keywords of ``Renderer.orbit`` (yaw, pitch, distance, target)."""
    validation: Optional[bool] = None

    def key(self) -> str:
        """Identifies the renderer this job needs (everything but the camera); computed once and
        shipped with the job, so workers do not hash a large volume again for every task."""
        return self._key

    @cached_property
    def _key(self) -> str:
        h = hashlib.sha1()
        v = self.volume
        if isinstance(v, np.ndarray):
            h.update(str((v.dtype.str, v.shape)).encode())
            h.update(np.ascontiguousarray(v).tobytes())
        else:
            h.update(repr(v).encode())
        rest = (self.spacing, self.origin, tuple(self.size), sorted(self.settings.items()), self.tf, self.seed,
                self.validation)
        h.update(repr(rest).encode())
        return h.hexdigest()

    def renderer(self):
        """A new ``Renderer`` for this job (on the calling process's device)."""
        from . import TransferFunction, Renderer, Volume

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


_RENDERERS: Dict[str, Any] = {}


def _renderer_for(job: Job):
    """This process's renderer for ``job``, built on first use; the camera set per call."""
    k = job.key()
    r = _RENDERERS.get(k)
    if r is None:
        # One volume on the device at a time: a worker moving on to another job frees the last.
        _RENDERERS.clear()
        r = _RENDERERS[k] = job.renderer()
    r.reset_camera()
    if job.orbit:
        r.orbit(**job.orbit)
    return r


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


def render_range(job: Job, start: int, stop: int, drill: Optional[Tuple[str, str]] = None) -> Dict[str, Any]:
    """Worker task: the exact sum of frames ``start..stop`` of ``job``."""
    _drill(drill, (start, stop), "start")
    t0 = time.perf_counter()
    r = _renderer_for(job)
    s, n = r.accumulate(start, stop)
    _drill(drill, (start, stop), "done")
    return {"sum": s, "count": n, "range": (start, stop), "pid": os.getpid(), "seconds": time.perf_counter() - t0}


def render_view(job: Job, frames: int) -> np.ndarray:
    """Worker task: ``frames`` progressive frames of ``job`` (the CLI's image)."""
    r = _renderer_for(job)
    r.reset()
    return r.render(frames=frames)


def split(frames: int, chunks: int) -> List[Range]:
    """``0..frames`` as ``chunks`` disjoint ranges of (nearly) equal length."""
    if frames < 1 or chunks < 1:
        raise ValueError(f"frames={frames}, chunks={chunks}: both must be >= 1")
    chunks = min(chunks, frames)
    edges = [round(i * frames / chunks) for i in range(chunks + 1)]
    return [(edges[i], edges[i + 1]) for i in range(chunks)]


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

    def submit(key, attempt):
        fn, args = tasks[key]
        args = args() if callable(args) else args
        fut = client.submit(fn, *args, pure=False, key=f"vkengine-{fn.__name__}-{key}-{attempt}-{time.monotonic_ns()}")
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


def render_image(client, job: Job, frames: int, chunks: Optional[int] = None, timeout: Optional[float] = None,
                 retries: int = 1, progress: Optional[Progress] = None,
                 drill: Optional[Tuple[str, str]] = None) -> Accumulation:
    """Renders frames ``0..frames`` of ``job`` as ``chunks`` ranges on ``client``'s workers and
    merges them exactly; ``.image()`` of the result is the mean. ``progress(done, total, range,
    worker)`` is called as ranges complete. ``drill`` (tests, fire drills): ``("kill", DIR)`` or
    ``("stall", DIR)``, see ``_drill``."""
    if chunks is None:
        chunks = max(1, len(client.scheduler_info().get("workers", {})))
    ranges = split(frames, chunks)
    shipped: List[Any] = []

    def job_ref():
        """A volume array goes to the workers once, not with every task; after the workers that
        held it died (the scheduler forgets such data) it is sent again. A file path or a
        procedural scene travels with each task."""
        if not isinstance(job.volume, np.ndarray):
            return job
        if not shipped or shipped[0].status != "finished":
            shipped[:] = [client.scatter(job, broadcast=True, hash=False)]
        return shipped[0]

    tasks = {r: (render_range, lambda r=r: (job_ref(), r[0], r[1], drill)) for r in ranges}
    done_frames = [0]

    def on_done(rng, value):
        done_frames[0] += value["count"]
        if progress:
            progress(done_frames[0], frames, rng, f"pid {value['pid']}")

    results = _run(client, tasks, timeout, retries, on_done)
    return merge(Accumulation(v["sum"], v["count"], [v["range"]]) for v in results.values())


def render_many(client, jobs: Sequence[Job], frames: int, timeout: Optional[float] = None, retries: int = 1,
                progress: Optional[Callable[[int, int], None]] = None) -> List[np.ndarray]:
    """One task per job (a turntable's views, a settings sweep): each returns the float32 image
    of ``frames`` progressive frames, in the order of ``jobs``."""
    tasks = {i: (render_view, (job, frames)) for i, job in enumerate(jobs)}
    count = [0]

    def on_done(_i, _v):
        count[0] += 1
        if progress:
            progress(count[0], len(jobs))

    results = _run(client, tasks, timeout, retries, on_done)
    return [results[i] for i in range(len(jobs))]


def turntable(job: Job, views: int, pitch: Optional[float] = None) -> List[Job]:
    """``views`` jobs around the volume, yaw ``2πk / views`` (the framed distance kept)."""
    out = []
    for k in range(views):
        orbit = dict(job.orbit or {})
        orbit["yaw"] = 2 * math.pi * k / views
        if pitch is not None:
            orbit["pitch"] = pitch
        out.append(replace(job, orbit=orbit))
    return out
