//! Device selection: which adapter shades, and the device and queue opened on it.
//!
//! [`GpuContext::shared`] opens one device per process (the first call chooses it; later
//! calls share it). The choice, in order: the adapter whose name contains
//! `SHADENET_GPU_ADAPTER` (case-insensitive) when that variable is set; otherwise a discrete
//! GPU, then an integrated one, then a virtual one, then a software adapter (Mesa's lavapipe
//! on Vulkan, llvmpipe on GL), Vulkan before GL at equal rank. No adapter at all is
//! [`GpuError::NoAdapter`], whose message lists what was tried and how to install the
//! software drivers.

use std::sync::{Arc, OnceLock};

/// The environment variable that chooses the accuracy class instead of the adapter:
/// `hardware` applies the hardware contract on any adapter (so that CI exercises it on
/// lavapipe), `exact` the bit-exact one (an experiment on a hardware GPU, which is expected
/// to fail it).
pub const ACCURACY_VAR: &str = "SHADENET_GPU_ACCURACY";

/// What the GPU back end promises against the CPU back ends on an adapter (see
/// `docs/gpu.md`, "Accuracy").
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Accuracy {
    /// Bit for bit with the interpreter and the JIT, except the documented transcendental
    /// bounds: software rasterizers (Mesa's lavapipe and llvmpipe), which keep subnormals,
    /// round `sqrt` correctly and do not contract `a * b + c` across the value barrier.
    BitExact,
    /// The bounded contract of a hardware GPU, where WGSL lets the driver flush subnormals
    /// to zero, round `sqrt` and division within a few ulps and contract `a * b + c` into
    /// fused multiply-adds: the bounds of `shadenet_gpu::testing::hardware`.
    Hardware,
}

impl Accuracy {
    /// The class of an adapter: [`Accuracy::BitExact`] for a software rasterizer,
    /// [`Accuracy::Hardware`] otherwise; `SHADENET_GPU_ACCURACY` (`hardware` or `exact`)
    /// overrides it.
    pub fn of(info: &AdapterSummary) -> Accuracy {
        match std::env::var(ACCURACY_VAR).as_deref() {
            Ok("hardware") => Accuracy::Hardware,
            Ok("exact") => Accuracy::BitExact,
            _ if info.is_software() => Accuracy::BitExact,
            _ => Accuracy::Hardware,
        }
    }

    /// The words `gpu-info` and the tests print.
    pub fn describe(self) -> &'static str {
        match self {
            Accuracy::BitExact => "bit-exact (software rasterizer)",
            Accuracy::Hardware => "hardware (bounded: subnormals flushed, fused multiply-adds)",
        }
    }
}

/// Why the GPU back end cannot run.
#[derive(Debug, Clone, thiserror::Error)]
pub enum GpuError {
    /// No adapter was found (or none matched `SHADENET_GPU_ADAPTER`).
    #[error("no GPU adapter: {0}")]
    NoAdapter(String),
    /// The adapter refused to open a device.
    #[error("cannot open a device on `{adapter}`: {reason}")]
    Device {
        /// The adapter's name.
        adapter: String,
        /// The driver's answer.
        reason: String,
    },
    /// A GPU operation failed after the device was opened (out of memory, a lost device, a
    /// shader the driver rejected).
    #[error("GPU error: {0}")]
    Runtime(String),
}

/// One adapter as `shadenet gpu-info` lists it.
#[derive(Clone, Debug, PartialEq)]
pub struct AdapterSummary {
    /// The adapter's name (`llvmpipe (LLVM 15.0.6, 256 bits)`, `NVIDIA H100 …`).
    pub name: String,
    /// Graphics API (`Vulkan`, `Gl`).
    pub backend: String,
    /// `DiscreteGpu`, `IntegratedGpu`, `VirtualGpu`, `Cpu`, `Other`.
    pub device_type: String,
    /// Driver name and version as the driver reports them.
    pub driver: String,
}

impl AdapterSummary {
    /// Whether the adapter is a software rasterizer: wgpu's `DeviceType::Cpu`, or a name
    /// of one (Mesa's lavapipe and llvmpipe, SwiftShader, WARP) where the driver reports
    /// another type.
    pub fn is_software(&self) -> bool {
        let name = self.name.to_lowercase();
        self.device_type == "Cpu"
            || [
                "llvmpipe",
                "lavapipe",
                "swiftshader",
                "microsoft basic render",
            ]
            .iter()
            .any(|s| name.contains(s))
    }
}

/// The opened device and what it allows.
pub struct GpuContext {
    /// The adapter the device was opened on.
    pub adapter: wgpu::Adapter,
    /// The device.
    pub device: wgpu::Device,
    /// Its queue.
    pub queue: wgpu::Queue,
    /// The adapter's description.
    pub info: AdapterSummary,
    /// The limits the device was opened with: the adapter's own (all of them, not the
    /// WebGPU defaults), which the pass partitioner plans under.
    pub limits: wgpu::Limits,
    /// The accuracy class of the adapter ([`Accuracy::of`]), chosen once when the device
    /// opens.
    pub accuracy: Accuracy,
}

impl std::fmt::Debug for GpuContext {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("GpuContext")
            .field("info", &self.info)
            .finish_non_exhaustive()
    }
}

