//! What light does in a volume, independent of how it is stored: transfer functions (and the
//! choice of one from a volume's units and histogram), phase functions, environment maps, blackbody
//! emission. Uses
//! `data` (a volume's units and histogram); used by `camera` (framing by visible values),
//! `render` and the UI's transfer-function editor.

pub mod blackbody;
pub mod envmap;
pub mod label_table;
pub mod phase;
pub mod tf;
pub mod tf_choice;
