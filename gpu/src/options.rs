//! The GPU back end's options: how the planner splits a program into passes
//! ([`PassMode`], `--gpu-passes`) and the sizes it plans under ([`GpuOptions`]).
//!
//! Owns: the option types and their defaults and parsing. Must not touch: anything that
//! uses them (the planner, the plan, the material); it imports nothing from this crate.

/// How the planner splits a program into passes (`--gpu-passes`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum PassMode {
    /// The cost model decides (op budget, adapter limits).
    #[default]
    Auto,
    /// One kernel between host steps (`--gpu-passes 1`).
    Fused,
    /// About this many passes of equal cost (at least the host steps' own).
    Count(u32),
}

impl std::str::FromStr for PassMode {
    type Err = String;
    fn from_str(s: &str) -> Result<PassMode, String> {
        match s {
            "auto" => Ok(PassMode::Auto),
            "1" => Ok(PassMode::Fused),
            n => match n.parse::<u32>() {
                Ok(k) if k >= 1 => Ok(PassMode::Count(k)),
                _ => Err(format!("`{s}`: expected auto, 1 or a pass count ≥ 1")),
            },
        }
    }
}

/// Options of the GPU back end.
#[derive(Clone, Debug, PartialEq)]
pub struct GpuOptions {
    /// Pass partitioning.
    pub passes: PassMode,
    /// Ops per pass the cost model allows in `Auto` mode.
    pub op_budget: usize,
    /// Most fragments per batch (one set of buffers).
    pub batch: usize,
    /// Threads per workgroup.
    pub workgroup_size: u32,
}

impl Default for GpuOptions {
    fn default() -> Self {
        GpuOptions {
            passes: PassMode::Auto,
            op_budget: 4096,
            batch: 1 << 18,
            workgroup_size: 64,
        }
    }
}
