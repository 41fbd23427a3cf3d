//! Host-only tools for glint.
