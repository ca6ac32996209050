//! Mesh renderer timings: per-pass GPU ms (median of N frames after a warm-up frame) for the
//! built-in scenes and a generated large glTF terrain, plus that model's load time. Writes
//! `results/mesh_bench/timings.csv` with the device it ran on.

use clap::Parser;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use std::time::Instant;
use vkengine::mesh::gpu_scene::GpuScene;
use vkengine::mesh::renderer::{render_frame, MeshRenderer, MeshTargets};
use vkengine::vk::{Context, ContextOptions};
use vkengine_demos::mesh_scene::{builtin_scene, mesh_settings, view_at};
use vkengine_demos::stats::PassStats;

#[derive(Parser)]
#[command(about = "Mesh renderer benchmark")]
struct Args {
    /// Output folder.
    #[arg(long, default_value = "results/mesh_bench")]
    out: PathBuf,
    /// Measured frames per scene.
    #[arg(long, default_value_t = 8)]
    frames: u64,
    /// Image size.
    #[arg(long, default_value = "1280x720", value_parser = vkengine_demos::cli::parse_size)]
    size: [u32; 2],
    /// Generated terrain: quads per side (2·n² triangles).
    #[arg(long, default_value_t = 1024)]
    terrain: u32,
    /// RSM edge (0 = none), as `--set rsm=` in the demos.
    #[arg(long, default_value_t = 256)]
    rsm: u32,
    /// Override a setting of every scene, `key=value` (repeatable; e.g. `cull_triangles=0`).
    #[arg(long = "set", value_parser = vkengine_demos::cli::parse_kv)]
    set: Vec<(String, String)>,
}

/// Writes a binary glTF heightfield of `n`×`n` quads (positions, normals, uvs, u32 indices).
fn write_terrain(path: &Path, n: u32) -> std::io::Result<usize> {
    let v = n + 1;
    let h = |x: f32, z: f32| 0.6 * (x * 0.7).sin() * (z * 0.5).cos() + 0.2 * (x * 2.3 + z * 1.7).sin();
    let (mut pos, mut nrm, mut uv, mut idx) = (Vec::new(), Vec::new(), Vec::new(), Vec::new());
    let size = 40.0f32;
    for j in 0..v {
        for i in 0..v {
            let (x, z) = (size * (i as f32 / n as f32 - 0.5), size * (j as f32 / n as f32 - 0.5));
            pos.extend([x, h(x, z), z]);
            let e = 1e-3;
            let (dx, dz) = ((h(x + e, z) - h(x - e, z)) / (2.0 * e), (h(x, z + e) - h(x, z - e)) / (2.0 * e));
            let l = (dx * dx + 1.0 + dz * dz).sqrt();
            nrm.extend([-dx / l, 1.0 / l, -dz / l]);
            uv.extend([i as f32 / n as f32 * 8.0, j as f32 / n as f32 * 8.0]);
        }
    }
    for j in 0..n {
        for i in 0..n {
            let a = j * v + i;
            idx.extend([a, a + v, a + 1, a + 1, a + v, a + v + 1]);
        }
    }
    let bytes = |f: &[f32]| f.iter().flat_map(|x| x.to_le_bytes()).collect::<Vec<u8>>();
    let mut bin = bytes(&pos);
    let (p_len, n_len, uv_len) = (pos.len() * 4, nrm.len() * 4, uv.len() * 4);
    bin.extend(bytes(&nrm));
    bin.extend(bytes(&uv));
    bin.extend(idx.iter().flat_map(|x| x.to_le_bytes()));
    let i_len = idx.len() * 4;
    let half = size * 0.5;
    let json = format!(
        r#"{{"asset":{{"version":"2.0"}},"scene":0,"scenes":[{{"nodes":[0]}}],"nodes":[{{"mesh":0}}],
"materials":[{{"pbrMetallicRoughness":{{"baseColorFactor":[0.45,0.55,0.35,1],"metallicFactor":0,"roughnessFactor":0.9}}}}],
"meshes":[{{"primitives":[{{"attributes":{{"POSITION":0,"NORMAL":1,"TEXCOORD_0":2}},"indices":3,"material":0}}]}}],
"buffers":[{{"byteLength":{}}}],
"bufferViews":[{{"buffer":0,"byteOffset":0,"byteLength":{p_len}}},{{"buffer":0,"byteOffset":{},"byteLength":{n_len}}},
{{"buffer":0,"byteOffset":{},"byteLength":{uv_len}}},{{"buffer":0,"byteOffset":{},"byteLength":{i_len}}}],
"accessors":[{{"bufferView":0,"componentType":5126,"count":{},"type":"VEC3","min":[{},-1,{}],"max":[{},1,{}]}},
{{"bufferView":1,"componentType":5126,"count":{},"type":"VEC3"}},{{"bufferView":2,"componentType":5126,"count":{},"type":"VEC2"}},
{{"bufferView":3,"componentType":5125,"count":{},"type":"SCALAR"}}]}}"#,
        bin.len(),
        p_len,
        p_len + n_len,
        p_len + n_len + uv_len,
        v * v,
        -half,
        -half,
        half,
        half,
        v * v,
        v * v,
        idx.len()
    );
    let mut json = json.into_bytes();
    while json.len() % 4 != 0 {
        json.push(b' ');
    }
    let mut out = Vec::with_capacity(28 + json.len() + bin.len());
    out.extend(b"glTF");
    out.extend(2u32.to_le_bytes());
    out.extend(((12 + 8 + json.len() + 8 + bin.len()) as u32).to_le_bytes());
    out.extend((json.len() as u32).to_le_bytes());
    out.extend(b"JSON");
    out.extend(&json);
    out.extend((bin.len() as u32).to_le_bytes());
    out.extend(b"BIN\0");
    out.extend(&bin);
    std::fs::write(path, out)?;
    Ok(idx.len() / 3)
}

