//! Pure-CPU tests of frame graph compilation: ordering, culling, barriers, state carry-over
//! and transient aliasing, plus property tests over random graphs.

use std::collections::HashSet;

use ash::vk;
use proptest::prelude::*;
use vkengine::graph::{
    place, Access, AliasRequest, BufferDesc, CompileOptions, CompiledGraph, GraphBuilder, GraphError, ImageBarrier,
    ImageDesc, ImageId, LoadOp, ResourceId, ResourceState, ShaderStage,
};

use vk::AccessFlags2 as A;
use vk::ImageLayout as L;
use vk::PipelineStageFlags2 as S;

fn img() -> ImageDesc {
    ImageDesc::d2(vk::Format::R8G8B8A8_UNORM, 64, 64)
}

fn names(g: &CompiledGraph<'_>) -> Vec<String> {
    g.passes().iter().map(|p| p.name.clone()).collect()
}

fn image_barrier(g: &CompiledGraph<'_>, pass: &str, image: ImageId) -> Option<ImageBarrier> {
    let p = g.passes().iter().find(|p| p.name == pass)?;
    p.barriers.images.iter().find(|b| b.image == image).copied()
}

#[test]
fn raw_war_waw_and_layout_barriers_have_exact_masks() -> Result<(), GraphError> {
    let mut gb = GraphBuilder::new();
    let a = gb.create_image("a", img());
    let out = gb.import_image("out", img(), ResourceState::UNDEFINED);
    gb.add_compute_pass("write_a").write_image(a, Access::StorageWrite(ShaderStage::Compute))?;
    gb.add_raster_pass("sample_a").read_image(a, Access::Sampled(ShaderStage::Fragment))?.color_attachment(
        out,
        LoadOp::Clear,
        [0.0; 4],
    )?;
    gb.add_compute_pass("overwrite_a").write_image(a, Access::StorageWrite(ShaderStage::Compute))?;
    gb.add_compute_pass("overwrite_a_again").write_image(a, Access::StorageWrite(ShaderStage::Compute))?;
    gb.add_raster_pass("blend").read_image(a, Access::Sampled(ShaderStage::Fragment))?.color_attachment(
        out,
        LoadOp::Load,
        [0.0; 4],
    )?;
    gb.export_image(out, Some(Access::Present))?;
    let g = gb.compile()?;
    assert_eq!(names(&g), ["write_a", "sample_a", "overwrite_a", "overwrite_a_again", "blend"]);

    // First use of a transient: discard from UNDEFINED with no source scope.
    assert_eq!(
        image_barrier(&g, "write_a", a),
        Some(ImageBarrier {
            image: a,
            src_stage: S::NONE,
            src_access: A::NONE,
            dst_stage: S::COMPUTE_SHADER,
            dst_access: A::SHADER_STORAGE_WRITE,
            old_layout: L::UNDEFINED,
            new_layout: L::GENERAL,
        })
    );
    // RAW + layout change.
    assert_eq!(
        image_barrier(&g, "sample_a", a),
        Some(ImageBarrier {
            image: a,
            src_stage: S::COMPUTE_SHADER,
            src_access: A::SHADER_STORAGE_WRITE,
            dst_stage: S::FRAGMENT_SHADER,
            dst_access: A::SHADER_SAMPLED_READ,
            old_layout: L::GENERAL,
            new_layout: L::SHADER_READ_ONLY_OPTIMAL,
        })
    );
    // WAR: execution dependency on the reader, no source access; layout change back.
    assert_eq!(
        image_barrier(&g, "overwrite_a", a),
        Some(ImageBarrier {
            image: a,
            src_stage: S::FRAGMENT_SHADER,
            src_access: A::NONE,
            dst_stage: S::COMPUTE_SHADER,
            dst_access: A::SHADER_STORAGE_WRITE,
            old_layout: L::SHADER_READ_ONLY_OPTIMAL,
            new_layout: L::GENERAL,
        })
    );
    // WAW, same layout.
    assert_eq!(
        image_barrier(&g, "overwrite_a_again", a),
        Some(ImageBarrier {
            image: a,
            src_stage: S::COMPUTE_SHADER,
            src_access: A::SHADER_STORAGE_WRITE,
            dst_stage: S::COMPUTE_SHADER,
            dst_access: A::SHADER_STORAGE_WRITE,
            old_layout: L::GENERAL,
            new_layout: L::GENERAL,
        })
    );
    // Color attachment: Load after Clear is a RAW+WAW on the attachment (same layout).
    assert_eq!(
        image_barrier(&g, "blend", out),
        Some(ImageBarrier {
            image: out,
            src_stage: S::COLOR_ATTACHMENT_OUTPUT | S::NONE,
            src_access: A::COLOR_ATTACHMENT_WRITE,
            dst_stage: S::COLOR_ATTACHMENT_OUTPUT,
            dst_access: A::COLOR_ATTACHMENT_READ | A::COLOR_ATTACHMENT_WRITE,
            old_layout: L::COLOR_ATTACHMENT_OPTIMAL,
            new_layout: L::COLOR_ATTACHMENT_OPTIMAL,
        })
    );
    // Export to present.
    assert_eq!(
        g.final_barriers().images,
        vec![ImageBarrier {
            image: out,
            src_stage: S::COLOR_ATTACHMENT_OUTPUT,
            src_access: A::COLOR_ATTACHMENT_WRITE,
            dst_stage: S::NONE,
            dst_access: A::NONE,
            old_layout: L::COLOR_ATTACHMENT_OPTIMAL,
            new_layout: L::PRESENT_SRC_KHR,
        }]
    );
    Ok(())
}

