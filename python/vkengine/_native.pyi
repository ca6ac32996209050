"""Type stubs of the native module (``vkengine._native``)."""

from os import PathLike
from typing import Any, Callable, Dict, List, Optional, Sequence, Tuple, Union

import numpy as np
import numpy.typing as npt

_Path = Union[str, PathLike]
_Vec3 = Tuple[float, float, float]

BUILD_PROFILE: str
"""``debug`` or ``release``: the Cargo profile this module was built in (release optimizes SPIR-V)."""

class ValidationError(RuntimeError):
    """The Vulkan validation layer reported messages during a render."""

class GpuError(RuntimeError):
    """The device failed: no Vulkan device, a lost device, an allocation failure."""

class Volume:
    """A scalar volume: values indexed ``[z, y, x]``, spacing and origin in physical units."""

    def __init__(self, array: npt.NDArray[Any], spacing: Optional[_Vec3] = None, origin: Optional[_Vec3] = None,
                 name: Optional[str] = None) -> None:
        """From a 3D array of any real integer or float dtype (float16 included) in either byte
        order, with any strides. Raises ``ValueError`` for empty axes, NaN voxels, bad spacing;
        ``TypeError`` for bool, complex and other dtypes. Pickles (as its values)."""
    @staticmethod
    def load(path: _Path, dims: Optional[Tuple[int, int, int]] = None, dtype: Optional[str] = None,
             endian: Optional[str] = None, spacing: Optional[_Vec3] = None, series: Optional[str] = None,
             frame: Optional[int] = None, grid: Optional[str] = None, allow_negative: bool = False) -> "Volume":
        """Any file the engine reads: MetaImage, NRRD, NIfTI, OpenVDB, DICOM, raw (with dims and dtype)."""
    @staticmethod
    def procedural(scene: str = "cloud", n: int = 128, seed: int = 0) -> "Volume":
        """One of the CLI's procedural scenes at ``n``³."""
    def to_numpy(self) -> npt.NDArray[np.float32]:
        """The decoded values, float32 ``[z, y, x]``."""
    @property
    def shape(self) -> Tuple[int, int, int]: ...
    @property
    def dims(self) -> Tuple[int, int, int]: ...
    @property
    def spacing(self) -> Tuple[float, float, float]: ...
    @property
    def origin(self) -> Tuple[float, float, float]: ...
    @property
    def value_range(self) -> Tuple[float, float]: ...
    @property
    def source(self) -> str: ...
    @property
    def warnings(self) -> List[str]: ...

class TransferFunction:
    """Normalized value (× gradient magnitude) → colour and extinction."""

    @staticmethod
    def preset(name: str) -> "TransferFunction":
        """``default``, ``cloud``, ``bone`` or ``edges``."""
    @staticmethod
    def from_json(text_or_path: str) -> "TransferFunction":
        """JSON text or a ``.json`` file (``{"points": [...]}`` or ``{"boxes": [...]}``)."""
    @staticmethod
    def from_points(points: Union[npt.NDArray[Any], Sequence[Sequence[float]]]) -> "TransferFunction":
        """``(N, 5)`` rows ``value, r, g, b, extinction`` (any real array or a list), values ascending in [0, 1]."""
    def to_json(self) -> str: ...

