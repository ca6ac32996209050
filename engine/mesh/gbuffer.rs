//! The G-buffer: albedo, world normal, specular and depth from the camera.

use super::formats::{ALBEDO_FORMAT, DEPTH_FORMAT, NORMAL_FORMAT, SPECULAR_FORMAT};
use super::frame::VIEW_CAMERA;
use super::geometry::{GbufferPipelines, Geometry};
use crate::graph::{GraphBuilder, ImageDesc, ImageId, LoadOp};
use crate::Result;

/// The G-buffer's images.
#[derive(Clone, Copy)]
pub(super) struct Gbuffer {
    pub albedo: ImageId,
    pub normal: ImageId,
    pub specular: ImageId,
    pub depth: ImageId,
}

/// Draws the scene's G-buffer at `w` × `h`.
pub(super) fn gbuffer<'a>(
    g: &mut GraphBuilder<'a>,
    geo: &Geometry<'a>,
    pipes: &'a GbufferPipelines,
    [w, h]: [u32; 2],
) -> Result<Gbuffer> {
    let desc = |f| ImageDesc::d2(f, w, h);
    let albedo = g.create_image("gbuffer albedo", desc(ALBEDO_FORMAT));
    let normal = g.create_image("gbuffer normal", desc(NORMAL_FORMAT));
    let specular = g.create_image("gbuffer specular", desc(SPECULAR_FORMAT));
    let depth = g.create_image("depth", desc(DEPTH_FORMAT));
    let geo = geo.clone();
    let culled = geo.cull_view(g, "gbuffer".into(), VIEW_CAMERA, [0, 0, w, h])?;
    let mut p = g.add_raster_pass("gbuffer");
    for id in [albedo, normal, specular] {
        p.color_attachment(id, LoadOp::Clear, [0.0; 4])?;
    }
    p.depth_attachment(depth, LoadOp::Clear, 1.0, true)?;
    geo.declare_reads_culled(&mut p, culled)?;
    p.record(move |pc| geo.draw_gbuffer(pc, pipes, VIEW_CAMERA, culled));
    Ok(Gbuffer { albedo, normal, specular, depth })
}
