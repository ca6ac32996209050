"""The denoiser from Python: image() is the denoised image, mean() the unbiased one, and an orbit
reuses the previous views' history in the shown image only, never in the mean."""

import numpy as np

import vkengine

# One whole path per pixel and frame, small: llvmpipe ends shader loops after 65,535 iterations
# per 8-lane row.
KW = dict(size=(40, 40), renderer="mcm", n=24, seed=3, mc_budget=0, density=2)
YAWS = [0.5 + 0.06 * k for k in range(4)]


def rel_rmse(a, ref):
    fg = np.abs(ref[..., :3] - ref[0, 0, :3]).max(axis=-1) > 1e-6
    d = (a[..., :3] - ref[..., :3])[fg]
    return float(np.sqrt((d * d).sum() / (ref[..., :3][fg] ** 2).sum()))


def test_an_orbit_reuses_history_in_the_shown_image_and_never_in_the_mean():
    den = vkengine.Renderer(denoise="on", **KW)
    raw = vkengine.Renderer(**KW)
    ref = vkengine.Renderer(**dict(KW, mc_budget=512, seed=99))
    shown_err, raw_err = [], []
    for k, yaw in enumerate(YAWS):
        for r in (den, raw, ref):
            r.orbit(yaw=yaw)
        den.render(frames=2)
        raw.render(frames=2)
        reference = ref.render(frames=32)
        # The denoiser and its history touch only the shown image: same seed, same paths, the
        # same mean bit for bit.
        assert np.array_equal(den.mean(), raw.mean()), f"view {k}: the mean changed"
        shown = den.image()
        assert shown.shape == (40, 40, 4) and np.isfinite(shown).all()
        if k > 0:
            shown_err.append(rel_rmse(shown, reference))
            raw_err.append(rel_rmse(raw.mean(), reference))
    # With two paths a view, each view's history (reprojected, clamped) and the filter leave the
    # shown image clearly closer to the reference than the raw two-path mean.
    print(f"shown {np.mean(shown_err):.4f}, raw {np.mean(raw_err):.4f}")
    assert np.mean(shown_err) < 0.75 * np.mean(raw_err), (shown_err, raw_err)

