"""Label maps from files written by nibabel at test time: a NIfTI scan and a NIfTI segmentation on
its grid render as the same label map given as an array (an independent path to the same ids),
through Python and the CLI; a segmentation on another grid is refused naming the file."""

import numpy as np
import pytest

import vkengine

import nibabel as nib  # noqa: E402  (tools/setup.sh --python installs it)

from conftest import run_cli  # noqa: E402

N = 16
AFFINE = np.diag([0.8, 0.8, 1.2, 1.0])


def scan():
    z, y, x = np.mgrid[-1:1:N * 1j, -1:1:N * 1j, -1:1:N * 1j]
    return (np.exp(-2 * (x * x + y * y + z * z)) * 1000).astype(np.int16)


def segmentation():
    """Label 1 where x < half, 2 where x >= half (indexed [z, y, x]), 0 in the first quarter of z."""
    lab = np.ones((N, N, N), dtype=np.uint8)
    lab[:, :, N // 2:] = 2
    lab[: N // 4] = 0
    return lab


def save(a_zyx, path, affine=AFFINE):
    # NIfTI stores x fastest: nibabel's array is indexed [x, y, z].
    img = nib.Nifti1Image(np.ascontiguousarray(a_zyx.transpose(2, 1, 0)), affine)
    img.set_qform(affine, 1)
    img.set_sform(affine, 1)
    nib.save(img, str(path))
    return str(path)


KW = dict(size=(32, 32), seed=3, renderer="eam", tf="ramp:50,900", label_mode="replace")
COLOURS = {1: {"color": [0.2, 0.4, 1.0]}, 2: {"color": [1.0, 0.1, 0.1]}}


def test_a_nibabel_segmentation_renders_as_the_same_ids_given_as_an_array(tmp_path):
    vol = vkengine.Volume.load(save(scan(), tmp_path / "scan.nii.gz"))
    seg = save(segmentation(), tmp_path / "seg.nii.gz")
    from_file = vkengine.Renderer(vol, labels=seg, label_colors=COLOURS, **KW).render(frames=1)
    # The affine is RAS (x to the right, y to anterior), so the loader turns x and y around into
    # patient (LPS) order, the scan and its segmentation alike: the array is given in that order.
    np.testing.assert_array_equal(vol.to_numpy(), scan()[:, ::-1, ::-1])
    lps = np.ascontiguousarray(segmentation()[:, ::-1, ::-1])
    from_array = vkengine.Renderer(vol, labels=lps, label_colors=COLOURS, **KW).render(frames=1)
    plain = vkengine.Renderer(vol, **KW).render(frames=1)
    np.testing.assert_array_equal(from_file, from_array)
    assert not np.array_equal(from_file, plain)
    # Each label shows its own colour: some pixels are mostly red (label 2), some mostly blue (label 1).
    img = from_file[..., :3]
    red = (img[..., 0] > 3 * img[..., 2]) & (img[..., 0] > 0.05)
    blue = (img[..., 2] > 3 * img[..., 0]) & (img[..., 2] > 0.05)
    assert red.sum() > 50 and blue.sum() > 50, (red.sum(), blue.sum())


def test_the_cli_renders_the_nibabel_files_and_refuses_a_segmentation_on_another_grid(tmp_path, volume_bin):
    exe = volume_bin
    s = save(scan(), tmp_path / "scan.nii.gz")
    seg = save(segmentation(), tmp_path / "seg.nii.gz")
    out = tmp_path / "out.png"
    run_cli(exe, "--volume", s, "--labels", seg, "--renderer", "eam", "--size", "24x24", "--frames", "1",
            "--out", str(out))
    assert out.stat().st_size > 0
    other = save(segmentation(), tmp_path / "seg_other.nii.gz", affine=np.diag([1.0, 0.8, 1.2, 1.0]))
    p = run_cli(exe, "--volume", s, "--labels", other, "--renderer", "eam", "--size", "24x24", "--frames", "1",
                "--out", str(out), check=False)
    assert p.returncode == 2, p.stderr
    lines = [l for l in p.stderr.splitlines() if l.startswith("error")]
    assert len(lines) == 1 and "seg_other.nii.gz" in lines[0], p.stderr
    with pytest.raises(ValueError, match="seg_other.nii.gz"):
        vkengine.Renderer(vkengine.Volume.load(s), labels=other, **KW).render(frames=1)
