//! CPU mirrors of the micro-benchmark kernels (`shaders_glsl/profile/`): what each writes, so
//! tests can check the work exactly, and the byte encodings of their inputs.

/// Invocations per workgroup of the buffer kernels (`WG` in `profile/common.glsl`).
pub const WG: u32 = 64;
/// vec4s each buffer-kernel invocation reads or writes (`ITEMS`).
pub const ITEMS: u32 = 32;
/// Texels along z each storage-image invocation covers (`ZITEMS`).
pub const ZITEMS: u32 = 16;
/// Trilinear fetches per texture-kernel invocation (`TEXTURE_FETCHES`).
pub const TEXTURE_FETCHES: u32 = 8;
/// What each tiny dispatch stores (`profile/tiny.comp`).
pub const TINY_MARKER: u32 = 0xD15A;
/// Addresses the contended atomics share.
pub const CONTENDED_ADDRESSES: u32 = 64;

/// `pattern(i)` of `profile/common.glsl`: what the write kernels store at element i.
pub fn pattern(i: u32) -> [f32; 4] {
    [(i & 0xFFF) as f32, ((i >> 12) & 0xFFF) as f32, (i >> 24) as f32, 1.0]
}

/// The read kernels' input at element j: small integers, so every sum is exact in f32.
pub fn read_input(j: u32) -> [f32; 4] {
    [(j % 7) as f32, (j % 5) as f32, (j % 3) as f32, 1.0]
}

/// `pcg_hash` of `common/hash.glsl`.
pub fn pcg_hash(v: u32) -> u32 {
    let state = v.wrapping_mul(747796405).wrapping_add(2891336453);
    let word = ((state >> ((state >> 28) + 4)) ^ state).wrapping_mul(277803737);
    (word >> 22) ^ word
}

/// Little-endian bytes of vec4s.
pub fn vec4_bytes(v: impl Iterator<Item = [f32; 4]>) -> Vec<u8> {
    v.flat_map(|t| t.into_iter().flat_map(f32::to_le_bytes)).collect()
}

/// Decodes little-endian u32 words.
pub fn u32s(bytes: &[u8]) -> Vec<u32> {
    bytes.chunks_exact(4).map(|c| u32::from_le_bytes([c[0], c[1], c[2], c[3]])).collect()
}

/// Decodes little-endian f32 vec4s.
pub fn vec4s(bytes: &[u8]) -> Vec<[f32; 4]> {
    u32s(bytes).chunks_exact(4).map(|c| [0, 1, 2, 3].map(|i| f32::from_bits(c[i]))).collect()
}

/// Component-wise sum.
pub fn add4(a: [f32; 4], b: [f32; 4]) -> [f32; 4] {
    [a[0] + b[0], a[1] + b[1], a[2] + b[2], a[3] + b[3]]
}

/// The copy source's word i.
pub fn copy_word(i: u32) -> u32 {
    i.wrapping_mul(2654435761) ^ 0xA5A5_A5A5
}

/// Texel (x, y, z) of the fetch benchmark's texture: linear in every channel.
pub fn texture_texel(x: u32, y: u32, z: u32) -> [f32; 4] {
    [x as f32, 2.0 * y as f32, 3.0 * z as f32, (x + y + z) as f32]
}

/// Coordinate of fetch k of invocation `id` (linear index `linear`) on a grid³ lattice, as
/// `profile/texture_fetch.comp` computes it.
pub fn fetch_coord(id: [u32; 3], linear: u32, k: u32, grid: u32, scattered: bool) -> [f32; 3] {
    if scattered {
        let h = pcg_hash(linear.wrapping_mul(TEXTURE_FETCHES).wrapping_add(k));
        [h & 1023, (h >> 10) & 1023, (h >> 20) & 1023].map(|v| (v as f32 + 0.5) * (1.0 / 1024.0))
    } else {
        let step = [0.25f32, 0.125, 0.0625];
        let inv = 1.0 / grid as f32;
        [0, 1, 2].map(|a| (id[a] as f32 + 0.5 + k as f32 * step[a]) * inv)
    }
}

/// Trilinear sample with clamp-to-edge of an n³ texture (x fastest) at normalised `uvw`.
pub fn trilinear(tex: &[[f32; 4]], n: u32, uvw: [f32; 3]) -> [f32; 4] {
    let mut i0 = [0u32; 3];
    let mut i1 = [0u32; 3];
    let mut f = [0f32; 3];
    for a in 0..3 {
        let t = uvw[a] * n as f32 - 0.5;
        let fl = t.floor();
        f[a] = t - fl;
        let clamp = |v: f32| v.clamp(0.0, (n - 1) as f32) as u32;
        i0[a] = clamp(fl);
        i1[a] = clamp(fl + 1.0);
    }
    let mut out = [0f32; 4];
    for corner in 0..8u32 {
        let pick = |a: usize| corner >> a & 1 == 1;
        let w: f32 = (0..3).map(|a| if pick(a) { f[a] } else { 1.0 - f[a] }).product();
        let [x, y, z] = [0, 1, 2].map(|a| if pick(a) { i1[a] } else { i0[a] });
        let t = tex[(x + n * (y + n * z)) as usize];
        for c in 0..4 {
            out[c] += w * t[c];
        }
    }
    out
}

/// The layout comparison's input: coefficient j of `cell`, an integer in 0..16.
pub fn lpv_input(cell: u32, j: u32) -> f32 {
    (pcg_hash(cell * 12 + j) & 15) as f32
}

/// CPU twin of `profile/lpv_layout.comp`: one gather step, per cell `[channel·4 + k]`.
pub fn lpv_reference(n: u32, input: &[[f32; 12]]) -> Vec<[f32; 12]> {
    const DIRS: [[i32; 3]; 6] = [[1, 0, 0], [-1, 0, 0], [0, 1, 0], [0, -1, 0], [0, 0, 1], [0, 0, -1]];
    let ni = n as i32;
    let mut out = vec![[0f32; 12]; input.len()];
    for z in 0..ni {
        for y in 0..ni {
            for x in 0..ni {
                let mut o = [0f32; 12];
                for d in DIRS {
                    let f = [x - d[0], y - d[1], z - d[2]];
                    if f.iter().any(|&v| v < 0 || v >= ni) {
                        continue;
                    }
                    let s = &input[(f[0] + ni * (f[1] + ni * f[2])) as usize];
                    let dv = d.map(|v| v as f32);
                    let basis = [0.5, -0.5 * dv[1], 0.5 * dv[2], -0.5 * dv[0]];
                    let lobe = [0.25, -0.5 * dv[1], 0.5 * dv[2], -0.5 * dv[0]];
                    for ch in 0..3 {
                        let c = &s[ch * 4..ch * 4 + 4];
                        let e: f32 = (0..4).map(|k| c[k] * basis[k]).sum();
                        for k in 0..4 {
                            o[ch * 4 + k] += 0.25 * c[k] + e * lobe[k];
                        }
                    }
                }
                out[(x + ni * (y + ni * z)) as usize] = o;
            }
        }
    }
    out
}
