"""vkengine for Python: Vulkan volume rendering of numpy arrays and volume files.

A ``Renderer`` is the ``volume`` command-line program's headless renderer: every ``--set`` key
is a keyword argument, checked by the same schema (a typo or a bad range raises ``ValueError``
with the CLI's message), and ``render(frames=N)`` gives the image ``volume --frames N`` writes.
``Renderer.accumulate(start, stop)`` returns a frame range's exact float64 sum, which
``vkengine.distributed`` uses to split one image over many workers (Dask).

    import numpy as np, vkengine
    z, y, x = np.mgrid[-1:1:64j, -1:1:64j, -1:1:64j]
    vol = vkengine.Volume(np.exp(-4 * (x*x + y*y + z*z)).astype(np.float32))
    r = vkengine.Renderer(vol, size=(256, 256), renderer="mcm", tf="cloud")
    hdr = r.render(frames=16)        # float32 (256, 256, 4), linear
    rgb = r.image_srgb()             # uint8 (256, 256, 4)
"""

from ._native import (
    GpuError,
    MeshRenderer,
    Renderer,
    TransferFunction,
    ValidationError,
    Volume,
    devices,
    read_image,
    setting_keys,
    write_image,
)
from .accumulation import Accumulation, merge

__all__ = [
    "Accumulation",
    "GpuError",
    "MeshRenderer",
    "Renderer",
    "TransferFunction",
    "ValidationError",
    "Volume",
    "devices",
    "merge",
    "read_image",
    "setting_keys",
    "write_image",
]