#[test]
fn read_after_read_same_layout_needs_no_barrier() -> Result<(), GraphError> {
    let mut gb = GraphBuilder::new();
    let a = gb.create_image("a", img());
    let b = gb.create_buffer("b", BufferDesc::new(256));
    let out = gb.create_buffer("out", BufferDesc::new(256));
    gb.add_compute_pass("w")
        .write_image(a, Access::StorageWrite(ShaderStage::Compute))?
        .write_buffer(b, Access::TransferDst)?;
    gb.add_compute_pass("r1")
        .read_image(a, Access::Sampled(ShaderStage::Compute))?
        .read_buffer(b, Access::StorageRead(ShaderStage::Compute))?
        .side_effect();
    gb.add_compute_pass("r2")
        .read_image(a, Access::Sampled(ShaderStage::Compute))?
        .read_buffer(b, Access::StorageRead(ShaderStage::Compute))?
        .write_buffer(out, Access::StorageWrite(ShaderStage::Compute))?;
    gb.export_buffer(out, None)?;
    let g = gb.compile()?;
    assert_eq!(names(&g), ["w", "r1", "r2"]);
    let r1 = &g.passes()[1].barriers;
    assert_eq!(r1.images.len(), 1);
    assert_eq!(r1.buffers.len(), 1);
    assert_eq!(r1.buffers[0].src_stage, S::TRANSFER);
    assert_eq!(r1.buffers[0].src_access, A::TRANSFER_WRITE);
    assert_eq!(r1.buffers[0].dst_access, A::SHADER_STORAGE_READ);
    // r2 reads the same things in the same stage/layout: already visible, no barrier; the
    // first write of `out` is a buffer with nothing to wait for.
    assert!(g.passes()[2].barriers.is_empty(), "{:?}", g.passes()[2].barriers);
    Ok(())
}

#[test]
fn read_in_new_stage_gets_its_own_barrier_and_merged_stages() -> Result<(), GraphError> {
    let mut gb = GraphBuilder::new();
    let a = gb.create_image("a", img());
    let out = gb.create_image("out", img());
    gb.add_compute_pass("w").write_image(a, Access::StorageWrite(ShaderStage::Compute))?;
    gb.add_raster_pass("draw")
        .read_image(a, Access::Sampled(ShaderStage::Vertex))?
        .read_image(a, Access::Sampled(ShaderStage::Fragment))?
        .color_attachment(out, LoadOp::DontCare, [0.0; 4])?;
    gb.add_compute_pass("post")
        .read_image(a, Access::Sampled(ShaderStage::Compute))?
        .read_image(out, Access::Sampled(ShaderStage::Compute))?
        .side_effect();
    let g = gb.compile()?;
    let draw = image_barrier(&g, "draw", a).expect("barrier before draw");
    assert_eq!(draw.dst_stage, S::VERTEX_SHADER | S::FRAGMENT_SHADER);
    assert_eq!(g.passes()[1].barriers.images.len(), 2);
    // Compute sampling after the transition: chained through the transition's stages.
    let post = image_barrier(&g, "post", a).expect("barrier before post");
    assert_eq!(post.src_stage, S::COMPUTE_SHADER | S::VERTEX_SHADER | S::FRAGMENT_SHADER);
    assert_eq!(post.src_access, A::SHADER_STORAGE_WRITE);
    assert_eq!(post.old_layout, post.new_layout);
    Ok(())
}

