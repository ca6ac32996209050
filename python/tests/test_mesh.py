"""Mesh scenes from Python: the mesh demos' settings, messages and images."""

import numpy as np
import pytest

import vkengine
from conftest import run_cli


@pytest.mark.parametrize("frames, sets", [(2, {}), (1, {"lpv": False, "ambient": 0.3, "cascades": 2})])
def test_mesh_render_equals_the_cli_exr_bit_for_bit(cornell_bin, tmp_path, frames, sets):
    out = tmp_path / "cli.exr"
    cli_sets = [a for k, v in sets.items() for a in ("--set", f"{k}={str(v).lower()}")]
    run_cli(cornell_bin, "--size", "48x40", "--frames", str(frames), *cli_sets, "--out", str(out))
    r = vkengine.MeshRenderer(builtin="cornell", size=(48, 40), **sets)
    img = r.render(frames=frames)
    ref = vkengine.read_image(str(out))
    assert img.shape == ref.shape == (40, 48, 4) and np.count_nonzero(img[..., :3]) > 0
    np.testing.assert_array_equal(img, ref)
    srgb = r.image_srgb()
    assert srgb.dtype == np.uint8 and srgb.shape == (40, 48, 4)
    rep = r.report()
    assert rep["frames"] == frames and rep["scene"]["source"] == "builtin:cornell" and rep["frame_ms"] > 0


def test_mesh_settings_and_files_raise_the_cli_message(cornell_bin, tmp_path):
    with pytest.raises(ValueError) as e:
        vkengine.MeshRenderer(size=(16, 16), bogus=1)
    cli = run_cli(cornell_bin, "--size", "16x16", "--set", "bogus=1", check=False)
    assert cli.returncode == 2 and f"error: {e.value}" in cli.stderr, (str(e.value), cli.stderr)
    with pytest.raises(ValueError, match="atrium2"):
        vkengine.MeshRenderer(builtin="atrium2", size=(16, 16))
    with pytest.raises((FileNotFoundError, OSError, ValueError), match="nope.gltf"):
        vkengine.MeshRenderer(str(tmp_path / "nope.gltf"), size=(16, 16))
    assert any(k == "lpv" for k, _, _ in vkengine.setting_keys(mesh=True))
