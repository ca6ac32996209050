#!/usr/bin/env python3
"""Writes volumes with independent tools (nibabel, pydicom) into DIR, each with the values those
tools read back, for tests/volume_independent.rs: `independent_volumes.py DIR`.

For each case NAME: the file or folder the engine loads, and NAME.f32 (little-endian f32, x
fastest, in patient axes L, P, S as the engine orders them) with NAME.json ({"dims": [x, y, z]}).
The expected values come from the tools' own readers (nibabel's get_fdata and reorientation,
pydicom's pixel_array and the file's rescale), not from the engine's rules."""
import json
import os
import sys

import nibabel as nib
import numpy as np
import pydicom
from nibabel.orientations import apply_orientation, axcodes2ornt, io_orientation, ornt_transform
from pydicom.data import get_testdata_file
from pydicom.dataset import Dataset, FileMetaDataset
from pydicom.uid import CTImageStorage, ExplicitVRLittleEndian, EnhancedCTImageStorage, generate_uid


def expect(out, name, xyz):
    """xyz: values indexed [x, y, z] in patient axes L, P, S."""
    xyz = np.asarray(xyz, dtype=np.float64)
    xyz.astype("<f4").ravel(order="F").tofile(os.path.join(out, name + ".f32"))
    with open(os.path.join(out, name + ".json"), "w") as f:
        json.dump({"dims": list(xyz.shape)}, f)


def lps(img):
    """nibabel's values reoriented to L, P, S by nibabel's own orientation code."""
    data = img.get_fdata()
    t = ornt_transform(io_orientation(img.affine), axcodes2ornt(("L", "P", "S")))
    return apply_orientation(data, t)


def nifti(out):
    rng = np.random.default_rng(7)
    # Partial bricks on every axis; scaled integers; axes flipped and permuted by the affine.
    shape = (37, 29, 23)
    raw = rng.integers(0, 3000, size=shape, dtype=np.int16)
    raw[5:20, 3:15, 2:9] = 1500
    affine = np.array([[0.0, 0.0, -2.5, 10.0], [1.5, 0.0, 0.0, -4.0], [0.0, -2.0, 0.0, 7.0], [0, 0, 0, 1.0]])
    img = nib.Nifti1Image(raw, affine)
    img.header.set_slope_inter(0.5, -100.0)
    img.set_qform(affine, code=1)
    img.set_sform(affine, code=1)
    path = os.path.join(out, "nib_scaled.nii.gz")
    nib.save(img, path)
    expect(out, "nib_scaled.nii.gz", lps(nib.load(path)))
    # float32, already L, P, S order in RAS terms flipped: an identity-free plain case.
    data = (rng.random((21, 18, 35)) * 40.0).astype(np.float32)
    data[:, :, 20:28] = 7.0
    img = nib.Nifti1Image(data, np.diag([-1.0, -1.0, 1.0, 1.0]))
    path = os.path.join(out, "nib_float.nii")
    nib.save(img, path)
    expect(out, "nib_float.nii", lps(nib.load(path)))
    # RAS (what most tools write): x and y reversed into L, P, slices kept; more than one 4 MiB
    # slab, cut inside a slice.
    data = rng.integers(0, 30000, size=(203, 151, 70), dtype=np.int16)
    data[:, :, 10:40] = 100
    path = os.path.join(out, "nib_ras.nii")
    nib.save(nib.Nifti1Image(data, np.diag([0.8, 0.9, 1.1, 1.0])), path)
    expect(out, "nib_ras.nii", lps(nib.load(path)))
    # Slices stored superior to inferior (the slice axis reversed), with x and y swapped in the
    # plane; gzipped, so it can only be read front to back.
    data = rng.integers(0, 3000, size=(29, 37, 45), dtype=np.int16)
    data[:, :, 30:40] = 17
    affine = np.array([[0.0, -0.9, 0.0, 5.0], [-0.7, 0.0, 0.0, 2.0], [0.0, 0.0, -1.2, 9.0], [0, 0, 0, 1.0]])
    path = os.path.join(out, "nib_reversed.nii.gz")
    nib.save(nib.Nifti1Image(data, affine), path)
    expect(out, "nib_reversed.nii.gz", lps(nib.load(path)))


def meta(sop_class):
    m = FileMetaDataset()
    m.MediaStorageSOPClassUID = sop_class
    m.MediaStorageSOPInstanceUID = generate_uid()
    m.TransferSyntaxUID = ExplicitVRLittleEndian
    return m


def image(ds, rows, cols):
    ds.Rows, ds.Columns = rows, cols
    ds.SamplesPerPixel = 1
    ds.PhotometricInterpretation = "MONOCHROME2"
    ds.BitsAllocated, ds.BitsStored, ds.HighBit = 16, 16, 15
    ds.PixelRepresentation = 1
    ds.PixelSpacing = [0.7, 0.6]