#[test]
fn culling_keeps_exactly_the_ancestors_of_exports() -> Result<(), GraphError> {
    let mut gb = GraphBuilder::new();
    let a = gb.create_image("a", img());
    let b = gb.create_image("b", img());
    let unused = gb.create_image("unused", img());
    let out = gb.import_image("out", img(), ResourceState::UNDEFINED);
    let dbg = gb.create_buffer("dbg", BufferDesc::new(64));
    let cs = Access::StorageWrite(ShaderStage::Compute);
    let rd = Access::Sampled(ShaderStage::Compute);
    gb.add_compute_pass("make_a").write_image(a, cs)?;
    gb.add_compute_pass("make_b").write_image(b, cs)?;
    gb.add_compute_pass("b_to_unused").read_image(b, rd)?.write_image(unused, cs)?;
    gb.add_compute_pass("a_to_out").read_image(a, rd)?.write_image(out, cs)?;
    gb.add_transfer_pass("debug_dump").write_buffer(dbg, Access::TransferDst)?.side_effect();
    gb.export_image(out, Some(Access::Sampled(ShaderStage::Fragment)))?;
    let g = gb.compile()?;
    assert_eq!(names(&g), ["make_a", "a_to_out", "debug_dump"]);
    let culled: Vec<&str> = g.culled_passes().iter().map(|p| p.name.as_str()).collect();
    assert_eq!(culled, ["make_b", "b_to_unused"]);
    let transients: Vec<&str> = g.transients().iter().map(|t| t.name.as_str()).collect();
    assert_eq!(transients, ["a", "dbg"], "culled-only transients are not allocated");
    assert_eq!(g.stats().passes_culled, 2);
    // Derived usage: storage write + sampled read.
    assert_eq!(g.transients()[0].image_usage, vk::ImageUsageFlags::STORAGE | vk::ImageUsageFlags::SAMPLED);
    Ok(())
}

#[test]
fn imported_state_carries_over_frames() -> Result<(), GraphError> {
    let mut state = ResourceState::UNDEFINED;
    let mut seen_old = Vec::new();
    for _frame in 0..2 {
        let mut gb = GraphBuilder::new();
        let hist = gb.import_image("history", img(), state);
        gb.add_compute_pass("accumulate").write_image(hist, Access::StorageReadWrite(ShaderStage::Compute))?;
        gb.export_image(hist, Some(Access::Sampled(ShaderStage::Fragment)))?;
        let g = gb.compile()?;
        seen_old.push(image_barrier(&g, "accumulate", hist).map(|b| (b.old_layout, b.src_stage)));
        state = g.final_state(ResourceId::Image(hist)).expect("imported resource has a final state");
    }
    assert_eq!(seen_old[0], Some((L::UNDEFINED, S::NONE)));
    assert_eq!(seen_old[1], Some((L::SHADER_READ_ONLY_OPTIMAL, S::FRAGMENT_SHADER)));
    assert_eq!(state.layout, L::SHADER_READ_ONLY_OPTIMAL);
    Ok(())
}

#[test]
fn misuse_is_reported() {
    let mut gb = GraphBuilder::new();
    let t = gb.create_image("t", img());
    let ro = gb.import_buffer_readonly("ro", BufferDesc::new(4), ResourceState::UNDEFINED);
    let mut other = GraphBuilder::new();
    let _ = other.create_buffer("x", BufferDesc::new(4));
    let foreign = other.create_image("y", img());
    let mut p = gb.add_compute_pass("p");
    assert!(matches!(p.read_image(t, Access::Sampled(ShaderStage::Compute)), Err(GraphError::ReadBeforeWrite { .. })));
    assert!(matches!(p.write_buffer(ro, Access::TransferDst), Err(GraphError::WriteToReadOnly { .. })));
    assert!(matches!(
        p.read_image(foreign, Access::Sampled(ShaderStage::Compute)),
        Err(GraphError::UnknownHandle { .. })
    ));
    assert!(matches!(
        p.read_image(t, Access::StorageWrite(ShaderStage::Compute)),
        Err(GraphError::AccessDirection { .. })
    ));
    assert!(matches!(p.color_attachment(t, LoadOp::Clear, [0.0; 4]), Err(GraphError::AttachmentOutsideRaster { .. })));
    assert!(p.write_image(t, Access::StorageWrite(ShaderStage::Compute)).is_ok());
    assert!(matches!(p.write_image(t, Access::TransferDst), Err(GraphError::LayoutConflict { .. })));
    assert!(matches!(gb.export_image(t, Some(Access::TransferDst)), Err(GraphError::InvalidExportAccess { .. })));
    let u = gb.create_image("u", img());
    assert!(matches!(gb.export_image(u, None), Err(GraphError::ExportUnwritten { .. })));
    // Pure-write attachments may target a transient nobody wrote.
    let mut r = gb.add_raster_pass("r");
    assert!(r.color_attachment(u, LoadOp::Clear, [0.0; 4]).is_ok());
}

