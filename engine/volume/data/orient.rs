//! Reordering voxels into patient axes, so the same scan gives the same volume whatever the format
//! or the acquisition plane: x runs to the patient's left, y to posterior, z to superior (DICOM's LPS).

use super::{value_buffer, VolumeError};

/// A volume's voxels with their geometry, as a loader hands them over.
pub(crate) struct Grid {
    pub dims: [u32; 3],
    pub spacing: [f32; 3],
    pub data: Vec<f32>,
}

/// Reorders `grid` so that voxel axes follow L, P, S. `axes[i]` is the LPS direction of voxel axis i.
/// An oblique orientation snaps to the nearest axes (with a warning): a 3D texture has no rotation.
pub(crate) fn to_lps(
    file: &str,
    grid: Grid,
    axes: [[f64; 3]; 3],
    warnings: &mut Vec<String>,
) -> Result<Grid, VolumeError> {
    let mut world = [0usize; 3];
    let mut flip = [false; 3];
    let mut oblique = false;
    for (i, a) in axes.iter().enumerate() {
        let norm = a.iter().map(|c| c * c).sum::<f64>().sqrt();
        if !norm.is_finite() || norm <= 1e-9 {
            warnings.push(format!("{file}: degenerate orientation {axes:?} ignored; voxels kept in stored order"));
            return Ok(grid);
        }
        let j = (0..3).max_by(|&p, &q| a[p].abs().total_cmp(&a[q].abs())).unwrap_or(i);
        world[i] = j;
        flip[i] = a[j] < 0.0;
        oblique |= (0..3).any(|k| k != j && (a[k] / norm).abs() > 1e-3);
    }
    if world[0] == world[1] || world[1] == world[2] || world[0] == world[2] {
        warnings.push(format!("{file}: orientation {axes:?} is not a rotation; voxels kept in stored order"));
        return Ok(grid);
    }
    if oblique {
        warnings.push(format!(
            "{file}: oblique orientation; the volume is shown along the nearest patient axes (rotation ignored)"
        ));
    }
    if world == [0, 1, 2] && flip == [false; 3] {
        return Ok(grid);
    }
    let src = grid.dims.map(|d| d as usize);
    let stride = [1, src[0], src[0] * src[1]];
    let mut dims = [0u32; 3];
    let mut spacing = [0f32; 3];
    // Per output axis: the step through the source data, and the source axis it walks.
    let mut step = [0isize; 3];
    let mut start = 0isize;
    for i in 0..3 {
        let j = world[i];
        dims[j] = grid.dims[i];
        spacing[j] = grid.spacing[i];
        step[j] = if flip[i] { -(stride[i] as isize) } else { stride[i] as isize };
        if flip[i] {
            start += ((src[i] - 1) * stride[i]) as isize;
        }
    }
    let mut data = value_buffer(file, grid.data.len() as u64)?;
    for z in 0..dims[2] as isize {
        for y in 0..dims[1] as isize {
            let row = start + z * step[2] + y * step[1];
            data.extend((0..dims[0] as isize).map(|x| grid.data[(row + x * step[0]) as usize]));
        }
    }
    Ok(Grid { dims, spacing, data })
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
}
