//! A volume's layout on the device: dense images or sparse brick atlases behind page tables,
//! chosen per volume, and their upload. Uses `data` (the host volume and its bricks); used by
//! `render`.

pub mod layout;
pub mod page_images;
pub mod resident;
