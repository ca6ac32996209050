"""numpy volumes in and out: every dtype, byte order, memory order and stride, and bad input as
exceptions."""

import pickle

import numpy as np
import pytest

import vkengine

DTYPES = [np.uint8, np.int8, np.uint16, np.int16, np.uint32, np.int32, np.uint64, np.int64, np.float16, np.float32,
          np.float64]


def sample(dtype, shape=(5, 4, 3)):
    """Distinct values (negative ones for signed types) that float32 holds exactly."""
    a = np.arange(np.prod(shape)).reshape(shape) * 3 + 1
    if np.issubdtype(dtype, np.signedinteger) or np.issubdtype(dtype, np.floating):
        a = a - 20
    if np.issubdtype(dtype, np.floating):
        a = a / 4
    return a.astype(dtype)


@pytest.mark.parametrize("order", ["C", "F"])
@pytest.mark.parametrize("dtype", DTYPES)
def test_round_trip_every_dtype_and_order(dtype, order):
    a = np.asarray(sample(dtype), order=order)
    v = vkengine.Volume(a, spacing=(0.5, 1.0, 2.0), origin=(1, 2, 3))
    back = v.to_numpy()
    assert back.dtype == np.float32 and back.shape == a.shape
    np.testing.assert_array_equal(back, a.astype(np.float32))
    # dims are (x, y, z) of an array indexed [z, y, x]; x varies fastest in the engine.
    assert v.dims == [3, 4, 5] and v.shape == (5, 4, 3)
    assert v.spacing == [0.5, 1.0, 2.0] and v.origin == [1.0, 2.0, 3.0]
    assert v.value_range == [float(a.min()), float(a.max())]


def test_unaligned_arrays_are_read():
    # What Dask's pickle frames and np.frombuffer at an odd offset produce.
    a = sample(np.float64)
    buf = bytearray(a.nbytes + 1)
    u = np.frombuffer(buf, dtype=np.float64, offset=1, count=a.size).reshape(a.shape)
    u[...] = a
    assert not u.flags.aligned
    np.testing.assert_array_equal(vkengine.Volume(u).to_numpy(), a.astype(np.float32))


def test_unaligned_images_and_points_are_read(tmp_path):
    def unaligned(a):
        buf = bytearray(a.nbytes + 1)
        u = np.frombuffer(buf, dtype=a.dtype, offset=1, count=a.size).reshape(a.shape)
        u[...] = a
        assert not u.flags.aligned
        return u

    hdr = np.random.default_rng(2).random((3, 5, 4), dtype=np.float32)
    vkengine.write_image(str(tmp_path / "u.exr"), unaligned(hdr))
    np.testing.assert_array_equal(vkengine.read_image(str(tmp_path / "u.exr")), hdr)
    pts = np.array([[0, 0, 0, 0, 0], [1, 1, 1, 1, 5.0]])
    assert vkengine.TransferFunction.from_points(unaligned(pts)).to_json() == \
        vkengine.TransferFunction.from_points(pts).to_json()


def test_extreme_integers_convert_like_numpy():
    a = np.array([0, 1, 2**32 - 1, 2**31], dtype=np.uint32).reshape(1, 2, 2)
    np.testing.assert_array_equal(vkengine.Volume(a).to_numpy(), a.astype(np.float32))


def native(a):
    """What the engine must see: the contiguous native-order copy of the same values."""
    return np.ascontiguousarray(a, dtype=a.dtype.newbyteorder("="))


VIEWS = {
    "crop": lambda a: a[1:4, 1:3, :2],
    "steps": lambda a: a[::2, :, ::2],
    "reversed": lambda a: a[::-1, :, ::-1],
    "reversed crop": lambda a: a[4:0:-2, ::-1, 1:],
    "transposed": lambda a: a.transpose(2, 0, 1),
    "fortran": lambda a: np.asfortranarray(a),
    "broadcast": lambda a: np.broadcast_to(a[:1], a.shape),
}


@pytest.mark.parametrize("view", VIEWS)
@pytest.mark.parametrize("order", ["<", ">"])
@pytest.mark.parametrize("dtype", DTYPES)
def test_any_view_in_either_byte_order_reads_like_its_native_copy(dtype, order, view):
    a = VIEWS[view](sample(dtype).astype(np.dtype(dtype).newbyteorder(order)))
    assert a.dtype.byteorder in (order, "|", "=")
    got = vkengine.Volume(a).to_numpy()
    # numpy's own conversion of the native contiguous copy is the independent reference.
    np.testing.assert_array_equal(got, native(a).astype(np.float32))
    assert got.shape == a.shape


