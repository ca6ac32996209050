//! TEMPORARY stand-in (replaced by the full module): procedural volumes per the agreed spec.
use super::Volume;

fn gen(dims: [u32; 3], name: String, f: impl Fn([f32; 3]) -> f32) -> Volume {
    let mut data = Vec::new();
    for z in 0..dims[2] {
        for y in 0..dims[1] {
            for x in 0..dims[0] {
                let p = [
                    (x as f32 + 0.5) / dims[0] as f32,
                    (y as f32 + 0.5) / dims[1] as f32,
                    (z as f32 + 0.5) / dims[2] as f32,
                ];
                data.push(f(p));
            }
        }
    }
    Volume::new(dims, [1.0; 3], data, name).expect("valid")
}
/// Constant volume.
pub fn homogeneous_box(dims: [u32; 3], density: f32) -> Volume {
    gen(dims, "box".into(), |_| density)
}
/// Smooth sphere.
pub fn smooth_sphere(dims: [u32; 3], radius: f32) -> Volume {
    gen(dims, "smooth sphere".into(), |p| {
        let r = ((p[0] - 0.5).powi(2) + (p[1] - 0.5).powi(2) + (p[2] - 0.5).powi(2)).sqrt();
        (1.0 - r / radius).clamp(0.0, 1.0)
    })
}
