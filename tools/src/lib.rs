//! Host-only tools for glint.
pub mod markers;
