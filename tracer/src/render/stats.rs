//! The render's statistics: [`RenderStats`] for the summary and the counters each tile (or
//! group of tiles) keeps while one thread works it, added up at the end. Counting must not
//! change what is rendered.

use shadenet_runtime::BatchTimes;
use std::sync::Mutex;
use std::sync::atomic::{AtomicU64, Ordering};
use std::time::{Duration, Instant};

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
    /// Rays traced: camera, secondary, shadow and occlusion (the sum of the next three).
    pub rays: u64,
    /// Camera rays traced.
    pub camera_rays: u64,
    /// Shadow rays (`occluded`) and ambient-occlusion rays traced: occlusion queries.
    pub shadow_rays: u64,
    /// Secondary rays (`trace`: reflection, refraction, diffuse) traced.
    pub secondary_rays: u64,
    /// Where the tiles' time went, per stage, summed over threads.
    pub stages: StageTimes,
    /// Shading calls (materials and overrides).
    pub shading_calls: u64,
    /// Non-finite values the output guard replaced with 0.
    pub nonfinite: u64,
    /// Loop executions the iteration limit stopped (a shader loop that would not end;
    /// `shadenet_graph::ir::LOOP_ITERATION_LIMIT`).
    pub loop_limits: u64,
    /// Deferred mode: [`crate::shader::Shader::shade_many`] calls made (0 in the immediate mode).
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
    pub(super) camera_rays: AtomicU64,
    pub(super) shadow_rays: AtomicU64,
    pub(super) secondary_rays: AtomicU64,
    /// Nanoseconds per stage: sample, trace (camera rays), shade, film, then the sampled
    /// estimates of shadow and secondary traversal inside shading (see [`TIME_EVERY`]).
    pub(super) stage_ns: [AtomicU64; 6],
    pub(super) shading_calls: AtomicU64,
    pub(super) nonfinite: AtomicU64,
    pub(super) batches: AtomicU64,
    pub(super) batched: AtomicU64,
    pub(super) largest: AtomicU64,
    pub(super) times: Mutex<BatchTimes>,
}

/// The time of a render's stages, summed over threads. Shading calls trace shadow and
/// secondary rays from inside (the scene services), so `shade` includes that traversal;
/// `shadow_trace` and `secondary_trace` estimate how much of it was traversal by timing one
/// query in [`TIME_EVERY`] (timing each would cost more than a shadow ray).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct StageTimes {
    /// Generating camera samples and rays.
    pub sample: Duration,
    /// Tracing camera rays and preparing their hits.
    pub trace: Duration,
    /// Shading camera hits (including the shadow and secondary rays shaders trace).
    pub shade: Duration,
    /// Adding samples into pixels (and, in the deferred mode, applying batch outputs).
    pub film: Duration,
    /// Estimated traversal time of shadow and occlusion rays (part of `shade`).
    pub shadow_trace: Duration,
    /// Estimated traversal time of secondary rays (part of `shade`).
    pub secondary_trace: Duration,
}

/// One occlusion query and one secondary ray in this many is timed (their time scaled by it).
pub(super) const TIME_EVERY: u64 = 32;

/// A stage of the tile loop, the index of its counter in `TileStats::stage_ns`.
#[derive(Clone, Copy, Debug)]
pub(super) enum Stage {
    Sample = 0,
    Trace = 1,
    Shade = 2,
    Film = 3,
    ShadowTrace = 4,
    SecondaryTrace = 5,
}

impl TileStats {
    /// Adds the time since `since` to a stage and returns now (the next stage's start).
    pub(super) fn lap(&self, stage: Stage, since: Instant) -> Instant {
        let now = Instant::now();
        self.add_ns(stage, (now - since).as_nanos() as u64);
        now
    }

    /// Adds nanoseconds to a stage.
    pub(super) fn add_ns(&self, stage: Stage, ns: u64) {
        self.stage_ns[stage as usize].fetch_add(ns, Ordering::Relaxed);
    }

    /// Runs `f`, timing it (scaled by [`TIME_EVERY`]) when `count` is a multiple of
    /// [`TIME_EVERY`]: a sampled estimate of a stage nested inside another.
    pub(super) fn sampled<T>(&self, stage: Stage, count: u64, f: impl FnOnce() -> T) -> T {
        if !count.is_multiple_of(TIME_EVERY) {
            return f();
        }
        let t = Instant::now();
        let r = f();
        self.add_ns(stage, t.elapsed().as_nanos() as u64 * TIME_EVERY);
        r
    }

    /// Adds this tile's counters to the render's statistics.
    pub(super) fn add_to(&self, stats: &mut RenderStats) {
        let get = |a: &AtomicU64| a.load(Ordering::Relaxed);
        let (c, s, r) = (
            get(&self.camera_rays),
            get(&self.shadow_rays),
            get(&self.secondary_rays),
        );
        stats.camera_rays += c;
        stats.shadow_rays += s;
        stats.secondary_rays += r;
        stats.rays += c + s + r;
        stats.shading_calls += get(&self.shading_calls);
        stats.nonfinite += get(&self.nonfinite);
        stats.batches += get(&self.batches);
        stats.batched_fragments += get(&self.batched);
        stats.largest_batch = stats.largest_batch.max(get(&self.largest));
        let t = self
            .times
            .lock()
            .map(|t| *t)
            .unwrap_or_else(|e| *e.into_inner());
        stats.batch_times.add(&t);
        let ns = |k: Stage| Duration::from_nanos(get(&self.stage_ns[k as usize]));
        let st = &mut stats.stages;
        st.sample += ns(Stage::Sample);
        st.trace += ns(Stage::Trace);
        st.shade += ns(Stage::Shade);
        st.film += ns(Stage::Film);
        st.shadow_trace += ns(Stage::ShadowTrace);
        st.secondary_trace += ns(Stage::SecondaryTrace);
    }
}
