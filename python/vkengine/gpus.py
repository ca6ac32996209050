"""Which GPU a worker process renders on: one device per worker, every device of a node used.

Vulkan does not read ``CUDA_VISIBLE_DEVICES``, and identical GPUs share a name, so a worker is
pinned by setting ``VKENGINE_DEVICE`` to ``#N`` (Vulkan's device index) or ``uuid:…`` (the
device's UUID; NVIDIA's ``GPU-…`` identifiers are the same UUIDs) before its first renderer.
``choose_device`` decides, in this order:

1. an explicit list (``devices=["uuid:…", "#1"]``): the worker's slot on this node picks one;
   ``devices=["cuda"]`` is the list ``CUDA_VISIBLE_DEVICES`` holds (several workers sharing one
   environment, as ``dask worker --nworkers N`` in a SLURM job with N GPUs);
2. the worker's ``CUDA_VISIBLE_DEVICES`` (set per worker by dask-cuda, SLURM ``--gres``,
   Kubernetes): its first entry, a ``GPU-…`` UUID or an index;
3. round-robin: the worker's slot on this node over the node's supported devices.

A slot is the lowest number no live process on this node holds, claimed with a file per slot
(``O_EXCL``) in a folder shared by the workers of one cluster, so the workers of a node spread
over its devices whatever their names, and a restarted worker takes the slot its dead
predecessor left.
"""

from __future__ import annotations

import os
import re
import shutil
import subprocess
import tempfile
from typing import Mapping, Optional, Sequence


def _alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:
        return True
    return True


def claim_slot(folder: str) -> int:
    """The lowest slot number in ``folder`` no live process holds, now held by this process."""
    os.makedirs(folder, exist_ok=True)
    for k in range(4096):
        path = os.path.join(folder, f"slot-{k}")
        try:
            fd = os.open(path, os.O_CREAT | os.O_EXCL | os.O_WRONLY)
        except FileExistsError:
            try:
                with open(path) as f:
                    pid = int(f.read().strip() or "0")
            except (OSError, ValueError):
                continue
            if pid == os.getpid():
                return k
            if pid and _alive(pid):
                continue
            # Its holder died: take it over (a rename is atomic; the loser of a race re-reads).
            tmp = f"{path}.{os.getpid()}"
            with open(tmp, "w") as f:
                f.write(str(os.getpid()))
            os.replace(tmp, path)
            with open(path) as f:
                if f.read().strip() == str(os.getpid()):
                    return k
            continue
        os.write(fd, str(os.getpid()).encode())
        os.close(fd)
        return k
    raise RuntimeError(f"{folder}: no free GPU slot among 4096")


def _nvidia_uuid(index: int) -> Optional[str]:
    """The UUID ``nvidia-smi`` gives GPU ``index`` (its PCI-bus order), if nvidia-smi is here."""
    exe = shutil.which("nvidia-smi")
    if not exe:
        return None
    try:
        out = subprocess.run([exe, "--query-gpu=index,uuid", "--format=csv,noheader"], capture_output=True,
                             text=True, timeout=20, check=True).stdout
    except (OSError, subprocess.SubprocessError):
        return None
    for line in out.splitlines():
        parts = [p.strip() for p in line.split(",")]
        if len(parts) == 2 and parts[0] == str(index):
            return parts[1]
    return None


def from_cuda_visible_devices(value: str) -> Optional[str]:
    """``VKENGINE_DEVICE`` for the first entry of a ``CUDA_VISIBLE_DEVICES`` value, or ``None``
    when it names no device. ``GPU-…`` is a UUID; an index is looked up with ``nvidia-smi``
    (whose order is CUDA's with ``CUDA_DEVICE_ORDER=PCI_BUS_ID``) and is otherwise taken as
    Vulkan's index. MIG instances are not Vulkan devices: ``ValueError``."""
    first = value.split(",")[0].strip()
    if not first or first == "-1" or first.lower() == "nodevfiles":
        return None
    if first.upper().startswith("MIG-"):
        raise ValueError(f"CUDA_VISIBLE_DEVICES={value!r}: a MIG instance is not a Vulkan device; "
                         "give the worker a whole GPU")
    if first.upper().startswith("GPU-"):
        return "uuid:" + first[4:]
    if re.fullmatch(r"\d+", first):
        uuid = _nvidia_uuid(int(first))
        return f"uuid:{uuid[4:] if uuid.upper().startswith('GPU-') else uuid}" if uuid else f"#{first}"
    raise ValueError(f"CUDA_VISIBLE_DEVICES={value!r}: expected GPU indices or GPU-… UUIDs")


def choose_device(devices: Optional[Sequence[str]] = None, env: Optional[Mapping[str, str]] = None,
                  slot_folder: Optional[str] = None, available: Optional[Sequence[dict]] = None) -> str:
    """The ``VKENGINE_DEVICE`` value for this worker process (see the module's description).
    ``available``: ``vkengine.devices()`` (asked when needed and not given)."""
    env = os.environ if env is None else env
    folder = slot_folder or os.path.join(tempfile.gettempdir(), "vkengine-gpu-slots")
    if devices and list(devices) == ["cuda"]:
        entries = env.get("CUDA_VISIBLE_DEVICES", "").split(",")
        devices = [d for d in (from_cuda_visible_devices(e) for e in entries) if d]
        if not devices:
            raise ValueError("devices=['cuda']: CUDA_VISIBLE_DEVICES names no GPU here")
    if devices:
        return str(devices[claim_slot(folder) % len(devices)])
    cuda = env.get("CUDA_VISIBLE_DEVICES")
    if cuda is not None:
        chosen = from_cuda_visible_devices(cuda)
        if chosen:
            return chosen
    if available is None:
        from . import devices as list_devices

        available = list_devices()
    usable = [d for d in available if not d.get("unsupported")]
    if not usable:
        raise RuntimeError("no Vulkan device here can run vkengine: " +
                           "; ".join(f"#{d['index']} {d['name']}: {d['unsupported']}" for d in available))
    return f"#{usable[claim_slot(folder) % len(usable)]['index']}"
