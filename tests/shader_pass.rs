//! Shader passes (CPU only): the declared binding sequence is checked against the bindings
//! `build.rs` reflected from the shader's SPIR-V, and the `#[repr(C)]` uniform/push structs
//! against the reflected block layouts. The reflection itself is checked against hand-written
//! SPIR-V facts (binding kinds and std140 offsets read off the GLSL), not against itself.

use std::mem::{offset_of, size_of};
use vkengine::graph::{BufferDesc, GraphBuilder, GraphError, ImageDesc};
use vkengine::shaders::{self, DescriptorKind, Shader};
use vkengine::vk::{vk, Sampling};

fn grid() -> ImageDesc {
    ImageDesc::d2(vk::Format::R32G32B32A32_SFLOAT, 8, 8)
}

/// A uniform buffer some earlier pass filled (so reading it is legal).
fn filled_ubo(g: &mut GraphBuilder<'_>) -> Result<vkengine::graph::BufferId, GraphError> {
    let ubo = g.create_buffer("params", BufferDesc::new(288));
    g.add_transfer_pass("fill").write_buffer(ubo, vkengine::graph::Access::TransferDst)?.record(|_| Ok(()));
    Ok(ubo)
}

/// The error message of a pass declared with `f`, which must fail.
fn declaration_error(f: impl FnOnce(&mut GraphBuilder<'_>) -> Result<(), GraphError>) -> String {
    let mut g = GraphBuilder::new();
    match f(&mut g) {
        Ok(()) => panic!("the declaration should have failed"),
        Err(e) => e.to_string(),
    }
}

#[test]
fn matching_declaration_is_accepted() -> Result<(), GraphError> {
    let mut g = GraphBuilder::new();
    let ubo = filled_ubo(&mut g)?;
    let (src, dst) = (g.create_image("src", grid()), g.create_image("dst", grid()));
    g.add_transfer_pass("seed").write_image(src, vkengine::graph::Access::TransferDst)?.record(|_| Ok(()));
    g.compute("dilate", &shaders::LPV_DILATE_COMP).uniform(ubo).read(src).write(dst).dispatch([1, 1, 1])?;
    g.export_image(dst, None)?;
    let compiled = g.compile()?;
    assert_eq!(compiled.passes().len(), 3);
    Ok(())
}

#[test]
fn wrong_kind_names_pass_binding_shader_and_both_kinds() {
    let msg = declaration_error(|g| {
        let ubo = filled_ubo(g)?;
        let (src, dst) = (g.create_image("src", grid()), g.create_image("dst", grid()));
        g.add_transfer_pass("seed").write_image(src, vkengine::graph::Access::TransferDst)?.record(|_| Ok(()));
        // dilate.comp's binding 1 is `readonly image3D src`, not a sampler.
        g.compute("lpv dilate 3", &shaders::LPV_DILATE_COMP)
            .uniform(ubo)
            .sampled(src, Sampling::Nearest)
            .write(dst)
            .dispatch([1, 1, 1])
    });
    for needle in ["lpv dilate 3", "binding 1", "lpv/dilate.comp", "storage image `src`", "sampled image"] {
        assert!(msg.contains(needle), "`{needle}` missing from: {msg}");
    }
}

#[test]
fn missing_and_extra_bindings_are_errors() {
    let missing = declaration_error(|g| {
        let ubo = filled_ubo(g)?;
        g.compute("short", &shaders::LPV_DILATE_COMP).uniform(ubo).dispatch([1, 1, 1])
    });
    assert!(missing.contains("binding 1") && missing.contains("binds only 1"), "{missing}");
    let extra = declaration_error(|g| {
        let ubo = filled_ubo(g)?;
        let (a, b, c) = (g.create_image("a", grid()), g.create_image("b", grid()), g.create_image("c", grid()));
        g.compute("long", &shaders::LPV_DILATE_COMP).uniform(ubo).write(a).write(b).write(c).dispatch([1, 1, 1])
    });
    assert!(extra.contains("binding 3") && extra.contains("does not declare"), "{extra}");
}

/// `read_at`: a binding at a fixed number past the positional ones (the volume marchers' page
/// table at 15): accepted with the gap between, refused where the shader's binding is missing,
/// lands on the gap, or collides with a positional one.
#[test]
fn fixed_bindings_leave_a_gap_and_must_match_the_shader() {
    let mip = |g: &mut GraphBuilder<'_>, at: Option<u32>| -> Result<(), GraphError> {
        let ubo = filled_ubo(g)?;
        // Declared, never run: the check compares descriptor kinds, so 2D images stand in.
        let vol = g.create_image("volume", ImageDesc::d2(vk::Format::R16_UNORM, 8, 8));
        let tf = g.create_image("tf", ImageDesc::d2(vk::Format::R32G32B32A32_SFLOAT, 8, 2));
        let page = g.create_image("page table", ImageDesc::d2(vk::Format::R32_UINT, 1, 1));
        let hdr = g.create_image("hdr", grid());
        let mut seed = g.add_transfer_pass("seed");
        for img in [vol, tf, page] {
            seed.write_image(img, vkengine::graph::Access::TransferDst)?;
        }
        seed.record(|_| Ok(()));
        let p = g
            .compute("mip", &shaders::VOLUME_MIP_COMP)
            .uniform(ubo)
            .sampled(vol, Sampling::Linear)
            .sampled(tf, Sampling::Linear)
            .write(hdr);
        let p = match at {
            Some(b) => p.read_at(b, page),
            None => p,
        };
        // `volume/common.glsl`'s further atlases (values, then gradients) at 16–21, its page
        // directory at 22, and its label map and label table at 25–26.
        p.each(16..22, |p, b| p.sampled_at(b, vol, Sampling::Linear))
            .read_at(22, page)
            .each(25..27, |p, b| p.sampled_at(b, vol, Sampling::Nearest))
            .dispatch([1, 1, 1])?;
        g.export_image(hdr, None)
    };
    let mut g = GraphBuilder::new();
    mip(&mut g, Some(15)).expect("the page table at 15");
    let missing = declaration_error(|g| mip(g, None));
    assert!(missing.contains("binding 15") && missing.contains("binds nothing there"), "{missing}");
    let gap = declaration_error(|g| mip(g, Some(14)));
    assert!(gap.contains("binding 15") && gap.contains("binds nothing there"), "{gap}");
    let collision = declaration_error(|g| mip(g, Some(2)));
    assert!(collision.contains("binding 2") && collision.contains("collides"), "{collision}");
}

