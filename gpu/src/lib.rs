//! stub
pub mod context;
pub use context::{GpuContext, GpuError};
