//! Reordering voxels into patient axes, so the same scan gives the same volume whatever the format
//! or the acquisition plane: x runs to the patient's left, y to posterior, z to superior (DICOM's LPS).

use super::{value_buffer, VolumeError};

/// A volume's voxels with their geometry, as a loader hands them over.
pub(crate) struct Grid {
    pub dims: [u32; 3],
    pub spacing: [f32; 3],
    pub data: Vec<f32>,
}

/// Where a reorientation sends each voxel: the output geometry, and per source axis the output
/// axis it becomes and whether it runs backwards.
pub(crate) struct Plan {
    pub dims: [u32; 3],
    pub spacing: [f32; 3],
    world: [usize; 3],
    flip: [bool; 3],
}

/// Visits output indices in source order (x fastest) without a division per voxel.
pub(crate) struct Walker {
    step: [i64; 3],
    n: [u32; 3],
    c: [u32; 3],
    index: i64,
}

impl Walker {
    /// The output index of the next source voxel.
    pub fn next_index(&mut self) -> usize {
        let at = self.index as usize;
        for a in 0..3 {
            self.c[a] += 1;
            self.index += self.step[a];
            if self.c[a] < self.n[a] {
                break;
            }
            self.index -= self.step[a] * i64::from(self.n[a]);
            self.c[a] = 0;
        }
        at
    }
}

impl Plan {
    /// Output index step per source axis, and the output index of source voxel (0, 0, 0).
    fn steps(&self, src: [u32; 3]) -> ([i64; 3], i64) {
        let d = self.dims.map(i64::from);
        let stride = [1, d[0], d[0] * d[1]];
        let mut step = [0i64; 3];
        let mut base = 0i64;
        for i in 0..3 {
            let s = stride[self.world[i]];
            step[i] = if self.flip[i] { -s } else { s };
            if self.flip[i] {
                base += (i64::from(src[i]) - 1) * s;
            }
        }
        (step, base)
    }

    /// Output index of source voxel `i` of a `src`-sized grid (the walker's reference).
    #[cfg(test)]
    pub fn target(&self, src: [u32; 3], i: u64) -> u64 {
        let (step, base) = self.steps(src);
        let n = src.map(u64::from);
        let c = [i % n[0], (i / n[0]) % n[1], i / (n[0] * n[1])];
        (base + (0..3).map(|a| c[a] as i64 * step[a]).sum::<i64>()) as u64
    }

    /// Whether each source slice (z) is the output slice of the same index, reordered within.
    pub fn keeps_slices(&self) -> bool {
        self.world[2] == 2 && !self.flip[2]
    }

    /// Whether each source slice (z) is output slice n − 1 − z, reordered within.
    pub fn reverses_slices(&self) -> bool {
        self.world[2] == 2 && self.flip[2]
    }

    /// A walker over the output indices of a `src`-sized grid's voxels, in source order.
    pub fn walker(&self, src: [u32; 3]) -> Walker {
        let (step, base) = self.steps(src);
        Walker { step, n: src, c: [0; 3], index: base }
    }
}

/// How voxels with axes `axes` (the LPS direction of each voxel axis) must move to follow L, P, S;
/// `None` when they already do or the orientation is unusable (with a warning saying so).
/// An oblique orientation snaps to the nearest axes (with a warning): a 3D texture has no rotation.
pub(crate) fn plan(
    file: &str,
    dims: [u32; 3],
    spacing: [f32; 3],
    axes: [[f64; 3]; 3],
    warnings: &mut Vec<String>,
) -> Option<Plan> {
    let mut world = [0usize; 3];
    let mut flip = [false; 3];
    let mut oblique = false;
    for (i, a) in axes.iter().enumerate() {
        let norm = a.iter().map(|c| c * c).sum::<f64>().sqrt();
        if !norm.is_finite() || norm <= 1e-9 {
            warnings.push(format!("{file}: degenerate orientation {axes:?} ignored; voxels kept in stored order"));
            return None;
        }
        let j = (0..3).max_by(|&p, &q| a[p].abs().total_cmp(&a[q].abs())).unwrap_or(i);
        world[i] = j;
        flip[i] = a[j] < 0.0;
        oblique |= (0..3).any(|k| k != j && (a[k] / norm).abs() > 1e-3);
    }
    if world[0] == world[1] || world[1] == world[2] || world[0] == world[2] {
        warnings.push(format!("{file}: orientation {axes:?} is not a rotation; voxels kept in stored order"));
        return None;
    }
    if oblique {
        warnings.push(format!(
            "{file}: oblique orientation; the volume is shown along the nearest patient axes (rotation ignored)"
        ));
    }
    if world == [0, 1, 2] && flip == [false; 3] {
        return None;
    }
    let mut out_dims = [0u32; 3];
    let mut out_spacing = [0f32; 3];
    for i in 0..3 {
        out_dims[world[i]] = dims[i];
        out_spacing[world[i]] = spacing[i];
    }
    Some(Plan { dims: out_dims, spacing: out_spacing, world, flip })
}

/// Reorders `grid` so that voxel axes follow L, P, S. `axes[i]` is the LPS direction of voxel axis i.
pub(crate) fn to_lps(
    file: &str,
    grid: Grid,
    axes: [[f64; 3]; 3],
    warnings: &mut Vec<String>,
) -> Result<Grid, VolumeError> {
    let Some(p) = plan(file, grid.dims, grid.spacing, axes, warnings) else { return Ok(grid) };
    let mut data = value_buffer(file, grid.data.len() as u64)?;
    data.resize(grid.data.len(), 0.0);
    let mut walk = p.walker(grid.dims);
    for &v in &grid.data {
        data[walk.next_index()] = v;
    }
    Ok(Grid { dims: p.dims, spacing: p.spacing, data })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn flips_and_permutes_axes() {
        // 2x3x1 grid, x fastest; voxel x runs to posterior (world y), voxel y to the right (−L).
        let grid = Grid { dims: [2, 3, 1], spacing: [1.0, 2.0, 3.0], data: vec![0., 1., 2., 3., 4., 5.] };
        let mut w = Vec::new();
        let g = to_lps("f", grid, [[0., 1., 0.], [-1., 0., 0.], [0., 0., 1.]], &mut w).expect("orient");
        assert_eq!(g.dims, [3, 2, 1]);
        assert_eq!(g.spacing, [2.0, 1.0, 3.0]);
        // Output (X, Y) = source (x = Y, y = 2 − X).
        assert_eq!(g.data, vec![4., 2., 0., 5., 3., 1.]);
        assert!(w.is_empty());
    }

    #[test]
    fn walker_and_target_agree_on_every_voxel() {
        let mut w = Vec::new();
        let p = plan("f", [3, 4, 5], [1.0; 3], [[0., 0., -1.], [1., 0., 0.], [0., -1., 0.]], &mut w).expect("plan");
        assert_eq!(p.dims, [4, 5, 3]);
        let mut walk = p.walker([3, 4, 5]);
        let mut seen = [false; 60];
        for i in 0..60 {
            let t = walk.next_index();
            assert_eq!(t as u64, p.target([3, 4, 5], i), "voxel {i}");
            seen[t] = true;
        }
        assert!(seen.iter().all(|&s| s), "a permutation");
    }
}