def test_float16_values_convert_exactly():
    # Every finite half, subnormals and both zeros included, through numpy's own conversion.
    bits = np.arange(0, 2**16, dtype=np.uint16)
    h = bits.view(np.float16)
    h = h[np.isfinite(h)]
    a = h[: (h.size // 64) * 64].reshape(16, 4, -1)
    for arr in (a, a.astype(">f2")):
        got = vkengine.Volume(arr).to_numpy()
        np.testing.assert_array_equal(got.view(np.uint32), arr.astype(np.float32).view(np.uint32))


@pytest.mark.parametrize("bad, exc, match", [
    (np.zeros((2, 2, 2), bool), TypeError, "dtype bool"),
    (np.zeros((2, 2, 2), np.complex64), TypeError, "complex64"),
    (np.zeros((4, 4)), ValueError, "3D array"),
    (np.zeros((0, 4, 4)), ValueError, "empty axis"),
    (np.zeros((2, 2, 2), np.longdouble), TypeError, "not supported"),
    (np.zeros((2, 2, 2), object), TypeError, "dtype object"),
    (np.zeros((2, 2, 2), "datetime64[s]"), TypeError, "datetime64"),
    (np.full((4, 4, 4), np.nan)[:, ::2, ::-1].astype(">f2"), ValueError, "32 NaN voxel"),
    (np.full((2, 2, 2), np.nan), ValueError, "8 NaN voxel"),
    (np.full((2, 2, 2), np.inf), ValueError, "numpy array"),
])
def test_bad_arrays_raise(bad, exc, match):
    with pytest.raises(exc, match=match):
        vkengine.Volume(bad)


@pytest.mark.parametrize("kw, match", [
    ({"spacing": (0, 1, 1)}, "spacing"),
    ({"spacing": (float("nan"), 1, 1)}, "spacing"),
    ({"origin": (float("inf"), 0, 0)}, "origin"),
])
def test_bad_geometry_raises(kw, match):
    with pytest.raises(ValueError, match=match):
        vkengine.Volume(np.ones((2, 2, 2), np.float32), **kw)


def test_missing_file_names_the_file(tmp_path):
    p = tmp_path / "nothing.nrrd"
    with pytest.raises(FileNotFoundError, match="nothing.nrrd"):
        vkengine.Volume.load(str(p))


def test_raw_file_loads_with_dims_and_dtype(tmp_path):
    a = sample(np.uint16, (3, 4, 5))
    p = tmp_path / "v.raw"
    a.tofile(p)
    v = vkengine.Volume.load(str(p), dims=(5, 4, 3), dtype="u16")
    np.testing.assert_array_equal(v.to_numpy(), a.astype(np.float32))
    with pytest.raises(ValueError, match="v.raw"):
        vkengine.Volume.load(str(p), dims=(5, 4, 4), dtype="u16")


def test_transfer_function_points_as_lists_and_any_real_dtype():
    rows = [[0, 0, 0, 0, 0], [0.5, 1, 0.5, 0.25, 2], [1, 1, 1, 1, 8]]
    ref = vkengine.TransferFunction.from_points(np.array(rows, np.float64)).to_json()
    for pts in (rows, np.array(rows, np.float32), np.array(rows, ">f8"), np.array(rows, np.float64)[::-1][::-1].T.T):
        assert vkengine.TransferFunction.from_points(pts).to_json() == ref
    with pytest.raises(ValueError, match="real numbers"):
        vkengine.TransferFunction.from_points([["a", 1, 1, 1, 1], [1, 1, 1, 1, 1]])
    with pytest.raises(ValueError, match="complex"):
        vkengine.TransferFunction.from_points(np.ones((2, 5), np.complex64))


def test_volumes_and_transfer_functions_pickle():
    vol = vkengine.Volume(sample(np.int16, (6, 5, 4)), spacing=(0.5, 1, 2), origin=(1, -2, 3), name="scan")
    back = pickle.loads(pickle.dumps(vol))
    np.testing.assert_array_equal(back.to_numpy(), vol.to_numpy())
    assert (back.spacing, back.origin, back.source, back.dims) == (vol.spacing, vol.origin, "scan", vol.dims)
    tf = vkengine.TransferFunction.preset("bone")
    assert pickle.loads(pickle.dumps(tf)).to_json() == tf.to_json()


def test_transfer_functions():
    tf = vkengine.TransferFunction.from_points(np.array([[0, 0, 0, 0, 0], [1, 1, 0.5, 0.2, 10.0]]))
    again = vkengine.TransferFunction.from_json(tf.to_json())
    assert again.to_json() == tf.to_json()
    assert "points" in vkengine.TransferFunction.preset("bone").to_json()
    with pytest.raises(ValueError, match="sorted"):
        vkengine.TransferFunction.from_points(np.array([[0.5, 0, 0, 0, 0], [0.1, 1, 1, 1, 1.0]]))
    with pytest.raises(ValueError, match="shape"):
        vkengine.TransferFunction.from_points(np.zeros((3, 4)))
    with pytest.raises(ValueError, match="preset"):
        vkengine.TransferFunction.preset("nope")


def test_image_files_round_trip(tmp_path):
    hdr = np.random.default_rng(1).random((3, 5, 4), dtype=np.float32)
    vkengine.write_image(str(tmp_path / "a.exr"), hdr)
    np.testing.assert_array_equal(vkengine.read_image(str(tmp_path / "a.exr")), hdr)
    with pytest.raises(ValueError, match="float32"):
        vkengine.write_image(str(tmp_path / "b.exr"), hdr.astype(np.float64))


def test_a_rust_panic_is_a_runtime_error():
    with pytest.raises(RuntimeError, match="internal error.*boom"):
        vkengine._native._panic_for_tests("boom")
    assert vkengine.Volume(np.ones((1, 1, 1), np.float32)).shape == (1, 1, 1)