#[test]
fn push_constant_size_must_match_the_block() {
    let msg = declaration_error(|g| {
        let hdr = g.create_image("hdr", grid());
        g.compute("scene", &shaders::DEMO_HELLO_COMP).write(hdr).constants(&[0f32; 4]).dispatch([1, 1, 1])
    });
    assert!(msg.contains("push constants") && msg.contains("16 bytes") && msg.contains("20 bytes"), "{msg}");
}

#[test]
fn reflection_reads_kinds_and_std140_offsets_off_the_glsl() {
    // shaders_glsl/lpv/propagate.comp: Lpv block, the source as a storage texel buffer at 1, the
    // step's flat buffer at 2, the accumulated grid's flat buffer at 3 and again as texels at 4;
    // the occluded variants add the GV (a storage image) at 5; directional adds `normals` after it.
    let kinds = |s: &Shader| s.bindings.iter().map(|b| (b.binding, b.kind)).collect::<Vec<_>>();
    let mut expected = vec![(0, DescriptorKind::UniformBuffer), (1, DescriptorKind::StorageTexelBuffer)];
    expected.push((2, DescriptorKind::StorageBuffer));
    expected.push((3, DescriptorKind::StorageBuffer));
    expected.push((4, DescriptorKind::StorageTexelBuffer));
    assert_eq!(kinds(&shaders::LPV_PROPAGATE_COMP), expected);
    let mut directional = expected.clone();
    directional.push((5, DescriptorKind::StorageImage));
    assert_eq!(kinds(&shaders::LPV_PROPAGATE_COMP__DIRECTIONAL), directional);
    expected.push((5, DescriptorKind::StorageImage));
    assert_eq!(kinds(&shaders::LPV_PROPAGATE_COMP__OCC2), expected);
    expected.push((6, DescriptorKind::StorageImage));
    assert_eq!(kinds(&shaders::LPV_PROPAGATE_COMP__DIRECTIONAL_OCC1), expected);
    // The scatter variant still reads its source as three storage images.
    let scatter = kinds(&shaders::LPV_PROPAGATE_COMP__SCATTER);
    assert_eq!(
        &scatter[1..4],
        &[(1, DescriptorKind::StorageImage), (2, DescriptorKind::StorageImage), (3, DescriptorKind::StorageImage)]
    );
    // lpv/gv_camera.comp: Lpv block, `sampler2D depth_tex` and `normal_tex`, the GV buffer.
    let camera = [
        (0, DescriptorKind::UniformBuffer),
        (1, DescriptorKind::CombinedImageSampler),
        (2, DescriptorKind::CombinedImageSampler),
        (3, DescriptorKind::StorageBuffer),
    ];
    assert_eq!(kinds(&shaders::LPV_GV_CAMERA_COMP), camera);
    // std140 by hand: vec4 cascade[4] (64 B), uvec4, vec4, mat4 (64 B), vec4, vec4, mat4, vec4, uvec4.
    let lpv = shaders::LPV_PROPAGATE_COMP.block(Some(0)).expect("Lpv block");
    let offsets: Vec<u32> = lpv.members.iter().map(|m| m.1).collect();
    assert_eq!(offsets, [0, 64, 80, 96, 160, 176, 192, 256, 272]);
    assert_eq!(lpv.size, 288);
    // post/accumulate.comp pushes one uint; volume/lao.comp the chunk (4 uints) and its 4
    // words, the light variant a vec4 and 4 words more.
    assert_eq!(shaders::POST_ACCUMULATE_COMP.push_size, 4);
    assert_eq!(shaders::VOLUME_LAO_COMP.push_size, 32);
    assert_eq!(shaders::VOLUME_LAO_COMP__LIGHT.push_size, 64);
}

