#!/usr/bin/env python3
"""Writes the small DICOM, NIfTI and OpenVDB files under tests/data/formats with independent writers
(pydicom, nibabel, OpenVDB's Python module), so the engine's loaders are tested against files that
the reference tools produce. Run once; the outputs are committed (a few KB in all).

    python3 -m venv /tmp/fx && /tmp/fx/bin/pip install pydicom nibabel numpy
    apt-get install python3-openvdb
    /tmp/fx/bin/python tools/make_format_fixtures.py dicom nifti   # pydicom + nibabel
    /usr/bin/python3 tools/make_format_fixtures.py vdb             # Debian's pyopenvdb
    /tmp/fx/bin/python tools/make_format_fixtures.py rtdose        # pydicom's own RT Dose file

Ground truth, shared by every format: a 6x5x4 volume (x fastest) whose stored value at (x, y, z)
is 300 z + 10 y + x; DICOM/NIfTI rescale it with slope 2, intercept -1000 (so -1000 .. 1290).
"""
import os
import shutil
import sys

OUT = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "tests", "data", "formats")
NX, NY, NZ = 6, 5, 4


def stored(x, y, z):
    return 300 * z + 10 * y + x


def dicom():
    import numpy as np
    import pydicom
    from pydicom.dataset import Dataset, FileMetaDataset
    from pydicom.uid import CTImageStorage, ExplicitVRLittleEndian, RLELossless, generate_uid, EnhancedCTImageStorage

    study = "1.2.826.0.1.3680043.8.498.1"

    def base(series, sop_class):
        meta = FileMetaDataset()
        meta.MediaStorageSOPClassUID = sop_class
        meta.MediaStorageSOPInstanceUID = generate_uid()
        meta.TransferSyntaxUID = ExplicitVRLittleEndian
        ds = Dataset()
        ds.file_meta = meta
        ds.SOPClassUID = sop_class
        ds.SOPInstanceUID = meta.MediaStorageSOPInstanceUID
        ds.StudyInstanceUID = study
        ds.SeriesInstanceUID = series
        ds.Modality = "CT"
        ds.SeriesDescription = "fixture"
        ds.PatientName = "Fixture^Volume"
        ds.PatientID = "0"
        ds.Rows, ds.Columns = NY, NX
        ds.SamplesPerPixel = 1
        ds.PhotometricInterpretation = "MONOCHROME2"
        ds.BitsAllocated, ds.BitsStored, ds.HighBit = 16, 16, 15
        ds.PixelRepresentation = 1
        ds.PixelSpacing = [0.8, 0.6]  # row spacing (y), column spacing (x)
        ds.RescaleSlope, ds.RescaleIntercept = 2, -1000
        return ds

    def plane(z):
        return np.array([[stored(x, y, z) for x in range(NX)] for y in range(NY)], dtype=np.int16)

    def series(folder, uid, names, compress=False, zs=range(NZ)):
        os.makedirs(folder, exist_ok=True)
        for z, name in zip(zs, names):
            ds = base(uid, CTImageStorage)
            ds.ImageOrientationPatient = [1, 0, 0, 0, 1, 0]
            ds.ImagePositionPatient = [-10, -20, 5 + 2.5 * z]
            # Instance numbers run against the geometry so that ordering by them would fail too.
            ds.InstanceNumber = NZ - z
            ds.PixelData = plane(z).tobytes()
            if compress:
                ds.compress(RLELossless, plane(z))
            ds.save_as(os.path.join(folder, name), enforce_file_format=True)

    # File names in an order that differs from the slice positions: b, d, a, c is z = 0..3.
    names = ["b.dcm", "d.dcm", "a.dcm", "c.dcm"]
    series(os.path.join(OUT, "ct_series"), "1.2.826.0.1.3680043.8.498.10", names)
    series(os.path.join(OUT, "ct_rle"), "1.2.826.0.1.3680043.8.498.11", names, compress=True)
    two = os.path.join(OUT, "two_series")
    series(two, "1.2.826.0.1.3680043.8.498.12", ["s1_0.dcm", "s1_1.dcm"], zs=range(2))
    series(two, "1.2.826.0.1.3680043.8.498.13", ["s2_0.dcm", "s2_1.dcm"], zs=range(2))

    # Enhanced multi-frame CT: frames stored in the order z = 1, 3, 0, 2 with per-frame positions.
    ds = base("1.2.826.0.1.3680043.8.498.14", EnhancedCTImageStorage)
    order = [1, 3, 0, 2]
    ds.NumberOfFrames = len(order)
    del ds.PixelSpacing, ds.RescaleSlope, ds.RescaleIntercept
    shared = Dataset()
    pm = Dataset()
    pm.PixelSpacing = [0.8, 0.6]
    pm.SliceThickness = 2.5
    po = Dataset()
    po.ImageOrientationPatient = [1, 0, 0, 0, 1, 0]
    pv = Dataset()
    pv.RescaleSlope, pv.RescaleIntercept, pv.RescaleType = 2, -1000, "HU"
    shared.PixelMeasuresSequence = [pm]
    shared.PlaneOrientationSequence = [po]
    shared.PixelValueTransformationSequence = [pv]
    ds.SharedFunctionalGroupsSequence = [shared]
    frames = []
    for z in order:
        f = Dataset()
        pp = Dataset()
        pp.ImagePositionPatient = [-10, -20, 5 + 2.5 * z]
        f.PlanePositionSequence = [pp]
        frames.append(f)
    ds.PerFrameFunctionalGroupsSequence = frames
    ds.PixelData = b"".join(plane(z).tobytes() for z in order)
    ds.save_as(os.path.join(OUT, "ct_multiframe.dcm"), enforce_file_format=True)


