//! Debian's `libshaderc.so` leaves glslang symbols undefined and `libshaderc_combined.a` lacks
//! glslang, so whoever links shaderc must also link these static libraries, in this order.
//! Link directives only reach a build script through a dependency, hence this crate.
fn main() {
    println!("cargo:rerun-if-env-changed=SHADERC_LIB_DIR");
    if std::env::var_os("CARGO_FEATURE_FROM_SOURCE").is_some() {
        return;
    }
    let dir = std::env::var("SHADERC_LIB_DIR").unwrap_or_else(|_| "/usr/lib/x86_64-linux-gnu".into());
    println!("cargo:rustc-link-search=native={dir}");
    for lib in [
        "glslang",
        "MachineIndependent",
        "GenericCodeGen",
        "OSDependent",
        "OGLCompiler",
        "SPIRV",
        "HLSL",
        "glslang-default-resource-limits",
        "SPIRV-Tools-opt",
        "SPIRV-Tools",
    ] {
        println!("cargo:rustc-link-lib=static={lib}");
    }
}
