"""`residency=view` from Python: the renderer keeps full-resolution bricks where the view needs
them within `gpu_memory`, streaming them frame by frame, as the CLI does. With room for every
brick the image is the plain one; under a small budget coarser bricks show; bad values raise
ValueError naming the keyword."""

import numpy as np
import pytest

import vkengine

SIZE = (32, 32)


def blob(n=32):
    z, y, x = np.mgrid[-1:1:n * 1j, -1:1:n * 1j, -1:1:n * 1j]
    noise = np.random.default_rng(7).random((n, n, n))
    return ((np.exp(-2 * (x * x + y * y + z * z)) + 0.3 * noise) * 1000).astype(np.float32)


def render(frames=6, **kw):
    kw.setdefault("renderer", "mip")
    return vkengine.Renderer(vkengine.Volume(blob()), size=SIZE, seed=3, **kw).render(frames=frames)


def test_residency_with_room_for_every_brick_renders_as_without():
    # filter=exact: texels fetched and interpolated in f32, so the atlas and the plain texture
    # agree to f32 rounding on any device (a GPU's texture unit quantizes filter weights, and the
    # two textures' normalized coordinates round differently).
    plain = render(filter="exact")
    resident = render(residency="view", filter="exact")
    np.testing.assert_allclose(resident, plain, atol=1e-4)


def test_residency_under_a_small_budget_shows_coarser_bricks():
    plain = render()
    coarse = render(residency="view", gpu_memory="24K")
    # Coarser bricks average the noise away: the maximum along rays falls.
    assert np.abs(coarse - plain).max() > 1e-2
    assert coarse[..., :3].sum() < plain[..., :3].sum()


@pytest.mark.parametrize("key,value", [("residency", "sometimes"), ("upload_budget", "-1")])
def test_bad_residency_values_name_the_keyword(key, value):
    with pytest.raises(ValueError, match=key):
        render(frames=1, **{key: value})
