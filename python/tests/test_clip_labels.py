"""Clipping, emission and label keywords from Python: each changes the image it should, the
defaults keep it bit for bit, and bad values raise ValueError naming the keyword."""

import json

import numpy as np
import pytest

import vkengine

SIZE = (32, 32)


def blob(n=16):
    z, y, x = np.mgrid[-1:1:n * 1j, -1:1:n * 1j, -1:1:n * 1j]
    return (np.exp(-2 * (x * x + y * y + z * z)) * 1000).astype(np.float32)


def render(vol=None, frames=1, **kw):
    kw.setdefault("renderer", "eam")
    kw.setdefault("tf", "ramp:50,900")
    return vkengine.Renderer(vol or vkengine.Volume(blob()), size=SIZE, seed=3, **kw).render(frames=frames)


def test_clip_and_crop_remove_part_of_the_image():
    full = render()
    # The kept side of x = 0 is the one the normal (+x) points away from: the half at x < 0.
    cut = render(clip=(0, 0, 0, 1, 0, 0))
    assert cut[..., :3].sum() < 0.8 * full[..., :3].sum()
    crop = render(crop=(-0.5, -0.5, -0.5, 0.5, 0.0, 0.5))
    assert crop[..., :3].sum() < 0.8 * full[..., :3].sum()
    turned = render(crop=(-0.5, -0.5, -0.5, 0.5, 0.0, 0.5), crop_rotation=(0, 0, 30))
    assert np.abs(turned - crop).max() > 0.05
    # The whole box as the crop box, unrotated: nothing is cut.
    whole = render(crop=(-1, -1, -1, 1, 1, 1))
    np.testing.assert_allclose(whole, full, atol=1e-6)


def test_clip_shadows_changes_only_monte_carlo_paths_of_a_clipped_volume():
    mc = dict(renderer="mcs", frames=2, tf="ramp:50,900")
    off = render(clip=(0, 0, 0, 0, 1, 0), **mc)
    np.testing.assert_array_equal(render(clip=(0, 0, 0, 0, 1, 0), clip_shadows="off", **mc), off)
    on = render(clip=(0, 0, 0, 0, 1, 0), clip_shadows="on", **mc)
    assert not np.array_equal(on, off)
    # Nothing clipped: the option has nothing to act on.
    np.testing.assert_array_equal(render(clip_shadows="on", **mc), render(**mc))


def test_emission_zero_keeps_the_image_bit_for_bit_and_emission_makes_it_glow():
    mc = dict(renderer="mcm", frames=2)
    base = render(**mc)
    np.testing.assert_array_equal(render(emission=0, **mc), base)
    glow = render(emission=3, **mc)
    assert glow[..., :3].sum() > 1.2 * base[..., :3].sum()


@pytest.mark.parametrize("key,value", [
    ("clip", (0, 0, 0, 0, 0, 0)),
    ("clip", (0, 0, 0, 1)),
    ("clip2", (0, 0, 0, float("nan"), 0, 1)),
    ("crop", (1, 0, 0, 0, 1, 1)),
    ("crop_rotation", (0, 0, 400)),
    ("crop_rotation", (10, 20)),
    ("clip_shadows", "maybe"),
    ("emission", -1),
    ("albedo", 2),
])
def test_bad_clipping_and_emission_values_name_the_keyword(key, value):
    with pytest.raises(ValueError, match=key):
        vkengine.Renderer(vkengine.Volume(blob(8)), size=(8, 8), **{key: value})


def two_labels(n=16):
    lab = np.zeros((n, n, n), dtype=np.uint8)
    lab[:, :, n // 2:] = 2  # x >= half: label 2
    lab[: n // 4] = 0
    return lab


def test_a_label_array_tints_its_half_and_colours_come_from_a_dict_or_a_file(tmp_path):
    vol = vkengine.Volume(blob())
    plain = render(vol)
    red = {2: {"color": [1, 0, 0]}}
    tinted = render(vol, labels=two_labels(), label_colors=red)
    assert not np.array_equal(tinted, plain)
    # Pure red over part of the volume: less green for the red it shows than without labels.
    ratio = lambda img: img[..., 1].sum() / img[..., 0].sum()
    assert ratio(tinted) < 0.9 * ratio(plain)
    path = tmp_path / "colors.json"
    path.write_text(json.dumps({"labels": {"2": {"color": [1, 0, 0]}}}))
    np.testing.assert_array_equal(render(vol, labels=two_labels(), label_colors=str(path)), tinted)
    # Any integer dtype and memory order is the same label map.
    np.testing.assert_array_equal(
        render(vol, labels=np.asfortranarray(two_labels().astype(np.int64)), label_colors=red), tinted)
    # A hidden label removes what it covers: here all but the thin, dim slab z < 2 of the blob,
    # so little more than the background is left.
    most = np.full((16, 16, 16), 2, dtype=np.uint8)
    most[:2] = 1
    hidden = render(vol, labels=most, label_colors={2: {"visible": False}})
    bg = render(vkengine.Volume(np.zeros((16, 16, 16), np.float32)))[..., :3].sum()
    assert hidden[..., :3].sum() - bg < 0.3 * (plain[..., :3].sum() - bg)


@pytest.mark.parametrize("labels,needle", [
    (np.zeros((16, 16, 8), dtype=np.uint8), "shape"),
    (np.zeros((16, 16, 16), dtype=np.float32), "dtype"),
    (np.full((16, 16, 16), -1, dtype=np.int16), "holds id -1"),
    (np.full((16, 16, 16), 256, dtype=np.int32), "holds id 256"),
    (np.zeros((16, 16), dtype=np.uint8), "3D"),
    ([1, 2, 3], "numpy integer array"),
])
def test_bad_label_arrays_raise_value_error_naming_labels(labels, needle):
    with pytest.raises(ValueError, match="labels") as e:
        render(labels=labels)
    assert needle in str(e.value)


def test_label_colours_for_an_absent_label_or_without_labels_raise():
    with pytest.raises(ValueError, match="label_colors"):
        render(labels=two_labels(), label_colors={7: {"color": [1, 0, 0]}})
    with pytest.raises(ValueError, match="label_colors"):
        render(label_colors={2: {"color": [1, 0, 0]}})