/// Every member of `block` has the offset `ours` gives for its name, and the sizes agree.
fn assert_layout(what: &str, block: Option<&shaders::ShaderBlock>, size: usize, ours: &[(&str, usize)]) {
    let block = block.unwrap_or_else(|| panic!("{what}: block not reflected"));
    assert_eq!(block.size as usize, size, "{what}: size");
    assert_eq!(block.members.len(), ours.len(), "{what}: member count");
    for (name, offset) in ours {
        let m = block.members.iter().find(|m| m.0 == *name).unwrap_or_else(|| panic!("{what}: no member `{name}`"));
        assert_eq!(m.1 as usize, *offset, "{what}.{name}");
    }
}

#[test]
fn pod_structs_match_the_reflected_blocks() {
    use vkengine::lpv::passes::{LpvParams, SkyPush};
    assert_layout(
        "LpvParams",
        shaders::LPV_INJECT_COMP.block(Some(0)),
        size_of::<LpvParams>(),
        &[
            ("cascade", offset_of!(LpvParams, cascade)),
            ("dims", offset_of!(LpvParams, dims)),
            ("params", offset_of!(LpvParams, params)),
            ("rsm_vp", offset_of!(LpvParams, rsm_vp)),
            ("rsm_light", offset_of!(LpvParams, rsm_light)),
            ("light", offset_of!(LpvParams, light)),
            ("inv_view_proj", offset_of!(LpvParams, inv_view_proj)),
            ("camera", offset_of!(LpvParams, camera)),
            ("gbuffer", offset_of!(LpvParams, gbuffer)),
        ],
    );
    assert_layout(
        "SkyPush",
        shaders::LPV_SKY_COMP.block(None),
        size_of::<SkyPush>(),
        &[("view_proj", offset_of!(SkyPush, view_proj)), ("radiance", offset_of!(SkyPush, radiance))],
    );
}

