//! The reflective shadow map: the scene seen from its light (position, normal, flux), into
//! persistent targets that a later frame with the same light, view and geometry reads as they
//! are.

use super::formats::DEPTH_FORMAT;
use super::frame::{FrameData, VIEW_RSM};
use super::geometry::Geometry;
use super::gpu_scene::GpuScene;
use super::settings::MeshSettings;
use super::shadow::ShadowView;
use super::targets::{MeshTargets, RsmKey};
use crate::graph::execute::Imports;
use crate::graph::{GraphBuilder, ImageDesc, ImageId, LoadOp};
use crate::vk::Pipeline;
use crate::Result;

/// What the RSM shows this frame: the scene seen from its light (None without an RSM view).
pub(super) fn rsm_key(
    scene: &GpuScene,
    rsm_view: Option<ShadowView>,
    frame: &FrameData,
    s: &MeshSettings,
) -> Option<RsmKey> {
    rsm_view.map(|v| RsmKey {
        scene: scene.id,
        view_proj: v.view_proj,
        rsm_light: frame.rsm_light,
        sun: scene.sun,
        spot: scene.sun.is_none().then(|| scene.spots.first().copied()).flatten(),
        cull: s.cull,
    })
}

/// Imports the RSM targets and renders them unless they already hold `key`'s answer
/// (`lpv_reuse=false` renders every frame, as a moving light would); None without an RSM.
#[allow(clippy::too_many_arguments)]
pub(super) fn rsm<'a>(
    g: &mut GraphBuilder<'a>,
    imports: &mut Imports,
    geo: &Geometry<'a>,
    pipe: &'a Pipeline,
    targets: &mut MeshTargets,
    view: Option<ShadowView>,
    key: Option<RsmKey>,
    reuse: bool,
) -> Result<Option<[ImageId; 3]>> {
    let (Some(r), Some(v)) = (targets.rsm.as_mut(), view) else { return Ok(None) };
    let n = r.flux.info.extent[0];
    let ids = [
        r.position.import(g, imports, "rsm position"),
        r.normal.import(g, imports, "rsm normal"),
        r.flux.import(g, imports, "rsm flux"),
    ];
    if !reuse || r.key.is_none() || r.key != key {
        let rsm_depth = g.create_image("rsm depth", ImageDesc::d2(DEPTH_FORMAT, n, n));
        let geo = geo.clone();
        let culled = geo.cull_view(g, "rsm".into(), VIEW_RSM, [0, 0, n, n])?;
        let mut p = g.add_raster_pass("rsm");
        for id in ids {
            p.color_attachment(id, LoadOp::Clear, [0.0; 4])?;
        }
        p.depth_attachment(rsm_depth, LoadOp::Clear, 1.0, true)?;
        geo.declare_reads_culled(&mut p, culled)?;
        p.record(move |pc| geo.draw_all(pc, pipe, VIEW_RSM, culled));
        r.key = key;
    }
    r.view = Some(v);
    Ok(Some(ids))
}
