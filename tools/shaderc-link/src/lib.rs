//! Re-exports `shaderc` with the link directives Debian's packaging needs (see build.rs).
pub use shaderc;
