//! Compilation: dependency DAG, culling, ordering, barrier simulation and transient lifetimes.

use ash::vk;

use super::barriers::{BufferBarrier, Dep, ImageBarrier, PassBarriers, Track};
use super::builder::{GraphBuilder, Origin, PassDecl, ResourceDecl, Use};
use super::compiled::{CompiledGraph, CompiledPass, CulledPass, GraphStats, ResourceInfo, ResourceUse, Transient};
use super::error::GraphError;
use super::resource::{BufferId, ImageId, ResourceDesc, ResourceId, ResourceState};
use super::work;

/// Knobs of `GraphBuilder::compile_with`.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct CompileOptions {
    /// Reorder passes to put distance between dependent passes (fewer back-to-back stalls);
    /// otherwise kept passes run in declaration order, which is always valid.
    pub reorder: bool,
}

/// Dependencies between declared passes; edges always point to an earlier-declared pass.
pub(crate) struct Dag {
    /// RAW, WAR and WAW: everything the order must respect.
    pub(crate) hazard_preds: Vec<Vec<usize>>,
    /// RAW and non-discarding WAW: the producers whose results a pass consumes, for culling.
    pub(crate) data_preds: Vec<Vec<usize>>,
    /// Last declared writer of each resource.
    pub(crate) last_writer: Vec<Option<usize>>,
}

fn push_unique(v: &mut Vec<usize>, x: usize) {
    if !v.contains(&x) {
        v.push(x);
    }
}