def nifti():
    import nibabel as nib
    import numpy as np

    data = np.zeros((NX, NY, NZ), dtype=np.int16)
    for z in range(NZ):
        for y in range(NY):
            for x in range(NX):
                data[x, y, z] = stored(x, y, z)
    # As a converter writes the DICOM series: voxel axes along patient left and posterior, which
    # NIfTI's RAS world space spells with negative x and y.
    affine = np.diag([-0.6, -0.8, 2.5, 1.0])
    for cls, name in [(nib.Nifti1Image, "ramp1"), (nib.Nifti2Image, "ramp2")]:
        img = cls(data, affine)
        img.header.set_slope_inter(2.0, -1000.0)
        img.header.set_xyzt_units("mm")
        img.set_qform(affine, 1)
        img.set_sform(affine, 1)
        nib.save(img, os.path.join(OUT, name + ".nii"))
        nib.save(img, os.path.join(OUT, name + ".nii.gz"))
    # The same scan stored in RAS order (x to the right, y to anterior): the loader flips it back.
    flipped = np.ascontiguousarray(data[::-1, ::-1, :])
    ras = np.diag([0.6, 0.8, 2.5, 1.0])
    img = nib.Nifti1Image(flipped, ras)
    img.header.set_slope_inter(2.0, -1000.0)
    img.set_qform(ras, 1)
    img.set_sform(ras, 1)
    nib.save(img, os.path.join(OUT, "ramp_ras.nii.gz"))
    # Only a qform (sform code 0): the quaternion path.
    img = nib.Nifti1Image(flipped, ras)
    img.header.set_slope_inter(2.0, -1000.0)
    img.set_qform(ras, 1)
    img.set_sform(None, 0)
    nib.save(img, os.path.join(OUT, "ramp_ras_qform.nii"))
    # 4D: two volumes, the second one = the first + 1 (stored).
    four = np.stack([data, data + 1], axis=3)
    img = nib.Nifti1Image(four, affine)
    img.header.set_slope_inter(2.0, -1000.0)
    nib.save(img, os.path.join(OUT, "ramp_4d.nii.gz"))


def vdb():
    import pyopenvdb as vdb

    # A sparse "cloud": a few single active voxels (two of them in one leaf), one negative-index voxel,
    # and a filled 8x8x8 block that OpenVDB may store as an active tile; background 0.
    g = vdb.FloatGrid(background=0.0)
    g.name = "density"
    a = g.getAccessor()
    for (x, y, z, v) in [(0, 0, 0, 1.0), (3, 1, 2, 2.5), (20, 9, 5, 0.75), (-4, 2, 1, 3.0)]:
        a.setValueOn((x, y, z), v)
    g.fill((8, 0, 0), (15, 7, 7), 0.5, active=True)
    g.transform = vdb.createLinearTransform(voxelSize=0.5)
    t = vdb.FloatGrid(background=0.25)
    t.name = "temperature"
    t.fill((0, 0, 0), (1, 1, 1), 4.0, active=True)
    v = vdb.Vec3SGrid()
    v.name = "velocity"
    v.getAccessor().setValueOn((0, 0, 0), (1, 0, 0))
    vdb.write(os.path.join(OUT, "sparse.vdb"), grids=[g, t, v])
    # A cube with a dense 64^3 interior region so that several leaves and compression kick in.
    c = vdb.FloatGrid(background=0.0)
    c.name = "smoke"
    c.fill((0, 0, 0), (39, 23, 15), 1.0, active=True)
    ca = c.getAccessor()
    for i in range(40):
        ca.setValueOn((i, i % 24, i % 16), 2.0 + i)
    c.transform = vdb.createLinearTransform(voxelSize=0.25)
    vdb.write(os.path.join(OUT, "smoke.vdb"), grids=[c])


def rtdose():
    """pydicom's test file rtdose.dcm (10x10, 15 frames placed by GridFrameOffsetVector, 32-bit,
    DoseGridScaling 1e-6), copied as written by pydicom's authors, and the same dose grid with
    absolute offsets (the first equals the z of ImagePositionPatient) stored from the top frame
    down, which must load as the same volume."""
    import pydicom
    from pydicom.data import get_testdata_file

    src = get_testdata_file("rtdose.dcm")
    shutil.copyfile(src, os.path.join(OUT, "rtdose.dcm"))
    ds = pydicom.dcmread(src)
    z0 = float(ds.ImagePositionPatient[2])
    offsets = [float(o) for o in ds.GridFrameOffsetVector]
    n = int(ds.NumberOfFrames)
    frame = ds.Rows * ds.Columns * ds.BitsAllocated // 8
    frames = [ds.PixelData[i * frame:(i + 1) * frame] for i in range(n)]
    ds.ImagePositionPatient = [ds.ImagePositionPatient[0], ds.ImagePositionPatient[1], z0 + offsets[-1]]
    ds.GridFrameOffsetVector = [z0 + o for o in reversed(offsets)]
    ds.PixelData = b"".join(reversed(frames))
    ds.save_as(os.path.join(OUT, "rtdose_absolute.dcm"), enforce_file_format=True)


if __name__ == "__main__":
    os.makedirs(OUT, exist_ok=True)
    for what in sys.argv[1:] or ["dicom", "nifti", "vdb"]:
        if what == "dicom":
            for d in ["ct_series", "ct_rle", "two_series"]:
                shutil.rmtree(os.path.join(OUT, d), ignore_errors=True)
        {"dicom": dicom, "nifti": nifti, "vdb": vdb, "rtdose": rtdose}[what]()
        print("wrote", what)