def series(out, name="pydicom_series", orientation=(1, 0, 0, 0, 1, 0)):
    """A series in `orientation`; expected values in L, P, S from the rows, columns and
    positions as DICOM defines them (row direction = first triple, one axis each)."""
    rng = np.random.default_rng(11)
    rows, cols, n = 20, 27, 13
    folder = os.path.join(out, name)
    os.makedirs(folder, exist_ok=True)
    uid = generate_uid()
    slices = {}
    # Written in a shuffled order with names that say nothing: positions order them.
    for i, k in enumerate(rng.permutation(n)):
        px = rng.integers(-1000, 2000, size=(rows, cols), dtype=np.int16)
        px[4:12, 5:20] = 40
        ds = Dataset()
        ds.file_meta = meta(CTImageStorage)
        ds.SOPClassUID, ds.SOPInstanceUID = CTImageStorage, ds.file_meta.MediaStorageSOPInstanceUID
        ds.Modality, ds.SeriesInstanceUID = "CT", uid
        image(ds, rows, cols)
        ds.ImageOrientationPatient = list(orientation)
        ds.ImagePositionPatient = [-20.0, 15.0, -50.0 + 2.5 * float(k)]
        ds.RescaleSlope, ds.RescaleIntercept = 1, -24
        ds.PixelData = px.tobytes()
        ds.save_as(os.path.join(folder, f"img{i:03d}"), enforce_file_format=True)
    for f in os.listdir(folder):
        d = pydicom.dcmread(os.path.join(folder, f))
        z = float(d.ImagePositionPatient[2])
        slices[z] = d.pixel_array * float(d.RescaleSlope) + float(d.RescaleIntercept)
    stack = np.stack([slices[z] for z in sorted(slices)])  # [S, row, col]
    # Columns run along the row direction, rows along the column direction: each is the
    # patient axis its direction cosine names (both positive here), S ascending.
    row_axis, col_axis = int(np.argmax(np.abs(orientation[:3]))), int(np.argmax(np.abs(orientation[3:])))
    xyz = stack.transpose(2, 1, 0) if (row_axis, col_axis) == (0, 1) else stack.transpose(1, 2, 0)
    expect(out, name, xyz)


def multiframe(out):
    rng = np.random.default_rng(5)
    rows, cols, n = 17, 22, 11
    order = rng.permutation(n)
    frames = rng.integers(0, 4000, size=(n, rows, cols), dtype=np.int16)
    ds = Dataset()
    ds.file_meta = meta(EnhancedCTImageStorage)
    ds.SOPClassUID, ds.SOPInstanceUID = EnhancedCTImageStorage, ds.file_meta.MediaStorageSOPInstanceUID
    ds.Modality, ds.SeriesInstanceUID = "CT", generate_uid()
    image(ds, rows, cols)
    del ds.PixelSpacing
    ds.NumberOfFrames = n
    shared = Dataset()
    orient, measures = Dataset(), Dataset()
    orient.ImageOrientationPatient = [1, 0, 0, 0, 1, 0]
    measures.PixelSpacing, measures.SliceThickness = [0.5, 0.8], 3.0
    shared.PlaneOrientationSequence = [orient]
    shared.PixelMeasuresSequence = [measures]
    ds.SharedFunctionalGroupsSequence = [shared]
    per = []
    for f in range(n):
        item, pos, scale = Dataset(), Dataset(), Dataset()
        pos.ImagePositionPatient = [0.0, 0.0, 3.0 * float(order[f])]
        scale.RescaleSlope, scale.RescaleIntercept, scale.RescaleType = 2, 10, "US"
        item.PlanePositionSequence = [pos]
        item.PixelValueTransformationSequence = [scale]
        per.append(item)
    ds.PerFrameFunctionalGroupsSequence = per
    ds.PixelData = frames.tobytes()
    path = os.path.join(out, "pydicom_multiframe.dcm")
    ds.save_as(path, enforce_file_format=True)
    d = pydicom.dcmread(path)
    z = [float(g.PlanePositionSequence[0].ImagePositionPatient[2]) for g in d.PerFrameFunctionalGroupsSequence]
    t = [g.PixelValueTransformationSequence[0] for g in d.PerFrameFunctionalGroupsSequence]
    values = [d.pixel_array[f] * float(t[f].RescaleSlope) + float(t[f].RescaleIntercept) for f in range(n)]
    stack = np.stack([values[f] for f in np.argsort(z)])
    expect(out, "pydicom_multiframe.dcm", stack.transpose(2, 1, 0))


def rtdose(out):
    d = pydicom.dcmread(get_testdata_file("rtdose.dcm"))
    path = os.path.join(out, "pydicom_rtdose.dcm")
    d.save_as(path)
    d = pydicom.dcmread(path)
    offsets = [float(v) for v in d.GridFrameOffsetVector]
    dose = d.pixel_array * float(d.DoseGridScaling)
    stack = np.stack([dose[f] for f in np.argsort(offsets)])
    expect(out, "pydicom_rtdose.dcm", stack.transpose(2, 1, 0))


if __name__ == "__main__":
    out = sys.argv[1]
    os.makedirs(out, exist_ok=True)
    nifti(out)
    series(out)
    # Rows along P, columns along L: the slice normal (row × column) points to −S, so the stack
    # runs against S.
    series(out, "pydicom_series_reversed", (0, 1, 0, 1, 0, 0))
    multiframe(out)
    rtdose(out)
