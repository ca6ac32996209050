//! Mesh demo for any scene: `--scene FILE` takes a scene description (.toml) or a bare
//! .gltf/.glb/.obj model (framed with a default camera and sun); without it, the Cornell box.

fn main() {
    vkengine_demos::mesh_app::main("scene", "cornell");
}
