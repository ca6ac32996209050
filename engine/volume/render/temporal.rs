//! Temporal reuse while the camera moves (`post/reproject.comp`): on a new view, the previous
//! views' integrated image is reprojected through this view's feature depth, rejected where the
//! features of the two views disagree (disocclusion, thin structures), clamped to the
//! neighbourhood of this view's first samples, and kept with its age as the view's prior. The
//! prior feeds only the denoised image (`super::denoise`), never the unbiased mean, and its
//! weight there falls as the view's own samples accumulate.

use crate::graph::{BufferId, GraphBuilder, ImageId};
use crate::shaders;
use crate::Result;
use glam::Mat4;

/// Push constants of `post/reproject.comp`: the previous view's inverse view-projection and the
/// test switches (`DenoiseSettings::debug_flags`).
#[derive(Clone, Copy, bytemuck::Pod, bytemuck::Zeroable)]
#[repr(C)]
struct ReprojectPush {
    inv_view_proj_prev: [f32; 16],
    flags: u32,
}

/// The reprojection pass: `integrated` (the last frame's) into `prior`, from the view whose
/// inverse view-projection is `prev` into the one of `params` (the volume's uniform block).
#[allow(clippy::too_many_arguments)] // each is a separate input of the pass
pub(super) fn add_reproject_pass(
    g: &mut GraphBuilder<'_>,
    params: BufferId,
    mean: ImageId,
    [feats, feats_prev]: [ImageId; 2],
    integrated: ImageId,
    prior: ImageId,
    prev: Mat4,
    flags: u32,
    groups: [u32; 3],
) -> Result<()> {
    let push = ReprojectPush { inv_view_proj_prev: prev.to_cols_array(), flags };
    g.compute("reproject", &shaders::POST_REPROJECT_COMP)
        .uniform(params)
        .read(mean)
        .read(feats)
        .read(feats_prev)
        .read(integrated)
        .write(prior)
        .constants(&push)
        .loop_bound(10)
        .dispatch(groups)?;
    Ok(())
}
