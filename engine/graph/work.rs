//! What a pass does, in units a device limit can be measured in, so a profile can say how close
//! each pass runs to what the device can do (a simple roofline), not just how long it took.

use super::resource::ResourceDesc;
use crate::vk::image::{texel_size, ImageKind};

/// Work of one pass. Declared by the pass ([`super::PassBuilder::work`]) when it knows better;
/// otherwise derived by the graph as "every declared resource touched once".
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
pub struct Work {
    /// Bytes moved to or from memory (reads plus writes).
    pub bytes: u64,
    /// Filtered (sampled) texel fetches.
    pub texel_fetches: u64,
    /// 32-bit atomic operations.
    pub atomics: u64,
    /// Worst-case loop iterations of one SIMD row per dispatch, all of the shader's loops
    /// together (0: not declared). llvmpipe silently ends every loop of a row past
    /// [`LLVMPIPE_LOOP_LIMIT`]; the executor refuses such a pass there.
    #[serde(default)]
    pub loop_iterations: u64,
    /// Declared by the pass (true) or derived from its resources (false).
    pub declared: bool,
}

/// llvmpipe's loop limit per SIMD row and shader invocation (`LP_MAX_TGSI_LOOP_ITERATIONS`):
/// past it every loop of the row stops, and the image is silently wrong.
pub const LLVMPIPE_LOOP_LIMIT: u64 = 65_535;

impl Work {
    /// Declared work of `bytes` moved.
    pub fn bytes(bytes: u64) -> Self {
        Self { bytes, declared: true, ..Default::default() }
    }
}

/// Size in bytes of a resource (all mips; unknown formats count 4 bytes a texel).
pub fn resource_bytes(desc: &ResourceDesc) -> u64 {
    match desc {
        ResourceDesc::Buffer(b) => b.size,
        ResourceDesc::Image(i) => {
            let layers = match i.kind {
                ImageKind::D2Array(n) => u64::from(n),
                _ => 1,
            };
            let texel = texel_size(i.format).unwrap_or(4);
            let mut total = 0u64;
            let [mut w, mut h, mut d] = i.extent.map(u64::from);
            for _ in 0..i.mip_levels.max(1) {
                total += w * h * d;
                (w, h, d) = ((w / 2).max(1), (h / 2).max(1), (d / 2).max(1));
            }
            total * layers * texel
        }
    }
}
