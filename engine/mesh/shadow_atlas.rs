//! The shadow atlas: one depth image, a viewport per tile (sun cascades and spot lights), each
//! tile drawing only the triangles its culling pass kept.

use super::formats::DEPTH_FORMAT;
use super::geometry::{set_viewport, DepthPipelines, Geometry};
use crate::graph::{GraphBuilder, ImageDesc, ImageId, LoadOp};
use crate::Result;

/// Renders every tile of the atlas (`rects` in uv, `tile` texels square); returns the atlas.
pub(super) fn shadow_atlas<'a>(
    g: &mut GraphBuilder<'a>,
    geo: &Geometry<'a>,
    pipes: &'a DepthPipelines,
    atlas_size: [u32; 2],
    rects: &[[f32; 4]],
    tile: u32,
) -> Result<ImageId> {
    let atlas = g.create_image("shadow atlas", ImageDesc::d2(DEPTH_FORMAT, atlas_size[0], atlas_size[1]));
    let geo = geo.clone();
    let tile_px: Vec<[u32; 4]> = rects
        .iter()
        .map(|r| [(r[0] * atlas_size[0] as f32) as u32, (r[1] * atlas_size[1] as f32) as u32, tile, tile])
        .collect();
    let culled = (tile_px.iter().enumerate())
        .map(|(i, &t)| geo.cull_view(g, format!("shadow tile {i}"), 1 + i as u32, t))
        .collect::<Result<Vec<_>>>()?;
    let mut p = g.add_raster_pass("shadow maps");
    p.depth_attachment(atlas, LoadOp::Clear, 1.0, true)?;
    geo.declare_reads(&mut p)?;
    for c in culled.iter().flatten() {
        c.declare_reads(&mut p)?;
    }
    p.record(move |pc| {
        for (i, &t) in tile_px.iter().enumerate() {
            set_viewport(pc, t);
            geo.draw_depth(pc, pipes, 1 + i as u32, culled[i])?;
        }
        Ok(())
    });
    Ok(atlas)
}
