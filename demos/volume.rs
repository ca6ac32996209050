//! Volume demo: MIP / ISO / EAM / Monte Carlo scattering of a procedural scene (default: a 128³
//! cloud) or any supported file (`--volume`). Headless: PNG or EXR + JSON report; windowed: drag
//! to orbit, scroll to zoom, 1/2/3 = MIP/ISO/EAM, T = next tone mapper, E = empty-space skipping.

fn main() {
    vkengine_demos::volume_app::main();
}
