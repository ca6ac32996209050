//! Mesh demo: the built-in atrium scene (or `--scene FILE`) with deferred direct lighting and
//! shadow maps; headless without a display (PNG + per-pass report), windowed with one.

fn main() {
    vkengine_demos::mesh_app::main("atrium", "atrium");
}
