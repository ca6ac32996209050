//! Where the cascades sit: nested grids that follow the camera, snapped to whole cells so a
//! moving camera never shifts the lattice by a fraction of a cell (which would make light swim).

use glam::Vec3;

/// One cascade: `n`³ cells of edge `cell`, the grid's minimum corner at `origin`.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize)]
pub struct Cascade {
    /// Cells per edge.
    pub n: u32,
    /// Cell edge (metres).
    pub cell: f32,
    /// Minimum corner (a whole multiple of `cell` on each axis).
    pub origin: [f32; 3],
}

impl Cascade {
    /// The grid's maximum corner.
    pub fn max(&self) -> Vec3 {
        Vec3::from(self.origin) + Vec3::splat(self.cell * self.n as f32)
    }

    /// Whether the grid overlaps the box `[lo, hi]`.
    pub fn overlaps(&self, lo: Vec3, hi: Vec3) -> bool {
        let (a, b) = (Vec3::from(self.origin), self.max());
        a.cmple(hi).all() && b.cmpge(lo).all()
    }

    /// Whether the grid contains the box `[lo, hi]`.
    pub fn contains(&self, lo: Vec3, hi: Vec3) -> bool {
        let (a, b) = (Vec3::from(self.origin), self.max());
        a.cmple(lo).all() && b.cmpge(hi).all()
    }
}

/// Places up to `count` cascades of `n`³ cells around the camera, each twice the extent of the
/// previous, the finest `extent` wide (0: the scene's largest side, so one cascade holds it all).
/// Grids are centred a quarter extent ahead of the camera (more of them lies in view) and
/// snapped with `floor` (truncation toward zero would snap asymmetrically below the origin).
/// Cascades that miss the scene are dropped, and once one contains the whole scene, coarser ones
/// would only repeat it at lower resolution, so they are dropped too.
pub fn place(camera: Vec3, forward: Vec3, scene: [Vec3; 2], n: u32, count: u32, extent: f32) -> Vec<Cascade> {
    place_following(camera, forward, scene, [n, count], extent, 0.0, &[])
}