/// Ping-pong chain: each pass reads the previous temp and writes a new one.
fn ping_pong(n: usize) -> Result<CompiledGraph<'static>, GraphError> {
    let mut gb = GraphBuilder::new();
    let mut prev = gb.create_image("t0", img());
    gb.add_compute_pass("p0").write_image(prev, Access::StorageWrite(ShaderStage::Compute))?;
    for i in 1..n {
        let next = gb.create_image(format!("t{i}"), img());
        gb.add_compute_pass(format!("p{i}"))
            .read_image(prev, Access::Sampled(ShaderStage::Compute))?
            .write_image(next, Access::StorageWrite(ShaderStage::Compute))?;
        prev = next;
    }
    gb.export_image(prev, None)?;
    gb.compile()
}

#[test]
fn aliasing_saves_memory_and_adds_barriers() -> Result<(), GraphError> {
    let mut g = ping_pong(8)?;
    let reqs = g.alias_requests(|_| (1 << 20, 4096));
    let plan = place(&reqs, 1024);
    assert_eq!(plan.unaliased_size, 8 << 20);
    assert!(plan.heap_size <= 2 << 20, "heap {}", plan.heap_size);
    assert_overlap_free(&reqs, &plan.offsets);
    g.apply_aliasing(&reqs, &plan)?;
    // t2 reuses t0's memory: its first use waits for t0's last reader (sampled in compute).
    let t2 = g.transients()[2].id;
    let ResourceId::Image(t2) = t2 else { panic!("t2 is an image") };
    let b = image_barrier(&g, "p2", t2).expect("first-use barrier");
    assert!(b.src_stage.contains(S::COMPUTE_SHADER), "{b:?}");
    assert_eq!(b.old_layout, L::UNDEFINED);
    assert_eq!(g.apply_aliasing(&reqs, &plan), Err(GraphError::AlreadyAliased));
    Ok(())
}

fn assert_overlap_free(reqs: &[AliasRequest], offsets: &[u64]) {
    for i in 0..reqs.len() {
        for j in i + 1..reqs.len() {
            let (a, b) = (&reqs[i], &reqs[j]);
            let live = a.first <= b.last && b.first <= a.last;
            let mem = offsets[i] < offsets[j] + b.size && offsets[j] < offsets[i] + a.size;
            assert!(!(live && mem), "{i} and {j} overlap: {a:?}@{} {b:?}@{}", offsets[i], offsets[j]);
        }
    }
}

// ---------------------------------------------------------------- property tests

#[derive(Clone, Debug)]
struct UseSpec {
    res: usize,
    access: usize,
}

#[derive(Clone, Debug)]
struct PassSpec {
    uses: Vec<UseSpec>,
    side_effect: bool,
}

#[derive(Clone, Debug)]
struct GraphSpec {
    imported: Vec<bool>,
    exported: Vec<bool>,
    passes: Vec<PassSpec>,
    reorder: bool,
}

const ACCESSES: [Access; 6] = [
    Access::Sampled(ShaderStage::Fragment),
    Access::StorageRead(ShaderStage::Compute),
    Access::StorageWrite(ShaderStage::Compute),
    Access::StorageReadWrite(ShaderStage::Vertex),
    Access::TransferSrc,
    Access::TransferDst,
];

fn graph_spec() -> impl Strategy<Value = GraphSpec> {
    (2usize..7).prop_flat_map(|n| {
        let pass = (prop::collection::vec((0..n, 0..ACCESSES.len()), 1..4), prop::bool::weighted(0.1)).prop_map(
            |(uses, side_effect)| PassSpec {
                uses: uses.into_iter().map(|(res, access)| UseSpec { res, access }).collect(),
                side_effect,
            },
        );
        (
            prop::collection::vec(any::<bool>(), n),
            prop::collection::vec(prop::bool::weighted(0.3), n),
            prop::collection::vec(pass, 1..14),
            any::<bool>(),
        )
            .prop_map(|(imported, exported, passes, reorder)| GraphSpec {
                imported,
                exported,
                passes,
                reorder,
            })
    })
}