fn main() {
    vkengine_demos::runner::exit_on_bench_error(run());
}

fn run() -> Result<(), Box<dyn std::error::Error>> {
    let args = Args::parse();
    std::fs::create_dir_all(&args.out)?;
    let ctx = Context::new(&ContextOptions::from_env())?;
    let renderer = MeshRenderer::new(&ctx)?;
    let terrain = args.out.join("terrain.glb");
    let t0 = Instant::now();
    let tris = write_terrain(&terrain, args.terrain)?;
    println!("generated {} ({tris} triangles) in {:.0} ms", terrain.display(), t0.elapsed().as_secs_f64() * 1e3);
    let t0 = Instant::now();
    let terrain_scene = vkengine::scene::load_scene(&terrain)?;
    let load_ms = t0.elapsed().as_secs_f64() * 1e3;
    println!("loaded {} triangles in {load_ms:.0} ms", terrain_scene.triangle_count());
    let [w, h] = args.size;
    let mut csv = format!(
        "# device: {} ({}); {w}x{h}, rsm {}, median of {} frames after one warm-up; terrain load {load_ms:.0} ms\nscene,triangles,pass,gpu_ms_median,dispatches,barriers,transfer_bytes\n",
        ctx.info.name, ctx.info.driver, args.rsm, args.frames
    );
    let scenes =
        [("cornell", builtin_scene("cornell")?), ("atrium", builtin_scene("atrium")?), ("terrain", terrain_scene)];
    for (name, scene) in &scenes {
        let mut sets = vec![("rsm".to_string(), args.rsm.to_string())];
        sets.extend(args.set.iter().cloned());
        let (settings, rsm) = mesh_settings(&scene.settings, &sets)?;
        let t0 = Instant::now();
        let gpu = GpuScene::upload(&ctx, scene)?;
        let upload_ms = t0.elapsed().as_secs_f64() * 1e3;
        let mut targets = MeshTargets::new(&ctx, args.size, rsm)?;
        let mut stats = PassStats::default();
        for frame in 0..=args.frames {
            let run = render_frame(&ctx, &renderer, &gpu, &mut targets, &view_at(scene, 0, 1), &settings)?;
            if frame > 0 {
                stats.add(&run.timings);
            }
        }
        println!(
            "{name}: {} triangles, upload {upload_ms:.0} ms, {:.2} ms/frame",
            scene.triangle_count(),
            stats.frame_median()
        );
        for (pass, ms) in stats.pass_medians() {
            println!("  {pass:<14} {ms:>8.3} ms");
            let c = stats.last_commands(&pass);
            let counts = format!("{},{},{}", c.dispatches, c.barriers, c.transfer_bytes);
            writeln!(csv, "{name},{},\"{pass}\",{ms:.3},{counts}", scene.triangle_count())?;
        }
        let c = stats.frame_commands();
        let counts = format!("{},{},{}", c.dispatches, c.barriers, c.transfer_bytes);
        writeln!(csv, "{name},{},frame,{:.3},{counts}", scene.triangle_count(), stats.frame_median())?;
        let png = args.out.join(format!("{name}.png"));
        vkengine_demos::output::write_png(&png, w, h, &targets.read_ldr(&ctx)?)?;
    }
    let path = args.out.join("timings.csv");
    std::fs::write(&path, csv)?;
    println!("wrote {}", path.display());
    Ok(())
}