/// [`place`], except that a cascade of `previous` with the same cells stays where it is until
/// the placement would move it by more than `slack` cells along some axis (0: [`place`]): a
/// walking camera then moves the finest cascade, whose cells it crosses nearly every frame, only
/// every few frames, so an unchanged cascade's LPV is reused more often and snaps less often.
pub fn place_following(
    camera: Vec3,
    forward: Vec3,
    scene: [Vec3; 2],
    [n, count]: [u32; 2],
    extent: f32,
    slack: f32,
    previous: &[Cascade],
) -> Vec<Cascade> {
    let size = scene[1] - scene[0];
    // Fitting the scene: one cell of margin on each side survives the snap to whole cells.
    let fit = size.max_element().max(1e-3) * n as f32 / (n as f32 - 2.0).max(1.0);
    let base = if extent > 0.0 { extent } else { fit };
    let mut out = Vec::new();
    for k in 0..count {
        let e = base * (1u32 << k) as f32;
        let cell = e / n as f32;
        // A scene that fits entirely is centred on itself instead (no reason to follow the camera).
        let centre = if k == 0 && extent <= 0.0 {
            (scene[0] + scene[1]) * 0.5
        } else {
            camera + forward.normalize_or_zero() * (0.25 * e)
        };
        let mut origin = ((centre - Vec3::splat(0.5 * e)) / cell).floor() * cell;
        if let Some(p) = previous.iter().find(|p| p.n == n && p.cell == cell) {
            // Both origins are whole cells: the distance is a whole number of them.
            if ((origin - Vec3::from(p.origin)).abs().max_element() / cell).round() <= slack {
                origin = p.origin.into();
            }
        }
        let c = Cascade { n, cell, origin: origin.into() };
        if !c.overlaps(scene[0], scene[1]) {
            continue;
        }
        out.push(c);
        if c.contains(scene[0], scene[1]) {
            break;
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn origins_are_whole_cells_even_below_zero() {
        let scene = [Vec3::splat(-100.0), Vec3::splat(100.0)];
        for cam in [Vec3::new(-3.3, 0.7, -0.01), Vec3::new(5.55, -7.25, 2.0)] {
            for c in place(cam, Vec3::Z, scene, 32, 3, 8.0) {
                for o in c.origin {
                    let k = o / c.cell;
                    assert!((k - k.round()).abs() < 1e-3, "origin {o} is not a whole number of cells {}", c.cell);
                }
                let centre = (Vec3::from(c.origin) + c.max()) * 0.5;
                assert!((centre - (cam + Vec3::Z * 0.25 * c.cell * 32.0)).abs().max_element() <= c.cell);
            }
        }
    }

    #[test]
    fn a_following_cascade_stays_until_the_camera_drifts_past_the_slack() {
        let scene = [Vec3::splat(-100.0), Vec3::splat(100.0)];
        let place_at = |x: f32, slack: f32, prev: &[Cascade]| {
            place_following(Vec3::new(x, 0.0, 0.0), Vec3::Z, scene, [32, 2], 8.0, slack, prev)
        };
        let start = place_at(0.0, 2.0, &[]);
        assert_eq!(start, place(Vec3::ZERO, Vec3::Z, scene, 32, 2, 8.0));
        let cell = start[0].cell;
        // 1.5 cells along x: the finest moves without slack, stays with 2 cells of it.
        assert_ne!(place_at(1.5 * cell, 0.0, &start)[0], start[0]);
        assert_eq!(place_at(1.5 * cell, 2.0, &start), start);
        // 3.5 cells: past the slack, the finest snaps to where `place` puts it; the coarser
        // (cells twice as large) has moved 1.75 of its cells and stays.
        let moved = place_at(3.5 * cell, 2.0, &start);
        assert_eq!(moved[0], place(Vec3::new(3.5 * cell, 0.0, 0.0), Vec3::Z, scene, 32, 2, 8.0)[0]);
        assert_ne!(moved[0], start[0]);
        assert_eq!(moved[1], start[1]);
    }

    #[test]
    fn cascades_nest_and_stop_once_the_scene_fits() {
        let scene = [Vec3::ZERO, Vec3::new(20.0, 8.0, 20.0)];
        let cs = place(Vec3::new(10.0, 2.0, 10.0), Vec3::X, scene, 32, 4, 6.0);
        assert!(cs.len() >= 2 && cs.len() <= 4, "{cs:?}");
        assert!(cs.windows(2).all(|w| (w[1].cell / w[0].cell - 2.0).abs() < 1e-6));
        assert!(cs.last().is_some_and(|c| c.contains(scene[0], scene[1])) || cs.len() == 4);
        // A small scene fits the first cascade: one grid, centred on the scene.
        let small = [Vec3::ZERO, Vec3::splat(0.5)];
        let cs = place(Vec3::new(0.25, 0.25, -1.0), Vec3::Z, small, 32, 4, 0.0);
        assert_eq!(cs.len(), 1);
        assert!(cs[0].contains(small[0], small[1]));
        // A cascade far from the scene is not built at all.
        let cs = place(Vec3::splat(1000.0), Vec3::Z, small, 32, 2, 1.0);
        assert!(cs.is_empty());
    }
}

/// A light grid read back to the host, in the images' order: per channel (R, G, B), per cell
/// (x fastest, cascades stacked along z), the four SH coefficients.
#[derive(Clone, Debug, Default)]
pub struct HostGrid {
    values: Vec<f32>,
}

impl HostGrid {
    /// Wraps three channel images' texels, back to back.
    pub fn new(values: Vec<f32>) -> Self {
        Self { values }
    }

    /// Cells per channel (all cascades).
    pub fn cells(&self) -> usize {
        self.values.len() / 12
    }

    /// The SH coefficients of channel `ch` (0 R, 1 G, 2 B) in cell `cell`.
    pub fn coeffs(&self, ch: usize, cell: usize) -> [f32; 4] {
        let i = (ch * self.cells() + cell) * 4;
        std::array::from_fn(|k| self.values.get(i + k).copied().unwrap_or(0.0))
    }

    /// Every coefficient, in storage order.
    pub fn values(&self) -> &[f32] {
        &self.values
    }
}
