//! The formats of the mesh renderer's targets, which the pipelines that write them and the
//! passes that allocate them share.

use crate::vk::vk;

/// G-buffer albedo format.
pub const ALBEDO_FORMAT: vk::Format = vk::Format::R8G8B8A8_UNORM;
/// G-buffer world-normal format.
pub const NORMAL_FORMAT: vk::Format = vk::Format::R16G16B16A16_SFLOAT;
/// G-buffer specular format (rgb colour, a = log2(shininess) / 12: 3.3 % steps over [1, 4096]).
pub const SPECULAR_FORMAT: vk::Format = vk::Format::R8G8B8A8_UNORM;
/// Depth format of every depth buffer and shadow map.
pub const DEPTH_FORMAT: vk::Format = vk::Format::D32_SFLOAT;
/// RSM world position, normal and flux: 32-bit float so summed flux stays exact.
pub const RSM_FORMAT: vk::Format = vk::Format::R32G32B32A32_SFLOAT;
