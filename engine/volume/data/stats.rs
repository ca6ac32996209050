//! CPU-side preparation of a volume's GPU data: gradient magnitudes, the value × gradient
//! histogram the transfer-function editor draws, and per-block value ranges for the occupancy
//! and majorant grids.

/// Voxels per occupancy block edge.
pub const BLOCK: u32 = 8;

/// Histogram and transfer-function table resolution along the value axis (the table is binned
/// as the histogram, so the editor draws one behind the other).
pub const TF_VALUES: usize = 256;
/// Histogram and transfer-function table resolution along the gradient-magnitude axis.
pub const TF_GRADIENTS: usize = 32;

/// Counts voxels per table cell, binned as the shaders look the table up (value by value,
/// gradient magnitude divided by its maximum).
pub(crate) fn histogram(values: &[u16], gradients: &[u16], max_gradient: f32) -> Vec<u32> {
    let mut h = vec![0u32; TF_VALUES * TF_GRADIENTS];
    let bin = histogram_bin(max_gradient);
    for (&v, &g) in values.iter().zip(gradients) {
        h[bin(v, g)] += 1;
    }
    h
}

/// The histogram cell of a (value, gradient magnitude) pair, for gradients up to `max_gradient`.
pub(crate) fn histogram_bin(max_gradient: f32) -> impl Fn(u16, u16) -> usize {
    let inv = if max_gradient > 0.0 { 1.0 / (max_gradient * 65535.0) } else { 0.0 };
    move |v, g| {
        let x = ((v as f32 / 65535.0) * (TF_VALUES - 1) as f32).round() as usize;
        let y = ((g as f32 * inv).min(1.0) * (TF_GRADIENTS - 1) as f32).round() as usize;
        y * TF_VALUES + x
    }
}

/// |∇v| as [`gradient_magnitudes`] stores it, from the central differences of normalized values.
pub(crate) fn gradient_u16(dx: [u16; 2], dy: [u16; 2], dz: [u16; 2]) -> u16 {
    let d = |[a, b]: [u16; 2]| a as f32 / 65535.0 - b as f32 / 65535.0;
    let (gx, gy, gz) = (d(dx), d(dy), d(dz));
    let g = 0.5 * (gx * gx + gy * gy + gz * gz).sqrt();
    (g.clamp(0.0, 1.0) * 65535.0).round() as u16
}

/// |∇v| per voxel by central differences with clamp-to-edge (as the shader's on-the-fly
/// `gradient`), in value change per voxel, stored as 16-bit unorm.
pub fn gradient_magnitudes(values: &[u16], dims: [u32; 3]) -> Vec<u16> {
    let [nx, ny, nz] = dims.map(|d| d as i64);
    let at = |x: i64, y: i64, z: i64| {
        let (x, y, z) = (x.clamp(0, nx - 1), y.clamp(0, ny - 1), z.clamp(0, nz - 1));
        values[((z * ny + y) * nx + x) as usize]
    };
    let mut out = Vec::with_capacity(values.len());
    for z in 0..nz {
        for y in 0..ny {
            for x in 0..nx {
                out.push(gradient_u16(
                    [at(x + 1, y, z), at(x - 1, y, z)],
                    [at(x, y + 1, z), at(x, y - 1, z)],
                    [at(x, y, z + 1), at(x, y, z - 1)],
                ));
            }
        }
    }
    out
}

/// Per-block [min, max] of normalized values over the block dilated by one voxel.
pub(crate) fn block_ranges(values: &[u16], dims: [u32; 3], grid: [u32; 3]) -> Vec<[f32; 2]> {
    let mut out = Vec::with_capacity((grid[0] * grid[1] * grid[2]) as usize);
    let range = |b: u32, d: u32| (b * BLOCK).saturating_sub(1)..((b + 1) * BLOCK + 1).min(d);
    for bz in 0..grid[2] {
        for by in 0..grid[1] {
            for bx in 0..grid[0] {
                let (mut lo, mut hi) = (u16::MAX, 0u16);
                for z in range(bz, dims[2]) {
                    for y in range(by, dims[1]) {
                        let row = ((z * dims[1] + y) * dims[0]) as usize;
                        for x in range(bx, dims[0]) {
                            let v = values[row + x as usize];
                            lo = lo.min(v);
                            hi = hi.max(v);
                        }
                    }
                }
                out.push([lo as f32 / 65535.0, hi as f32 / 65535.0]);
            }
        }
    }
    out
}
