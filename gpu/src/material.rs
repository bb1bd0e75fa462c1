//! `GpuBackend` and `GpuMaterial` (interface fixed; bodies are being written).

use crate::context::GpuError;
use shadenet_graph::ir::Program;
use shadenet_runtime::{Backend, BackendError, Material};
use std::sync::Arc;
use std::time::Duration;

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

/// The GPU back end: compiles programs into [`Material`]s that shade batches on the device.
pub struct GpuBackend {
    #[allow(dead_code)]
    options: GpuOptions,
    #[allow(dead_code)]
    scalar: Arc<dyn Backend>,
}

impl GpuBackend {
    /// A back end on the shared device ([`crate::GpuContext::shared`]); `scalar` shades the
    /// single fragments (`Material::shade`, `shade_x4`).
    pub fn new(options: GpuOptions, scalar: Arc<dyn Backend>) -> Result<GpuBackend, GpuError> {
        crate::GpuContext::shared()?;
        Ok(GpuBackend { options, scalar })
    }
}

impl Backend for GpuBackend {
    fn name(&self) -> &'static str {
        "gpu"
    }

    fn compile_program(
        &self,
        program: &Program,
        _optimize: Duration,
    ) -> Result<Arc<dyn Material>, BackendError> {
        Err(BackendError::Unsupported {
            backend: "gpu",
            material: program.name.clone(),
            op: "the program".into(),
            reason: "the GPU back end is not built yet".into(),
        })
    }
}
