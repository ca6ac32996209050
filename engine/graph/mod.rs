//! Frame graph: declared passes and resources, compiled into culled, ordered, synchronized work.
//! Its files are layered: `resource`, `access`, `error` → `work`, `alias`, `pass_context` (what a
//! pass's closure sees) → `builder` (declare) → `barriers` → `compiled`, `compile` → `imports`,
//! `transients`, `persistent`, `commands`, `trace`, `shader_pass`, `present` → `execute` (record
//! and run), which nothing here imports. Uses `crate::vk`; used by every renderer.
//!
//! Data flow, one frame:
//!
//! 1. **Declare** ([`GraphBuilder`]): transient resources (graph-owned, contents start
//!    undefined), imported resources (persistent, with the [`ResourceState`] they were last
//!    left in) and passes with their reads/writes. Declaration order is the semantics: a read
//!    sees the latest earlier-declared write. Misuse is reported immediately as [`GraphError`].
//! 2. **Compile** ([`GraphBuilder::compile`], pure CPU): build the RAW/WAR/WAW DAG, cull
//!    passes nothing exported (or side-effecting) depends on, pick a topological order,
//!    simulate every resource's state along it to emit one barrier batch per pass plus a final
//!    export batch, and compute transient lifetimes, usage flags and next-frame states.
//! 3. **Place memory** (device-dependent): query memory requirements of
//!    [`CompiledGraph::transients`], build requests with [`CompiledGraph::alias_requests`],
//!    run [`place`], then [`CompiledGraph::apply_aliasing`] to add the barriers that memory
//!    reuse requires.
//! 4. **Execute** (the executor module): create/bind resources, then per pass record its
//!    barriers and its closure; record the final barriers; feed
//!    [`CompiledGraph::final_states`] into next frame's imports.
//!
//! [`dot`] and [`trace`] are diagnostics: a Graphviz view of a compiled graph and Chrome
//! trace / text reports of measured pass timings.

mod access;
mod alias;
mod barriers;
mod builder;
mod commands;
mod compile;
mod compiled;
pub mod dot;
mod error;
pub mod execute;
mod imports;
mod pass_context;
pub mod persistent;
pub mod present;
mod resource;
pub mod shader_pass;
pub mod trace;
mod transients;
pub mod work;

pub use access::{write_bits, Access, ShaderStage};
pub use alias::{place, AliasPlan, AliasRequest};
pub use barriers::{BufferBarrier, ImageBarrier, PassBarriers};
pub use builder::{ColorAttachment, DepthAttachment, GraphBuilder, LoadOp, PassBuilder, PassKind, RecordFn};
pub use commands::Commands;
pub use compile::CompileOptions;
pub use compiled::{CompiledGraph, CompiledPass, CulledPass, GraphStats, ResourceInfo, ResourceUse, Transient};
pub use error::GraphError;
pub use imports::Imports;
pub use pass_context::{GraphBuffer, GraphImage, PassContext};
pub use persistent::{PersistentBuffer, PersistentImage};
pub use present::{add_present_pass, add_window_passes, FrameOverlay, PresentTarget};
pub use resource::{BufferDesc, BufferId, ImageDesc, ImageId, ImageKind, ResourceDesc, ResourceId, ResourceState};
pub use shader_pass::{ComputePass, Dispatcher};
pub use transients::MemoryReport;
pub use work::Work;