class Renderer:
    """The ``volume`` CLI's headless renderer; every ``--set`` key is a keyword argument."""

    def __init__(self, volume: Optional[Volume] = None, *, size: Tuple[int, int] = (512, 512),
                 tf: Union[TransferFunction, str, None] = None,
                 env: Union[str, npt.NDArray[np.float32], None] = None, seed: int = 0, jitter: bool = True,
                 device: Optional[str] = None, validation: Optional[bool] = None,
                 gpu_timeout: Optional[float] = None, **settings: Any) -> None:
        """Raises ``ValueError`` with the CLI's message for an unknown key or a bad value.

        ``labels``: a label file or an integer array ``[z, y, x]`` on the volume's grid;
        ``label_colors``: a JSON file or a dict ``{label: {"color": [r, g, b], "opacity": o,
        "visible": b}}``; a wrong shape or dtype, or an id outside 0..255 raises ``ValueError``."""
    def render(self, frames: int = 1,
               progress: Optional[Callable[[int, int], Any]] = None) -> npt.NDArray[np.float32]:
        """Renders ``frames`` more frames (GIL released) and returns ``image()``; Ctrl-C stops it
        after the frame in flight (``KeyboardInterrupt``); ``progress(done, frames)`` per frame."""
    def step(self) -> None:
        """Renders one more frame into the progressive mean."""
    def estimated_error(self) -> Optional[float]:
        """Monte Carlo: the image's estimated relative error (foreground), or None."""
    def image(self) -> npt.NDArray[np.float32]:
        """The image shown, linear HDR, (height, width, 4): denoised with ``denoise="on"``, else the progressive mean."""
    def mean(self) -> npt.NDArray[np.float32]:
        """The unbiased progressive mean, linear HDR, (height, width, 4), whatever ``denoise`` says."""
    def image_srgb(self) -> npt.NDArray[np.uint8]:
        """The tone-mapped image, sRGB, (height, width, 4)."""
    def reset(self) -> None:
        """Forgets the accumulation; the next frame is frame 0."""
    def accumulate(self, start: int, stop: int,
                   progress: Optional[Callable[[int, int], Any]] = None) -> Tuple[npt.NDArray[np.float64], int]:
        """The exact float64 sum of frames ``start..stop`` and its count (for distributed merges)."""
    def orbit(self, yaw: Optional[float] = None, pitch: Optional[float] = None, distance: Optional[float] = None,
              target: Optional[_Vec3] = None) -> None:
        """Moves the orbit camera (radians; world units, largest axis = 1)."""
    def look_at(self, eye: _Vec3, target: _Vec3, physical: bool = False) -> None:
        """Looks from ``eye`` at ``target``, in world or (``physical=True``) the volume's coordinates."""
    def reset_camera(self) -> None:
        """Back to the camera the settings gave."""
    def camera(self) -> str: ...
    def report(self) -> Dict[str, Any]:
        """Device, volume, settings, frames, median GPU ms per pass and frame, wall ms."""
    def save(self, path: _Path) -> None:
        """``.exr``: linear HDR (as ``volume --out x.exr``); otherwise PNG."""
    @property
    def frames(self) -> int: ...
    @property
    def size(self) -> Tuple[int, int]: ...
    @property
    def device(self) -> str:
        """``#index name (driver) uuid:…``."""
    def close(self) -> None:
        """Frees the device now; later calls raise ``ValueError``."""
    @property
    def closed(self) -> bool: ...
    def __enter__(self) -> "Renderer": ...
    def __exit__(self, *exc: Any) -> bool: ...
    def _repr_png_(self) -> bytes:
        """The tone-mapped image as PNG (Jupyter's inline display)."""

class MeshRenderer:
    """The mesh demos' headless renderer (direct light, shadows, cascaded LPV, fog)."""

    def __init__(self, scene: Optional[_Path] = None, *, builtin: str = "cornell", size: Tuple[int, int] = (512, 512),
                 device: Optional[str] = None, validation: Optional[bool] = None,
                 gpu_timeout: Optional[float] = None, **settings: Any) -> None:
        """A scene file (``.toml``, ``.gltf``/``.glb``/``.obj``) or a built-in (``cornell``, ``atrium``);
        every other keyword is a mesh ``--set`` key, layered over the scene file's settings."""
    def render(self, frames: int = 1) -> npt.NDArray[np.float32]:
        """``frames`` frames along the scene's camera path (as ``--frames``); the last frame's HDR."""
    def image(self) -> npt.NDArray[np.float32]: ...
    def image_srgb(self) -> npt.NDArray[np.uint8]: ...
    def report(self) -> Dict[str, Any]: ...
    def save(self, path: _Path) -> None: ...
    @property
    def frames(self) -> int: ...

def read_image(path: _Path) -> npt.NDArray[np.float32]:
    """An image file as float32 RGBA, (height, width, 4)."""

def write_image(path: _Path, image: npt.NDArray[Any]) -> None:
    """float32 RGBA as ``.exr``, uint8 RGBA as PNG."""

def devices() -> List[Dict[str, Any]]:
    """The machine's Vulkan devices: ``index`` (``device="#N"``), ``name``, ``type``, ``uuid``, ``unsupported``."""

def setting_keys(mesh: bool = False) -> List[Tuple[str, str, str]]:
    """Every settings keyword of ``Renderer`` (``MeshRenderer`` with ``mesh=True``): (key, type, description)."""
