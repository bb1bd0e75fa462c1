//! The render's statistics: [`RenderStats`] for the summary and the counters each tile (or
//! group of tiles) keeps while one thread works it, added up at the end. Counting must not
//! change what is rendered.

use shadenet_runtime::BatchTimes;
use std::sync::Mutex;
use std::sync::atomic::AtomicU64;
use std::time::Duration;

/// What the render did, for the end summary.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct RenderStats {
    /// Building the BVH.
    pub bvh_time: Duration,
    /// Specializing and compiling materials.
    pub compile_time: Duration,
    /// Rendering the tiles.
    pub render_time: Duration,
    /// Triangles in the BVH.
    pub triangles: usize,
    /// Distinct specialized shaders compiled (materials × masks, and overrides).
    pub shaders: usize,
    /// Rays traced: camera, secondary, shadow and occlusion.
    pub rays: u64,
    /// Shading calls (materials and overrides).
    pub shading_calls: u64,
    /// Non-finite values the output guard replaced with 0.
    pub nonfinite: u64,
    /// Deferred mode: [`Shader::shade_many`] calls made (0 in the immediate mode).
    pub batches: u64,
    /// Deferred mode: fragments shaded through those calls (camera hits; every shading call
    /// of a camera hit, overrides included).
    pub batched_fragments: u64,
    /// Deferred mode: the largest batch, in fragments.
    pub largest_batch: u64,
    /// Deferred mode: where the batch calls' time went, summed over all calls (and threads:
    /// groups of tiles shade in parallel). A CPU back end reports only `kernels`.
    pub batch_times: BatchTimes,
}

/// Counters of one tile, or one group of tiles in the deferred mode (one thread works it, so
/// they are never contended).
#[derive(Default)]
pub(super) struct TileStats {
    pub(super) rays: AtomicU64,
    pub(super) shading_calls: AtomicU64,
    pub(super) nonfinite: AtomicU64,
    pub(super) batches: AtomicU64,
    pub(super) batched: AtomicU64,
    pub(super) largest: AtomicU64,
    pub(super) times: Mutex<BatchTimes>,
}
