"""Rendering from Python: the CLI's settings and messages, its image bit for bit, exact
accumulation, and the GIL released while the GPU works."""

import threading
import time

import numpy as np
import pytest

import vkengine
from conftest import run_cli

# Small and few frames: llvmpipe ends shader loops after 65,535 iterations per 8-lane row.
SMALL = dict(size=(48, 40), n=24)


def blob(n=24, dtype=np.float32):
    z, y, x = np.mgrid[-1:1:n * 1j, -1:1:n * 1j, -1:1:n * 1j]
    return (np.exp(-3 * (x * x + 2 * y * y + z * z)) * 1000).astype(dtype)


@pytest.mark.parametrize("bad", [
    {"bogus": 1},
    {"density": -1},
    {"renderer": "mcx"},
    {"bounces": 0},
    {"ess": "maybe"},
    {"mc_budget": 12},
    {"target": (1, 2)},
])
def test_bad_settings_raise_the_cli_message(volume_bin, bad):
    (key, value), = bad.items()
    with pytest.raises(ValueError) as e:
        vkengine.Renderer(size=(16, 16), **bad)
    text = ",".join(map(str, value)) if isinstance(value, tuple) else str(value)
    cli = run_cli(volume_bin, "--size", "16x16", "--set", f"{key}={text}", check=False)
    assert cli.returncode == 2, cli.stderr
    # The CLI prints `error: MESSAGE`; Python raises MESSAGE.
    assert f"error: {e.value}" in cli.stderr, (str(e.value), cli.stderr)


def test_bad_keyword_types_and_sizes():
    with pytest.raises(TypeError, match="density"):
        vkengine.Renderer(size=(16, 16), density=object())
    with pytest.raises(ValueError, match="size"):
        vkengine.Renderer(size=(0, 16))
    with pytest.raises(ValueError, match="transfer function `nope`"):
        vkengine.Renderer(vkengine.Volume(blob(8)), size=(16, 16), tf="nope")
    with pytest.raises(ValueError, match="missing.exr"):
        vkengine.Renderer(size=(16, 16), renderer="mcs", env="missing.exr")


def test_render_equals_the_cli_exr_bit_for_bit(volume_bin, tmp_path):
    out = tmp_path / "cli.exr"
    cli = ["--size", "48x40", "--frames", "3", "--seed", "7", "--renderer", "mcm",
           "--set", "n=24", "--set", "density=2", "--set", "yaw=1.1", "--out", str(out)]
    run_cli(volume_bin, *cli)
    r = vkengine.Renderer(size=(48, 40), seed=7, renderer="mcm", n=24, density=2, yaw=1.1)
    img = r.render(frames=3)
    ref = vkengine.read_image(str(out))
    assert img.shape == ref.shape == (40, 48, 4)
    assert np.count_nonzero(img[..., :3]) > 0
    np.testing.assert_array_equal(img, ref)
    # Saved by Python, the file is the CLI's byte for byte.
    r.save(str(tmp_path / "py.exr"))
    assert (tmp_path / "py.exr").read_bytes() == out.read_bytes()


def test_numpy_volume_renders_and_reports():
    vol = vkengine.Volume(blob(), spacing=(1, 1, 2), origin=(-5, 0, 0))
    r = vkengine.Renderer(vol, size=(32, 32), renderer="eam", tf="ramp:100,900")
    hdr = r.render(frames=1)
    assert hdr.dtype == np.float32 and hdr.shape == (32, 32, 4)
    centre, corner = hdr[16, 16, :3].sum(), hdr[0, 0, :3].sum()
    assert centre > 10 * corner
    srgb = r.image_srgb()
    assert srgb.dtype == np.uint8 and srgb.shape == (32, 32, 4) and srgb[16, 16, :3].max() > 0
    rep = r.report()
    assert rep["frames"] == 1 and rep["size"] == [32, 32] and rep["volume"]["dims"] == [24, 24, 24]
    assert rep["device"]["name"] and rep["frame_ms"] > 0 and any(p[0] == "eam" for p in rep["passes"])


def test_look_at_in_physical_coordinates_centres_the_voxel():
    # One bright voxel off the centre of an anisotropic volume with an origin: looking at its
    # physical position must put it in the middle of the image.
    a = np.zeros((24, 24, 24), np.float32)
    x, y, z = 18, 6, 15
    a[z, y, x] = 1000
    spacing, origin = (1.0, 1.0, 2.0), (-5.0, 3.0, 7.0)
    vol = vkengine.Volume(a, spacing=spacing, origin=origin)
    r = vkengine.Renderer(vol, size=(33, 33), renderer="mip", jitter=False)
    p = [o + i * s for o, i, s in zip(origin, (x, y, z), spacing)]
    for eye in ([p[0], p[1], p[2] + 12], [p[0] + 9, p[1] + 6, p[2] - 5]):
        r.look_at(eye=eye, target=p, physical=True)
        img = r.render(frames=1)[..., 0]
        row, col = np.unravel_index(np.argmax(img), img.shape)
        assert img.max() > 0 and abs(row - 16) <= 1 and abs(col - 16) <= 1, (eye, row, col)