pub(crate) fn build_dag(resources: &[ResourceDecl], passes: &[PassDecl<'_>]) -> Dag {
    let mut hazard_preds = vec![Vec::new(); passes.len()];
    let mut data_preds = vec![Vec::new(); passes.len()];
    let mut last_writer: Vec<Option<usize>> = vec![None; resources.len()];
    let mut readers: Vec<Vec<usize>> = vec![Vec::new(); resources.len()];
    for (p, pass) in passes.iter().enumerate() {
        for u in &pass.uses {
            let w = last_writer[u.res];
            if u.reads_prev {
                if let Some(w) = w {
                    push_unique(&mut hazard_preds[p], w);
                    push_unique(&mut data_preds[p], w);
                }
            }
            if u.writes {
                if let Some(w) = w {
                    push_unique(&mut hazard_preds[p], w);
                    // A non-discarding write may be partial, so it keeps the old contents alive.
                    if !u.discards {
                        push_unique(&mut data_preds[p], w);
                    }
                }
                for &r in &readers[u.res] {
                    push_unique(&mut hazard_preds[p], r);
                }
                readers[u.res].clear();
                last_writer[u.res] = Some(p);
            } else {
                readers[u.res].push(p);
            }
        }
    }
    Dag { hazard_preds, data_preds, last_writer }
}

fn cull(resources: &[ResourceDecl], passes: &[PassDecl<'_>], dag: &Dag) -> Vec<bool> {
    let mut kept = vec![false; passes.len()];
    let mut stack: Vec<usize> = resources
        .iter()
        .enumerate()
        .filter(|(_, r)| r.export.is_some())
        .filter_map(|(i, _)| dag.last_writer[i])
        .chain(passes.iter().enumerate().filter(|(_, p)| p.side_effect).map(|(i, _)| i))
        .collect();
    while let Some(p) = stack.pop() {
        if !std::mem::replace(&mut kept[p], true) {
            stack.extend(dag.data_preds[p].iter().copied().filter(|&q| !kept[q]));
        }
    }
    kept
}

/// List scheduling that prefers the ready pass whose nearest producer ran longest ago.
fn spread_order(dag: &Dag, kept: &[bool]) -> Vec<usize> {
    let n = kept.len();
    let preds: Vec<Vec<usize>> =
        (0..n).map(|p| dag.hazard_preds[p].iter().copied().filter(|&q| kept[q]).collect()).collect();
    let mut succs = vec![Vec::new(); n];
    let mut missing = vec![0usize; n];
    for p in (0..n).filter(|&p| kept[p]) {
        missing[p] = preds[p].len();
        for &q in &preds[p] {
            succs[q].push(p);
        }
    }
    let mut ready: Vec<usize> = (0..n).filter(|&p| kept[p] && missing[p] == 0).collect();
    let mut pos = vec![usize::MAX; n];
    let mut order = Vec::with_capacity(ready.len());
    while !ready.is_empty() {
        let step = order.len();
        let distance = |p: usize| preds[p].iter().map(|&q| step - pos[q]).min().unwrap_or(usize::MAX);
        // Ties go to the earliest declared pass, keeping the order close to the author's.
        let (slot, _) = ready
            .iter()
            .enumerate()
            .max_by_key(|&(_, &p)| (distance(p), std::cmp::Reverse(p)))
            .expect("ready is non-empty inside the loop");
        let p = ready.swap_remove(slot);
        pos[p] = step;
        order.push(p);
        for &s in &succs[p] {
            missing[s] -= 1;
            if missing[s] == 0 {
                ready.push(s);
            }
        }
    }
    order
}

fn resource_id(resources: &[ResourceDecl], res: usize) -> ResourceId {
    match resources[res].desc {
        ResourceDesc::Image(_) => ResourceId::Image(ImageId(res as u32)),
        ResourceDesc::Buffer(_) => ResourceId::Buffer(BufferId(res as u32)),
    }
}

fn public_use(resources: &[ResourceDecl], u: &Use) -> ResourceUse {
    ResourceUse {
        resource: resource_id(resources, u.res),
        stage: u.stage,
        access: u.access,
        layout: u.layout,
        reads: u.reads_prev,
        writes: u.writes,
    }
}

fn push_dep(batch: &mut PassBarriers, id: ResourceId, d: Dep) {
    match id {
        ResourceId::Image(image) => batch.images.push(ImageBarrier {
            image,
            src_stage: d.src_stage,
            src_access: d.src_access,
            dst_stage: d.dst_stage,
            dst_access: d.dst_access,
            old_layout: d.old_layout,
            new_layout: d.new_layout,
        }),
        ResourceId::Buffer(buffer) => batch.buffers.push(BufferBarrier {
            buffer,
            src_stage: d.src_stage,
            src_access: d.src_access,
            dst_stage: d.dst_stage,
            dst_access: d.dst_access,
        }),
    }
}

/// Lifetime and usage accumulated for one transient while walking the order.
struct Life {
    first: usize,
    last: usize,
    image_usage: vk::ImageUsageFlags,
    buffer_usage: vk::BufferUsageFlags,
    first_use: ResourceUse,
}

impl<'a> GraphBuilder<'a> {
    /// Compiles with default options.
    pub fn compile(self) -> Result<CompiledGraph<'a>, GraphError> {
        self.compile_with(CompileOptions::default())
    }

    /// Culls, orders and synchronizes the declared graph; needs no device.
    pub fn compile_with(self, options: CompileOptions) -> Result<CompiledGraph<'a>, GraphError> {
        let GraphBuilder { resources, passes } = self;
        let dag = build_dag(&resources, &passes);
        let kept = cull(&resources, &passes, &dag);
        let order: Vec<usize> =
            if options.reorder { spread_order(&dag, &kept) } else { (0..passes.len()).filter(|&p| kept[p]).collect() };

        let mut tracks: Vec<Track> = resources
            .iter()
            .map(|r| match r.origin {
                Origin::Transient => Track::new(ResourceState::UNDEFINED),
                Origin::Imported { state, .. } => Track::new(state),
            })
            .collect();
        let mut lives: Vec<Option<Life>> = resources.iter().map(|_| None).collect();
        let mut batches = Vec::with_capacity(order.len());
        let mut stats = GraphStats {
            passes_declared: passes.len(),
            passes_kept: order.len(),
            passes_culled: passes.len() - order.len(),
            ..GraphStats::default()
        };
        for (pos, &p) in order.iter().enumerate() {
            let mut batch = PassBarriers::default();
            for u in &passes[p].uses {
                let id = resource_id(&resources, u.res);
                if let Some(d) = tracks[u.res].apply(u) {
                    push_dep(&mut batch, id, d);
                }
                let life = lives[u.res].get_or_insert_with(|| Life {
                    first: pos,
                    last: pos,
                    image_usage: vk::ImageUsageFlags::empty(),
                    buffer_usage: vk::BufferUsageFlags::empty(),
                    first_use: public_use(&resources, u),
                });
                life.last = pos;
                life.image_usage |= u.image_usage;
                life.buffer_usage |= u.buffer_usage;
            }
            batches.push(batch);
        }

        let mut final_barriers = PassBarriers::default();
        for (res, decl) in resources.iter().enumerate() {
            let Some(Some(access)) = decl.export else {
                continue;
            };
            let is_image = matches!(decl.desc, ResourceDesc::Image(_));
            let u = Use {
                res,
                stage: access.stage(),
                access: access.access(),
                layout: is_image.then(|| access.image_layout()),
                reads_prev: true,
                writes: false,
                discards: false,
                image_usage: access.image_usage(),
                buffer_usage: access.buffer_usage(),
            };
            if let Some(d) = tracks[res].apply(&u) {
                push_dep(&mut final_barriers, resource_id(&resources, res), d);
            }
            if let Some(life) = lives[res].as_mut() {
                life.image_usage |= u.image_usage;
                life.buffer_usage |= u.buffer_usage;
            }
        }

        let final_states = resources
            .iter()
            .enumerate()
            .filter(|(_, r)| matches!(r.origin, Origin::Imported { .. }))
            .map(|(res, r)| {
                // After an export transition the resource is exactly in that access's state;
                // otherwise report what is still pending so next frame waits for it.
                let state = match r.export {
                    Some(Some(a)) => {
                        ResourceState { layout: tracks[res].pending().layout, stage: a.stage(), access: a.access() }
                    }
                    _ => tracks[res].pending(),
                };
                (resource_id(&resources, res), state)
            })
            .collect();

        let end = order.len().saturating_sub(1);
        let transients: Vec<Transient> = resources
            .iter()
            .enumerate()
            .filter(|(_, r)| r.origin == Origin::Transient)
            .filter_map(|(res, r)| {
                let life = lives[res].take()?;
                let (image_usage, buffer_usage) = match r.desc {
                    ResourceDesc::Image(d) => (life.image_usage | d.extra_usage, vk::BufferUsageFlags::empty()),
                    ResourceDesc::Buffer(d) => (vk::ImageUsageFlags::empty(), life.buffer_usage | d.extra_usage),
                };
                Some(Transient {
                    id: resource_id(&resources, res),
                    name: r.name.clone(),
                    desc: r.desc,
                    image_usage,
                    buffer_usage,
                    first: life.first,
                    // Exported memory must outlive the graph, so nothing may alias it later.
                    last: if r.export.is_some() { end } else { life.last },
                    end_state: tracks[res].pending(),
                    first_use: life.first_use,
                })
            })
            .collect();

        for b in batches.iter().chain(std::iter::once(&final_barriers)) {
            stats.barriers += b.len();
            stats.layout_transitions += b.images.iter().filter(|i| i.old_layout != i.new_layout).count();
        }
        stats.transients = transients.len();

        let resource_infos = resources
            .iter()
            .enumerate()
            .map(|(res, r)| ResourceInfo {
                id: resource_id(&resources, res),
                name: r.name.clone(),
                desc: r.desc,
                imported: r.origin != Origin::Transient,
                read_only: matches!(r.origin, Origin::Imported { read_only: true, .. }),
                export: r.export,
            })
            .collect();

        let mut slots: Vec<Option<PassDecl<'a>>> = passes.into_iter().map(Some).collect();
        let compiled_passes = order
            .iter()
            .zip(batches)
            .filter_map(|(&p, barriers)| {
                let decl = slots[p].take()?;
                let uses: Vec<ResourceUse> = decl.uses.iter().map(|u| public_use(&resources, u)).collect();
                let work = decl.work.unwrap_or_else(|| derived_work(&uses, |u| resources[u.resource.index()].desc));
                let work = work::Work { loop_iterations: work.loop_iterations.max(decl.loop_iterations), ..work };
                Some(CompiledPass {
                    uses,
                    work,
                    name: decl.name,
                    kind: decl.kind,
                    declared_index: p,
                    barriers,
                    color_attachments: decl.colors,
                    depth_attachment: decl.depth,
                    record: decl.record,
                })
            })
            .collect();
        let culled = slots
            .into_iter()
            .flatten()
            .map(|decl| CulledPass {
                uses: decl.uses.iter().map(|u| public_use(&resources, u)).collect(),
                name: decl.name,
                kind: decl.kind,
            })
            .collect();

        Ok(CompiledGraph {
            passes: compiled_passes,
            culled,
            resources: resource_infos,
            transients,
            final_barriers,
            final_states,
            stats,
            aliased: false,
        })
    }
}

/// The graph's estimate when a pass declares nothing: each resource it reads is read once and
/// each one it writes is written once.
fn derived_work(uses: &[ResourceUse], desc: impl Fn(&ResourceUse) -> ResourceDesc) -> work::Work {
    let bytes = uses.iter().map(|u| work::resource_bytes(&desc(u)) * (u64::from(u.reads) + u64::from(u.writes))).sum();
    work::Work { bytes, declared: false, ..Default::default() }
}