fn summary(info: &wgpu::AdapterInfo) -> AdapterSummary {
    AdapterSummary {
        name: info.name.clone(),
        backend: format!("{:?}", info.backend),
        device_type: format!("{:?}", info.device_type),
        driver: format!("{} {}", info.driver, info.driver_info)
            .trim()
            .to_string(),
    }
}

fn rank(info: &wgpu::AdapterInfo) -> (u8, u8) {
    let ty = match info.device_type {
        wgpu::DeviceType::DiscreteGpu => 0,
        wgpu::DeviceType::IntegratedGpu => 1,
        wgpu::DeviceType::VirtualGpu => 2,
        wgpu::DeviceType::Cpu => 3,
        wgpu::DeviceType::Other => 4,
    };
    let api = match info.backend {
        wgpu::Backend::Vulkan | wgpu::Backend::Metal | wgpu::Backend::Dx12 => 0,
        _ => 1,
    };
    (ty, api)
}

fn instance(backends: wgpu::Backends) -> wgpu::Instance {
    wgpu::Instance::new(wgpu::InstanceDescriptor {
        backends,
        ..wgpu::InstanceDescriptor::new_without_display_handle()
    })
}

/// Every adapter the instance finds, best first (the order [`GpuContext::open`] chooses in).
pub fn adapters() -> Vec<AdapterSummary> {
    sorted_adapters()
        .1
        .iter()
        .map(|a| summary(&a.get_info()))
        .collect()
}

/// The adapters of the primary APIs (Vulkan, Metal, DX12); GL only where those have none
/// (GL through EGL complains on stderr on a machine without a display, so it is asked only
/// when needed).
fn sorted_adapters() -> (wgpu::Instance, Vec<wgpu::Adapter>) {
    let primary = instance(wgpu::Backends::PRIMARY);
    let mut list = pollster::block_on(primary.enumerate_adapters(wgpu::Backends::PRIMARY));
    let instance = if list.is_empty() {
        let gl = instance(wgpu::Backends::GL);
        list = pollster::block_on(gl.enumerate_adapters(wgpu::Backends::GL));
        gl
    } else {
        primary
    };
    list.sort_by_key(|a| rank(&a.get_info()));
    (instance, list)
}

const INSTALL_HINT: &str = "install Mesa's software Vulkan driver (`apt-get install -y \
     --no-install-recommends mesa-vulkan-drivers libvulkan1`) or run on a machine with a GPU";

impl GpuContext {
    /// Opens a device on the best adapter (see the module documentation).
    pub fn open() -> Result<GpuContext, GpuError> {
        let (_instance, list) = sorted_adapters();
        if list.is_empty() {
            return Err(GpuError::NoAdapter(format!(
                "wgpu found no Vulkan, Metal or GL adapter; {INSTALL_HINT}"
            )));
        }
        let wanted = std::env::var("SHADENET_GPU_ADAPTER")
            .ok()
            .filter(|s| !s.is_empty());
        let adapter = match &wanted {
            Some(w) => {
                let w = w.to_lowercase();
                let found = list
                    .iter()
                    .find(|a| a.get_info().name.to_lowercase().contains(&w));
                match found {
                    Some(a) => a.clone(),
                    None => {
                        let names: Vec<String> =
                            list.iter().map(|a| a.get_info().name.clone()).collect();
                        return Err(GpuError::NoAdapter(format!(
                            "SHADENET_GPU_ADAPTER={w:?} matches none of: {}",
                            names.join(", ")
                        )));
                    }
                }
            }
            None => list[0].clone(),
        };
        let info = summary(&adapter.get_info());
        let accuracy = Accuracy::of(&info);
        let limits = adapter.limits();
        let (device, queue) = pollster::block_on(adapter.request_device(&wgpu::DeviceDescriptor {
            label: Some("shadenet"),
            required_features: wgpu::Features::empty(),
            required_limits: limits.clone(),
            ..Default::default()
        }))
        .map_err(|e| GpuError::Device {
            adapter: info.name.clone(),
            reason: e.to_string(),
        })?;
        Ok(GpuContext {
            adapter,
            device,
            queue,
            info,
            limits,
            accuracy,
        })
    }

    /// The process's shared context: opened on first use, the same `Arc` (or the same
    /// error) afterwards.
    pub fn shared() -> Result<Arc<GpuContext>, GpuError> {
        static SHARED: OnceLock<Result<Arc<GpuContext>, GpuError>> = OnceLock::new();
        SHARED
            .get_or_init(|| GpuContext::open().map(Arc::new))
            .clone()
    }

    /// The lines `shadenet gpu-info` prints: adapter, backend, driver and the limits the
    /// partitioner uses.
    pub fn describe(&self) -> String {
        let l = &self.limits;
        format!(
            "adapter: {}\nbackend: {}\ntype: {}\ndriver: {}\naccuracy: {}\n\
             max_storage_buffers_per_shader_stage: {}\n\
             max_storage_buffer_binding_size: {}\nmax_buffer_size: {}\n\
             max_compute_workgroup_storage_size: {}\n\
             max_compute_invocations_per_workgroup: {}\n\
             max_compute_workgroups_per_dimension: {}\n",
            self.info.name,
            self.info.backend,
            self.info.device_type,
            self.info.driver,
            self.accuracy.describe(),
            l.max_storage_buffers_per_shader_stage,
            l.max_storage_buffer_binding_size,
            l.max_buffer_size,
            l.max_compute_workgroup_storage_size,
            l.max_compute_invocations_per_workgroup,
            l.max_compute_workgroups_per_dimension,
        )
    }
}