#[test]
fn volume_blocks_match_the_reflected_layouts() {
    use vkengine::volume::render::renderer::{McParams, VolumeParams};
    assert_layout(
        "VolumeParams",
        shaders::VOLUME_EAM_COMP.block(Some(0)),
        size_of::<VolumeParams>(),
        &[
            ("inv_view_proj", offset_of!(VolumeParams, inv_view_proj)),
            ("box_min", offset_of!(VolumeParams, box_min)),
            ("box_max", offset_of!(VolumeParams, box_max)),
            ("light_dir", offset_of!(VolumeParams, light_dir)),
            ("background", offset_of!(VolumeParams, background)),
            ("voxel", offset_of!(VolumeParams, voxel)),
            ("flags", offset_of!(VolumeParams, flags)),
            ("grid", offset_of!(VolumeParams, grid)),
            ("dims", offset_of!(VolumeParams, dims)),
            ("atlas", offset_of!(VolumeParams, atlas)),
            ("clip", offset_of!(VolumeParams, clip)),
            ("clip_count", offset_of!(VolumeParams, clip_count)),
            ("emission", offset_of!(VolumeParams, emission)),
        ],
    );
    let mc = [
        ("sun_dir", offset_of!(McParams, sun_dir)),
        ("sun_radiance", offset_of!(McParams, sun_radiance)),
        ("env_radiance", offset_of!(McParams, env_radiance)),
        ("phase", offset_of!(McParams, phase)),
        ("opts", offset_of!(McParams, opts)),
        ("global_majorant", offset_of!(McParams, global_majorant)),
        ("point_pos", offset_of!(McParams, point_pos)),
        ("point_intensity", offset_of!(McParams, point_intensity)),
        ("env_map", offset_of!(McParams, env_map)),
        ("hybrid", offset_of!(McParams, hybrid)),
        ("emission", offset_of!(McParams, emission)),
    ];
    // Every variant declares the whole block.
    assert_layout("McParams", shaders::VOLUME_MC_COMP__ENV_MAP.block(Some(6)), size_of::<McParams>(), &mc);
    assert_layout("McParams (plain)", shaders::VOLUME_MC_COMP.block(Some(6)), size_of::<McParams>(), &mc);
}

/// llvmpipe vectorizes compute invocations only along x (8 lanes at 256 bits; y and z are scalar
/// loops), so a workgroup narrower than 8 in x runs half-empty vectors: every compute module's
/// reflected `local_size_x` is a multiple of 8, unless its source says why in a
/// `// SIMD width:` comment.
#[test]
fn compute_workgroups_fill_llvmpipe_rows() {
    let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("shaders_glsl");
    let mut narrow = Vec::new();
    let mut checked = 0;
    for s in shaders::ALL.iter().filter(|s| s.stage == shaders::Stage::Compute) {
        let info = vkengine::spirv_reflect::reflect(s.words).unwrap_or_else(|e| panic!("{}: {e}", s.label()));
        let Some([x, y, z]) = info.local_size else { panic!("{}: no LocalSize execution mode", s.label()) };
        checked += 1;
        if x % 8 != 0 {
            let src = std::fs::read_to_string(root.join(s.path)).unwrap_or_default();
            if !src.lines().any(|l| l.trim_start().starts_with("// SIMD width:")) {
                narrow.push(format!("{}: local_size = ({x}, {y}, {z})", s.label()));
            }
        }
    }
    assert!(checked >= 40, "only {checked} compute modules found");
    assert!(
        narrow.is_empty(),
        "local_size_x not a multiple of 8 and no `// SIMD width:` reason:\n{}",
        narrow.join("\n")
    );
}

/// Every volume shader's main reads the per-invocation copies of its parameters first
/// (`volume/common.glsl`'s `load_params`, `tracking.glsl`'s `load_mc_params`): per-sample code
/// reads those copies, which a main that skips the call leaves at zero, a wrong image and no
/// error. The exceptions, `dos.comp`'s INIT variant and the Monte Carlo image passes, do not
/// include `common.glsl`.
#[test]
fn every_volume_shader_main_loads_its_parameters_first() {
    let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("shaders_glsl/volume");
    let mut mains = 0;
    for entry in std::fs::read_dir(&dir).expect("shaders_glsl/volume") {
        let path = entry.expect("entry").path();
        if path.extension().is_none_or(|e| e != "comp") {
            continue;
        }
        let name = path.file_name().expect("name").to_string_lossy().into_owned();
        let text = std::fs::read_to_string(&path).expect("shader");
        // The Monte Carlo image passes (mc_accumulate, mc_tiles, mc_adapt) read no volume
        // parameters: they include none of the files that declare them.
        if !["common.glsl", "tracking.glsl", "mc_common.glsl"]
            .iter()
            .any(|f| text.contains(&format!("#include \"{f}\"")))
        {
            continue;
        }
        for (i, after) in text.split("void main() {").skip(1).enumerate() {
            mains += 1;
            if name == "dos.comp" && i == 0 {
                assert!(!text.split("void main() {").next().unwrap_or("").contains("#include \"common.glsl\""));
                continue;
            }
            let first = after.lines().map(str::trim).find(|l| !l.is_empty()).unwrap_or("");
            assert!(
                first == "load_params();" || first == "load_mc_params();",
                "{name}: main {i} starts with `{first}`, not load_params() / load_mc_params()"
            );
        }
    }
    assert!(mains >= 9, "found only {mains} mains under {}", dir.display());
}
