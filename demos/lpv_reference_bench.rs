//! Times the CPU diffuse-lighting reference (engine/mesh/reference.rs) on the built-in Cornell box:
//! BVH build and render wall time, plus the mean direct and indirect radiance as a sanity check.

use clap::Parser;
use std::process::ExitCode;
use std::time::Instant;
use vkengine::mesh::camera::View;
use vkengine::mesh::reference::{ReferenceSettings, Tracer};
use vkengine::scene::procedural::cornell_box;

#[derive(Parser)]
#[command(about = "CPU lighting reference timing on the Cornell box")]
struct Args {
    /// Image size.
    #[arg(long, default_value = "128x128", value_parser = vkengine_demos::cli::parse_size)]
    size: [u32; 2],
    /// Indirect samples per pixel.
    #[arg(long, default_value_t = 256)]
    samples: u32,
    /// Worker threads (0: one per core).
    #[arg(long, default_value_t = 0)]
    threads: usize,
}

fn main() -> ExitCode {
    let args = Args::parse();
    let scene = cornell_box();
    let c = scene.camera;
    let view = View::look_at(c.position.into(), c.target.into(), c.up.into(), c.fov_y_deg, c.near, c.far);
    let t0 = Instant::now();
    let tracer = match Tracer::new(&scene) {
        Ok(t) => t,
        Err(e) => {
            eprintln!("error: {e}");
            return ExitCode::FAILURE;
        }
    };
    let build = t0.elapsed();
    let settings = ReferenceSettings { samples: args.samples, seed: 0, threads: args.threads, sky: [0.0; 3] };
    let t1 = Instant::now();
    let img = match tracer.render(&view, args.size, &settings) {
        Ok(img) => img,
        Err(e) => {
            eprintln!("error: {e}");
            return ExitCode::from(2);
        }
    };
    let render = t1.elapsed();
    let mean = |v: &[[f32; 4]]| [0, 1, 2].map(|k| v.iter().map(|c| c[k] as f64).sum::<f64>() / v.len() as f64);
    let [w, h] = args.size;
    println!(
        "cornell {w}x{h}, {} spp, {} threads: build {:.2} ms, render {:.3} s; mean direct {:.4?}, indirect {:.4?}",
        args.samples,
        if args.threads == 0 { std::thread::available_parallelism().map_or(1, |n| n.get()) } else { args.threads },
        build.as_secs_f64() * 1e3,
        render.as_secs_f64(),
        mean(&img.direct),
        mean(&img.indirect),
    );
    ExitCode::SUCCESS
}
