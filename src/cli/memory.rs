//! `--max-memory-mb`: the limit the options' memory needs are checked against at start-up,
//! before anything is allocated (see `glint::budget`).

use anyhow::Result;
use clap::Args;

use glint::budget::{MemoryPlan, DEFAULT_MAX_MEMORY_MB};

/// The limit's bounds: below 16 MB not even a small frame fits; above 64 GB is no limit.
const MIN_MAX_MEMORY_MB: u64 = 16;
const MAX_MAX_MEMORY_MB: u64 = 65_536;

/// The memory limit option.
#[derive(Debug, Args)]
pub struct MemoryArgs {
    /// Refuse to start when the options need more memory than this, in MB, 16 to 65536 (the
    /// frame buffers, masks and background model grow with --size and --background-frames).
    #[arg(long, value_name = "MB", default_value_t = DEFAULT_MAX_MEMORY_MB,
          allow_negative_numbers = true,
          value_parser = clap::value_parser!(u64).range(MIN_MAX_MEMORY_MB..=MAX_MAX_MEMORY_MB))]
    max_memory_mb: u64,
}

impl MemoryArgs {
    /// Checks `plan` against the limit; the error names the option and the need.
    pub fn check(&self, plan: &MemoryPlan) -> Result<()> {
        plan.check(self.max_memory_mb)?;
        log::debug!(
            "memory for the options: {} of {} MB",
            plan.total_bytes().div_ceil(glint::budget::BYTES_PER_MB),
            self.max_memory_mb
        );
        Ok(())
    }
}
