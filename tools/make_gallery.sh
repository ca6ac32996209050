#!/usr/bin/env bash
# Renders the README gallery's real-data images (docs/gallery-*.png) with the release `volume`
# binary: an MR (the MNI152 2009a T1 template, NIfTI, shipped inside nilearn's wheel on PyPI) and
# a sparse cloud written by OpenVDB's own Python module (tools/make_vdb_cloud.py; Debian's
# python3-openvdb). No CT is reachable from the package registries this project may use, so the
# gallery has none. Inputs go to out/gallery/ (not committed).
set -euo pipefail
cd "$(dirname "$0")/.."
mkdir -p out/gallery
cargo build --locked --release --bin volume
vol=target/release/volume
mni=out/gallery/mni_icbm152_t1_tal_nlin_sym_09a_converted.nii.gz
if [ ! -f "$mni" ]; then
    python3 -m pip download --no-deps --dest out/gallery nilearn==0.14.1
    unzip -o -j out/gallery/nilearn-0.14.1-py3-none-any.whl \
        "nilearn/datasets/data/$(basename "$mni")" -d out/gallery
fi
# Its transfer function is the automatic choice (printed); the camera frames what it shows.
$vol --headless --volume "$mni" --renderer mcm --size 320x320 --frames 48 \
    --set bounces=8 --set env=0.15 --set yaw=0.7 --set pitch=0.3 --set exposure=1.4 \
    --out docs/gallery-mr.png
dpkg -s python3-openvdb >/dev/null 2>&1 || apt-get install -y python3-openvdb
/usr/bin/python3 tools/make_vdb_cloud.py out/gallery/cloud.vdb
$vol --headless --volume out/gallery/cloud.vdb --renderer mcm --size 320x240 --frames 64 \
    --set bounces=16 --set env=0.08 --set yaw=2.2 --set pitch=0.2 --set exposure=1.6 --set density=2 \
    --out docs/gallery-vdb.png