/// One accepted (pass, resource) use, merged like the graph merges them.
#[derive(Clone, Copy, Debug)]
struct RefUse {
    res: usize,
    stage: vk::PipelineStageFlags2,
    reads: bool,
    writes: bool,
}

struct Built {
    graph: CompiledGraph<'static>,
    uses: Vec<Vec<RefUse>>,
    exported: Vec<usize>,
    side_effect: Vec<bool>,
}

fn build(spec: &GraphSpec) -> Built {
    let mut gb = GraphBuilder::new();
    let ids: Vec<ImageId> = spec
        .imported
        .iter()
        .enumerate()
        .map(|(i, &imp)| {
            if imp {
                gb.import_image(format!("r{i}"), img(), ResourceState::UNDEFINED)
            } else {
                gb.create_image(format!("r{i}"), img())
            }
        })
        .collect();
    let mut uses = Vec::new();
    let mut side_effect = Vec::new();
    for (pi, ps) in spec.passes.iter().enumerate() {
        let mut p = gb.add_compute_pass(format!("p{pi}"));
        let mut accepted: Vec<RefUse> = Vec::new();
        for u in &ps.uses {
            let a = ACCESSES[u.access];
            let r = if a.is_write() {
                p.write_image(ids[u.res], a).map(|_| ())
            } else {
                p.read_image(ids[u.res], a).map(|_| ())
            };
            if r.is_ok() {
                match accepted.iter_mut().find(|x| x.res == u.res) {
                    Some(x) => {
                        x.stage |= a.stage();
                        x.reads |= a.is_read();
                        x.writes |= a.is_write();
                    }
                    None => {
                        accepted.push(RefUse { res: u.res, stage: a.stage(), reads: a.is_read(), writes: a.is_write() })
                    }
                }
            }
        }
        if ps.side_effect {
            p.side_effect();
        }
        side_effect.push(ps.side_effect);
        uses.push(accepted);
    }
    let mut exported = Vec::new();
    for (i, &e) in spec.exported.iter().enumerate() {
        if e && gb.export_image(ids[i], None).is_ok() {
            exported.push(i);
        }
    }
    let graph = gb.compile_with(CompileOptions { reorder: spec.reorder }).expect("declarations were validated");
    Built { graph, uses, exported, side_effect }
}