def test_exact_accumulation_matches_the_progressive_mean():
    # mc_budget=0: accumulate renders whole paths, and the progressive mean compared with it must draw
    # the same numbers (auto may pick bounded work on this device).
    kw = dict(size=(32, 32), renderer="mcs", n=24, seed=3, mc_budget=0)
    r = vkengine.Renderer(**kw)
    whole, n = r.accumulate(0, 6)
    assert n == 6 and whole.dtype == np.float64
    a, na = r.accumulate(0, 2)
    b, nb = r.accumulate(2, 6)
    # Disjoint ranges add up to the whole (float32 values summed in float64: exact here).
    np.testing.assert_array_equal(a + b, whole)
    progressive = r.render(frames=6)
    np.testing.assert_allclose(whole / 6, progressive, rtol=1e-5, atol=1e-6)
    assert not np.array_equal(a / 2, b / 4), "different frames must differ (the streams follow the frame index)"
    merged = vkengine.merge([vkengine.Accumulation(b, nb, [(2, 6)]), vkengine.Accumulation(a, na, [(0, 2)])])
    assert merged.count == 6 and np.array_equal(merged.sum, whole)
    with pytest.raises(ValueError, match="overlap"):
        vkengine.merge([vkengine.Accumulation(a, na, [(0, 2)]), vkengine.Accumulation(whole, n, [(0, 6)])])
    bounded = vkengine.Renderer(size=(16, 16), renderer="mcs", n=16, mc_budget=64)
    with pytest.raises(ValueError, match="mc_budget=64"):
        bounded.accumulate(0, 2)


def test_gil_is_released_while_rendering():
    r = vkengine.Renderer(size=(64, 64), renderer="mcm", n=32)
    r.render(frames=1)
    ticks = []
    stop = threading.Event()

    def count():
        while not stop.is_set():
            ticks.append(time.perf_counter())
            time.sleep(0.001)

    t = threading.Thread(target=count)
    t.start()
    t0 = time.perf_counter()
    r.render(frames=4)
    t1 = time.perf_counter()
    stop.set()
    t.join()
    inside = [x for x in ticks if t0 < x < t1]
    # With the GIL held the other thread could not run at all during the render.
    assert len(inside) >= 5, (len(inside), t1 - t0)


def test_environment_map_from_an_array_equals_the_same_file(tmp_path):
    env = np.ones((8, 16, 3), np.float32)
    env[:4] *= 3  # a brighter upper half: the map matters
    kw = dict(size=(16, 16), renderer="mcs", n=16)
    from_array = vkengine.Renderer(env=env, **kw).render(frames=2)
    vkengine.write_image(str(tmp_path / "env.exr"), np.dstack([env, np.ones((8, 16, 1), np.float32)]))
    from_file = vkengine.Renderer(env=str(tmp_path / "env.exr"), **kw).render(frames=2)
    np.testing.assert_array_equal(from_array, from_file)
    assert not np.array_equal(from_array, vkengine.Renderer(**kw).render(frames=2))
    with pytest.raises(ValueError, match="height, width, 3"):
        vkengine.Renderer(env=np.ones((8, 16, 4), np.float32), **kw)


def test_device_choice_and_gpu_timeout_are_exceptions():
    with pytest.raises(ValueError, match="no-such-gpu"):
        vkengine.Renderer(size=(16, 16), device="no-such-gpu")
    with pytest.raises(TimeoutError, match="GPU timeout"):
        # The uploads may beat 1 µs; a 256² multiple-scattering frame cannot.
        vkengine.Renderer(size=(256, 256), renderer="mcm", n=64, gpu_timeout=1e-6).render(frames=1)
    with pytest.raises(ValueError, match="gpu_timeout"):
        vkengine.Renderer(size=(16, 16), gpu_timeout=-1)
    # The interpreter and the driver carry on.
    assert vkengine.Renderer(size=(16, 16), n=16).render().shape == (16, 16, 4)


def test_a_volume_past_the_3d_image_limit_renders_in_bricks():
    # 4500 slices: past lavapipe's 4096, so the default layout stores it in 8³ bricks.
    a = np.zeros((4500, 8, 8), np.float32)
    a[np.arange(4500) % 7 < 3, 2:6, 2:6] = 1.0
    r = vkengine.Renderer(vkengine.Volume(a), size=(16, 16), renderer="mip", jitter=False)
    # Down the long axis from just past its end: every slice is on the rays through the middle.
    r.look_at(eye=[3.5, 3.5, 4510.0], target=[3.5, 3.5, 0.0], physical=True)
    img = r.render(frames=1)[..., 0]
    assert img[8, 8] > 0.99 and img[0, 0] < 0.1, (img[8, 8], img[0, 0])
    with pytest.raises(Exception, match="3D texture limit"):
        vkengine.Renderer(vkengine.Volume(a), size=(16, 16), renderer="mip", volume_layout="dense")


@pytest.mark.parametrize("make", [
    lambda a: a[2:22:2, ::-1, 3:],            # a strided, reversed crop
    lambda a: a.astype(">f4"),                # big-endian (nibabel's big-endian NIfTI, FITS)
    lambda a: a.astype(np.float16),           # half precision
    lambda a: np.asfortranarray(a.astype(">u2"))[::-1],  # all at once
])
def test_views_and_byte_orders_render_like_their_native_contiguous_copy(make):
    a = make(blob())
    copy = np.ascontiguousarray(a, dtype=a.dtype.newbyteorder("="))
    assert not (a.flags.c_contiguous and a.dtype.isnative and a.dtype == np.float32)
    kw = dict(size=(24, 24), renderer="mcs", tf="ramp:100,900", seed=4)
    img = vkengine.Renderer(vkengine.Volume(a), **kw).render(frames=2)
    assert img[..., :3].max() > 0
    np.testing.assert_array_equal(img, vkengine.Renderer(vkengine.Volume(copy), **kw).render(frames=2))
