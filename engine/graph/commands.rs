//! What each pass recorded, counted by the executor: dispatches, barriers and the bytes its
//! transfer commands wrote. On a GPU these fixed costs, not the work, bound small passes;
//! counting them on every device (lavapipe included) shows every change in profiles and bench
//! CSVs without a GPU.

use super::builder::PassKind;
use super::compiled::{CompiledPass, ResourceInfo};
use super::work::resource_bytes;
use ash::vk;
use serde::{Deserialize, Serialize};

/// Commands one pass (or one frame) recorded.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct Commands {
    /// Compute dispatches, direct and indirect.
    pub dispatches: u32,
    /// Buffer and image memory barriers recorded before the pass (the graph's final batch
    /// counts with its last pass).
    pub barriers: u32,
    /// Bytes written by the pass's transfer commands (copies, fills, updates), each declared
    /// destination counted whole.
    pub transfer_bytes: u64,
}

impl Commands {
    /// The sum of a frame's passes.
    pub fn total<'t>(passes: impl IntoIterator<Item = &'t Commands>) -> Commands {
        passes.into_iter().fold(Commands::default(), |a, c| Commands {
            dispatches: a.dispatches + c.dispatches,
            barriers: a.barriers + c.barriers,
            transfer_bytes: a.transfer_bytes + c.transfer_bytes,
        })
    }
}

/// Bytes a transfer pass writes: every resource it declared as a transfer destination.
pub(crate) fn transfer_bytes(pass: &CompiledPass<'_>, resources: &[ResourceInfo]) -> u64 {
    if pass.kind != PassKind::Transfer {
        return 0;
    }
    pass.uses
        .iter()
        .filter(|u| u.writes && u.access.contains(vk::AccessFlags2::TRANSFER_WRITE))
        .filter_map(|u| resources.get(u.resource.index()))
        .map(|r| resource_bytes(&r.desc))
        .sum()
}