/// Reference hazard/data relations computed directly from the accepted uses.
fn reference(b: &Built, n_res: usize) -> (Vec<HashSet<usize>>, HashSet<usize>) {
    let n = b.uses.len();
    let mut hazard = vec![HashSet::new(); n];
    let mut data = vec![HashSet::new(); n];
    let mut last_writer = vec![None; n_res];
    for q in 0..n {
        for u in &b.uses[q] {
            for p in 0..q {
                for pu in b.uses[p].iter().filter(|pu| pu.res == u.res) {
                    if pu.writes || u.writes {
                        hazard[q].insert(p);
                    }
                }
            }
            if let Some(w) = last_writer[u.res] {
                // Every access in the mix is storage/transfer: writes are never discarding.
                if u.reads || u.writes {
                    data[q].insert(w);
                }
            }
        }
        for u in b.uses[q].iter().filter(|u| u.writes) {
            last_writer[u.res] = Some(q);
        }
    }
    let mut kept = HashSet::new();
    let mut stack: Vec<usize> =
        b.exported.iter().filter_map(|&r| last_writer[r]).chain((0..n).filter(|&p| b.side_effect[p])).collect();
    while let Some(p) = stack.pop() {
        if kept.insert(p) {
            stack.extend(data[p].iter().copied());
        }
    }
    (hazard, kept)
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(300))]

    #[test]
    fn compiled_graphs_respect_dependencies(spec in graph_spec()) {
        let b = build(&spec);
        let g = &b.graph;
        let (hazard, kept_ref) = reference(&b, spec.imported.len());
        let order: Vec<usize> = g.passes().iter().map(|p| p.declared_index).collect();
        let kept: HashSet<usize> = order.iter().copied().collect();
        prop_assert_eq!(&kept, &kept_ref);
        prop_assert_eq!(kept.len(), order.len());
        let mut pos = vec![usize::MAX; b.uses.len()];
        for (i, &p) in order.iter().enumerate() {
            pos[p] = i;
        }
        // Valid topological order of the hazard relation restricted to kept passes.
        for &q in &order {
            for &p in &hazard[q] {
                if kept.contains(&p) {
                    prop_assert!(pos[p] < pos[q], "p{} must precede p{}", p, q);
                }
            }
        }
        // Every conflicting pair is separated by a barrier on that resource whose source
        // scope covers the earlier pass's stages.
        for &q in &order {
            for &p in &hazard[q] {
                if !kept.contains(&p) {
                    continue;
                }
                for qu in &b.uses[q] {
                    for pu in b.uses[p].iter().filter(|pu| pu.res == qu.res) {
                        if !(pu.writes || qu.writes) {
                            continue;
                        }
                        let covered = g.passes()[pos[p] + 1..=pos[q]].iter().any(|cp| {
                            cp.barriers.images.iter().any(|ib| {
                                ib.image.index() as usize == qu.res
                                    && ib.src_stage.contains(pu.stage)
                            })
                        });
                        prop_assert!(covered, "no barrier for r{} between p{} and p{}", qu.res, p, q);
                    }
                }
            }
        }
    }

    #[test]
    fn alias_plans_never_overlap_live_ranges(
        items in prop::collection::vec((1u64..5000, 0u32..8, 0usize..20, 0usize..6), 0..40),
        granularity in prop::sample::select(vec![1u64, 64, 1024]),
    ) {
        let reqs: Vec<AliasRequest> = items
            .iter()
            .map(|&(size, align_pow, first, len)| AliasRequest {
                size,
                align: 1 << align_pow,
                first,
                last: first + len,
            })
            .collect();
        let plan = place(&reqs, granularity);
        prop_assert_eq!(plan.offsets.len(), reqs.len());
        for (r, &off) in reqs.iter().zip(&plan.offsets) {
            prop_assert_eq!(off % r.align.max(granularity), 0);
            prop_assert!(off + r.size <= plan.heap_size);
        }
        for i in 0..reqs.len() {
            for j in i + 1..reqs.len() {
                let (a, c) = (&reqs[i], &reqs[j]);
                let live = a.first <= c.last && c.first <= a.last;
                let mem = plan.offsets[i] < plan.offsets[j] + c.size
                    && plan.offsets[j] < plan.offsets[i] + a.size;
                prop_assert!(!(live && mem), "items {} and {} overlap", i, j);
            }
        }
        prop_assert!(plan.heap_size <= plan.unaliased_size);
    }
}

#[test]
fn dot_and_trace_reports_describe_the_graph() -> Result<(), GraphError> {
    let mut gb = GraphBuilder::new();
    let a = gb.create_image("a", img());
    let dead = gb.create_image("dead", img());
    let out = gb.import_image("swapchain", img(), ResourceState::UNDEFINED);
    gb.add_compute_pass("make").write_image(a, Access::StorageWrite(ShaderStage::Compute))?;
    gb.add_compute_pass("unused").write_image(dead, Access::StorageWrite(ShaderStage::Compute))?;
    gb.add_raster_pass("draw").read_image(a, Access::Sampled(ShaderStage::Fragment))?.color_attachment(
        out,
        LoadOp::Clear,
        [0.0; 4],
    )?;
    gb.export_image(out, Some(Access::Present))?;
    let g = gb.compile()?;
    let dot = vkengine::graph::dot::to_dot(&g);
    assert!(dot.starts_with("digraph"));
    assert!(dot.contains("unused (culled)"));
    assert!(dot.contains("GENERAL → SHADER_READ_ONLY_OPTIMAL"), "{dot}");
    assert!(dot.contains("(imported)"));

    use vkengine::graph::trace::{chrome_trace, format_table, PassTiming};
    let frame = vec![
        PassTiming {
            name: "make".into(),
            gpu_begin_ns: 1_000,
            gpu_end_ns: 3_000,
            cpu_ns: 500,
            work: Default::default(),
            commands: Default::default(),
        },
        PassTiming {
            name: "draw".into(),
            gpu_begin_ns: 3_000,
            gpu_end_ns: 7_000,
            cpu_ns: 250,
            work: Default::default(),
            commands: Default::default(),
        },
    ];
    let trace = chrome_trace(std::slice::from_ref(&frame));
    let events = trace["traceEvents"].as_array().expect("traceEvents array");
    let complete: Vec<_> = events.iter().filter(|e| e["ph"] == "X").collect();
    assert_eq!(complete.len(), 4);
    assert_eq!(complete[2]["ts"], 2.0);
    assert_eq!(complete[2]["dur"], 4.0);
    let table = format_table(&frame);
    assert!(table.contains("draw") && table.contains("0.004"), "{table}");
    Ok(())
}
