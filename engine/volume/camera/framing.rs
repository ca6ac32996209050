//! What the default volume camera frames: the object in the volume's box, so a scan with a
//! wide empty border still fills the view.
//!
//! The object is the voxels at or above the histogram's Otsu threshold (background against
//! object, [`histogram_ramp`]): it depends on the data alone, so changing the transfer function
//! in the window or on the command line keeps the camera where it was.

use crate::volume::data::Volume;
use crate::volume::optics::tf_choice::histogram_ramp;
use glam::Vec3;

/// Centre and half-extent (world units, in the box `±box_half`) of the cells of the voxels at
/// or above the volume's Otsu threshold; the whole box when there are none.
pub fn object_box(volume: &Volume, box_half: Vec3) -> (Vec3, Vec3) {
    let [threshold, _] = histogram_ramp(volume);
    let visible = |v: f32| v >= threshold;
    let [nx, ny, nz] = volume.dims.map(|d| d as usize);
    let (mut min, mut max) = ([usize::MAX; 3], [0usize; 3]);
    if let Some(g) = volume.sparse_only() {
        // A sparse grid's box may hold more voxels than can be visited: its leaves and tiles.
        let range = volume.value_range;
        if let Some((lo, hi)) = g.bounds(|q| visible(crate::volume::data::dequantize(q, range))) {
            (min, max) = (lo.map(|c| c as usize), hi.map(|c| c as usize));
        }
    }
    for z in (0..nz).filter(|_| volume.sparse_only().is_none()) {
        for y in 0..ny {
            let Some((first, last)) = volume.row_span(y as u32, z as u32, visible) else { continue };
            min = [min[0].min(first), min[1].min(y), min[2].min(z)];
            max = [max[0].max(last), max[1].max(y), max[2].max(z)];
        }
    }
    if min[0] == usize::MAX {
        return (Vec3::ZERO, box_half);
    }
    let dims = Vec3::new(nx as f32, ny as f32, nz as f32);
    let to_world = |i: [usize; 3]| (Vec3::new(i[0] as f32, i[1] as f32, i[2] as f32) / dims * 2.0 - 1.0) * box_half;
    let (a, b) = (to_world(min), to_world(max.map(|m| m + 1)));
    ((a + b) * 0.5, (b - a) * 0.5)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::volume::data::{self, LoadOptions};

    #[test]
    fn the_object_box_is_the_cells_above_the_threshold() {
        // 10×4×2 voxels, all 0 but a 1 at x = 6..=7, y = 1, z = 1.
        let mut data = vec![0.0f32; 80];
        for x in 6..=7 {
            data[(4 + 1) * 10 + x] = 1.0;
        }
        let v = Volume::new([10, 4, 2], [1.0; 3], data, "test").expect("volume");
        let half = Vec3::new(0.5, 0.2, 0.1);
        let (c, h) = object_box(&v, half);
        // Cells x 6..8 of 10 → [0.2, 0.6]·0.5; y 1..2 of 4 → [−0.5, 0]·0.2; z 1..2 of 2 → [0, 1]·0.1.
        let (want_c, want_h) = (Vec3::new(0.2, -0.05, 0.05), Vec3::new(0.1, 0.05, 0.05));
        assert!((c - want_c).length() < 1e-6 && (h - want_h).length() < 1e-6, "{c} {h}");
        // A constant volume has no object: the whole box.
        let flat = Volume::new([10, 4, 2], [1.0; 3], vec![0.5; 80], "flat").expect("volume");
        assert_eq!(object_box(&flat, half), (Vec3::ZERO, half));
    }

    #[test]
    fn a_grid_kept_sparse_frames_and_ramps_as_its_dense_samples() {
        for name in ["sparse.vdb", "smoke.vdb"] {
            let p = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/formats").join(name);
            let s = data::load(&p, &LoadOptions { stream_above: 0, ..LoadOptions::default() }).expect("sparse");
            let mut d = s.clone();
            d.normalized = Some(s.normalized_u16().into_owned());
            d.sparse = None;
            let total: u64 = s.value_counts().map(|(_, n)| n).sum();
            assert_eq!(total, d.voxel_count() as u64, "{name}: voxels counted");
            assert_eq!(histogram_ramp(&s), histogram_ramp(&d), "{name}: ramp");
            let half = glam::Vec3::new(0.5, 0.3, 0.2);
            assert_eq!(object_box(&s, half), object_box(&d, half), "{name}: object box");
        }
    }
}
