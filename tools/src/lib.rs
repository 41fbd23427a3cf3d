//! Host-only tools for glint.
//!
//! - [`scene`]: the synthetic scene renderer with exact ground truth that glint's accuracy
//!   tests rely on (also the `glint-scene` binary).

pub mod scene;
