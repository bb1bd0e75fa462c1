//! The ABI between compiled code and Rust: the call context, the entry-point signatures and
//! the helper functions compiled code calls.
//!
//! Every entry point takes a [`CallCtx`] (the environment, the material's textures and
//! uniform block, the component mask and the light count; the shading entries also add
//! the loops they stopped at the iteration limit to it). Helpers are `extern "C"` Rust
//! functions registered as symbols of the JIT module; each calls the very function the
//! interpreter calls (`shadenet_graph::ops`, `ops::noise`, `runtime::lights::sample`,
//! `TextureSet` sampling, `runtime::interp::transform`'s matrices), so compiled code and
//! the interpreter agree bit for bit on everything a helper computes.
//!
//! Print ops (`printf`, `warning`, `error`) call the message helpers of `abi/print.rs`.
//!
//! Two helper conventions:
//! - **math**: `extern "C" fn(f32) -> f32` or `fn(f32, f32) -> f32` (sin, pow, …) for the
//!   scalar entry; the batch entry calls a four-lane form once per packet,
//!   `unsafe extern "C" fn(args, out)` with the arguments' lanes in a stack slot (structure
//!   of arrays) and the result's four lanes written to another (`ops::math_x4`: SIMD with
//!   the scalar bits), or — with `SHADENET_SIMD=lanes`, to measure against — the scalar
//!   helper once per lane;
//! - **memory**: `unsafe extern "C" fn(ctx, imm, args, out)`: the arguments are floats (ints
//!   as their bits) in a stack slot, the results are written to another; `imm` is an
//!   immediate (a texture or light index). Batch (`_x4`) versions take structure-of-arrays
//!   slots, four lanes per component, and loop over the lanes in Rust — or, where a helper
//!   has a four-lane form, call that once per packet (`=> name` in the table below:
//!   `noise3`, `fbm3`: `ops::noise_x4`, SIMD with the scalar bits; `cellnoise3`,
//!   `rgb_to_hsv`, `hsv_to_rgb`: `ops::cell_hsv_x4`, the same; the OSL/MaterialX noises
//!   (`osl_*`, `mx_*`): `ops::osl_noise_x4`, the same; `=> ctx name` where the
//!   form needs the context: `light` and `texture` find their light or texture once for the
//!   four lanes, `visible` answers four lanes at once without a scene).

mod print;

pub use print::{PrintTable, sn_print, sn_print_x4};
use shadenet_graph::ir::{ProbeField, Sampling};
use shadenet_graph::ops::osl_noise_x4 as x4;
use shadenet_graph::ops::{self, cell_hsv_x4, math_x4, noise, noise_x4, osl_noise, osl_simplex};
use shadenet_runtime::ctx::{Fragment, SceneServices, ShadeEnv};
use shadenet_runtime::interp;
use shadenet_runtime::lights;
use shadenet_runtime::texture::TextureSet;
use shadenet_runtime::{FragmentX4, LANES, fragment_services};
use std::cell::Cell;

/// What every compiled entry point reads besides the fragment: `#[repr(C)]`, built by the
/// material for each call (a few stores). Compiled code writes only `first`, `lanes`
/// (batch entry) and `loop_limits`.
#[repr(C)]
#[derive(Clone, Copy, Debug)]
pub struct CallCtx {
    /// The shading environment (lights, transforms); read only by helpers.
    pub env: *const ShadeEnv,
    /// The material's textures; read only by the texture helper.
    pub textures: *const TextureSet,
    /// The material's uniform block: parameter values, then prelude values (one 32-bit
    /// slot per component).
    pub uniforms: *const u32,
    /// Active render components.
    pub mask: u32,
    /// [`light_samples`]: the illuminance loop's trip count.
    pub n_lights: u32,
    /// The renderer's services: the [`shadenet_runtime::ShadeCtx::scene`] field of a
    /// `Material::shade` call (whichever entry runs it: a material built without a scalar
    /// entry shades one lane of the batch entry), the batch's services of a
    /// `Material::shade_many` call with a scene, or null (`shade_x4` calls, scene-less
    /// batches and the prelude); read only by the scene helpers (`sn_trace`,
    /// `sn_occlusion`, `sn_visible`) through [`CallCtx::scene`] and
    /// [`CallCtx::lane_scene`].
    pub scene: *const SceneRef,
    /// The answers of `light.visible` so far in this call ([`VisibilityMemo`]), or null (no
    /// memo: every question goes to the scene).
    pub visibility: *const VisibilityMemo,
    /// Batch calls: one memo per lane (each keyed by its fragment), or null.
    pub visibility_x4: *const [VisibilityMemo; LANES],
    /// Batch calls: the index in the batch of the current packet's first fragment (the
    /// compiled loop stores it before each packet; the caller sets the first packet's).
    pub first: u32,
    /// Batch calls: the current packet's lanes that hold fragments (1 to 4; the compiled loop
    /// stores it). Padding lanes never ask the scene.
    pub lanes: u32,
    /// 1 when `scene` is a whole batch's services (lane `l` asks
    /// `fragment_services(scene, first + l)`), 0 when it is one fragment's own.
    pub batch_scene: u32,
    /// Loop executions that stopped at
    /// [`LOOP_ITERATION_LIMIT`](shadenet_graph::ir::LOOP_ITERATION_LIMIT) with their
    /// condition still true: the caller zeroes it, the compiled code adds to it (the batch
    /// entry: one per stopped lane below its `n`), the caller reads it after the call.
    pub loop_limits: u32,
    /// The material's print ops ([`PrintTable`]), read by the message helpers; null where
    /// nothing prints (the prelude).
    pub prints: *const PrintTable,
}

/// Light samples per call whose visibility [`VisibilityMemo`] remembers; later sample slots
/// ask the scene every time.
pub const MEMO_SLOTS: usize = 64;

/// The `light.visible` answers of one shading call, by light-sample slot, for one point:
/// every light loop at the point asks the scene once per sample, as the interpreter does
/// (the scene's answers are pure, so this saves shadow rays and changes no result). A
/// question at another point forgets the answers.
pub struct VisibilityMemo {
    /// The fragment (its index in a batch; 0 for a single call) and point the answers are
    /// for.
    at: Cell<Option<(u32, [u32; 3])>>,
    /// 0 not asked, 1 open, 2 blocked.
    answers: [Cell<u8>; MEMO_SLOTS],
}

impl Default for VisibilityMemo {
    fn default() -> Self {
        VisibilityMemo {
            at: Cell::new(None),
            answers: std::array::from_fn(|_| Cell::new(0)),
        }
    }
}

impl VisibilityMemo {
    /// The answer for sample `slot` of fragment `frag` seen from `p`, asking `ask` the first
    /// time.
    fn get_or_ask(&self, slot: u32, frag: u32, p: [f32; 3], ask: impl FnOnce() -> bool) -> bool {
        let Some(cell) = self.answers.get(slot as usize) else {
            return ask();
        };
        let at = Some((frag, p.map(f32::to_bits)));
        if self.at.get() != at {
            self.at.set(at);
            for a in &self.answers {
                a.set(0);
            }
        }
        match cell.get() {
            1 => true,
            2 => false,
            _ => {
                let open = ask();
                cell.set(if open { 1 } else { 2 });
                open
            }
        }
    }
}

/// The pointee of [`CallCtx::scene`]: the shading context's `scene` field (its real lifetime
/// is the call's).
pub type SceneRef = Option<&'static dyn SceneServices>;

impl CallCtx {
    /// This call's visibility memo, if any.
    pub fn visibility(&self) -> Option<&VisibilityMemo> {
        // SAFETY: a non-null `visibility` points at a memo on the stack of the running call.
        unsafe { self.visibility.as_ref() }
    }

    /// The services lane `lane` of a batch call asks: the fragment's own (see
    /// [`CallCtx::batch_scene`]); `None` without a scene or for a padding lane.
    pub fn lane_scene(&self, lane: usize) -> Option<&dyn SceneServices> {
        if lane as u32 >= self.lanes {
            return None;
        }
        let scene = self.scene()?;
        if self.batch_scene == 0 {
            return Some(scene);
        }
        fragment_services(Some(scene), self.first as usize + lane)
    }

    /// The scene this call may ask, if any.
    pub fn scene(&self) -> Option<&dyn SceneServices> {
        if self.scene.is_null() {
            return None;
        }
        // SAFETY: a non-null `scene` points at the `ShadeCtx::scene` of the running call,
        // which outlives it.
        unsafe { *self.scene }
    }
}

/// Byte offset of a [`CallCtx`] field, for loads from compiled code.
pub mod ctx_offset {
    use super::CallCtx;
    use std::mem::offset_of;
    /// `env`.
    pub const ENV: i32 = offset_of!(CallCtx, env) as i32;
    /// `uniforms`.
    pub const UNIFORMS: i32 = offset_of!(CallCtx, uniforms) as i32;
    /// `mask`.
    pub const MASK: i32 = offset_of!(CallCtx, mask) as i32;
    /// `n_lights`.
    pub const N_LIGHTS: i32 = offset_of!(CallCtx, n_lights) as i32;
    /// `first`.
    pub const FIRST: i32 = offset_of!(CallCtx, first) as i32;
    /// `lanes`.
    pub const LANES: i32 = offset_of!(CallCtx, lanes) as i32;
    /// `loop_limits`.
    pub const LOOP_LIMITS: i32 = offset_of!(CallCtx, loop_limits) as i32;
}

/// The scalar entry: shades one fragment into `out` (the interpreter's output layout) and
/// returns the non-finite floats the guard replaced. It adds the loops it stopped at the
/// iteration limit to the context's `loop_limits` (hence `*mut`).
pub type ScalarFn = unsafe extern "C" fn(*mut CallCtx, *const Fragment, *mut f32) -> u32;

/// The batch entry: shades `n` fragments (the last argument) in consecutive four-lane
/// packets into `out` in the packets' layout (`shadenet_runtime::packets`: per packet,
/// float `k` of lane `l` at `k * 4 + l`), walking the packets in one call; only the first
/// `n` lanes' non-finite floats are counted. At least one packet is shaded (`n = 0` shades
/// the first packet and counts nothing). The entry writes the context's `first` and
/// `lanes` before each packet and adds the first `n` lanes' loops stopped at the iteration
/// limit to `loop_limits` (hence `*mut`).
pub type BatchFn = unsafe extern "C" fn(*mut CallCtx, *const FragmentX4, *mut f32, u32) -> u32;

/// The prelude entry: evaluates the prelude once and writes its values into the uniform
/// block (the second argument; the same block `CallCtx::uniforms` points to).
pub type PreludeFn = unsafe extern "C" fn(*const CallCtx, *mut u32);

/// A memory-convention helper (see the module documentation).
pub type MemHelper = unsafe extern "C" fn(*const CallCtx, u32, *const f32, *mut f32);

// ---- math helpers: exactly the interpreter's f32 op semantics (`ops::math`'s functions) ----

extern "C" fn sn_exp(x: f32) -> f32 {
    ops::exp(x)
}
extern "C" fn sn_log(x: f32) -> f32 {
    ops::log(x)
}
extern "C" fn sn_sin(x: f32) -> f32 {
    ops::sin(x)
}
extern "C" fn sn_cos(x: f32) -> f32 {
    ops::cos(x)
}
extern "C" fn sn_tan(x: f32) -> f32 {
    ops::tan(x)
}
extern "C" fn sn_asin(x: f32) -> f32 {
    ops::asin(x)
}
extern "C" fn sn_acos(x: f32) -> f32 {
    ops::acos(x)
}
extern "C" fn sn_pow(a: f32, b: f32) -> f32 {
    ops::pow(a, b)
}
extern "C" fn sn_atan2(a: f32, b: f32) -> f32 {
    ops::atan2(a, b)
}

/// A four-lane math helper (see the module documentation): `args` holds the arguments'
/// lanes, four floats per argument; `out` receives the result's four lanes.
pub type MathX4 = unsafe extern "C" fn(*const f32, *mut f32);

macro_rules! math_x4_helpers {
    ($($name:ident: $op:ident / $arity:tt),* $(,)?) => {
        $(
            unsafe extern "C" fn $name(a: *const f32, o: *mut f32) {
                // SAFETY: compiled code passes `4 * arity` readable and 4 writable floats.
                unsafe {
                    let a = &*(a as *const [[f32; LANES]; $arity]);
                    *(o as *mut [f32; LANES]) = math_x4_helpers!(@call $op, a, $arity);
                }
            }
        )*
    };
    (@call $op:ident, $a:ident, 1) => { (math_x4::chosen().$op)($a[0]) };
    (@call $op:ident, $a:ident, 2) => { (math_x4::chosen().$op)($a[0], $a[1]) };
}

math_x4_helpers! {
    sn_exp_x4: exp / 1,
    sn_log_x4: log / 1,
    sn_sin_x4: sin / 1,
    sn_cos_x4: cos / 1,
    sn_tan_x4: tan / 1,
    sn_asin_x4: asin / 1,
    sn_acos_x4: acos / 1,
    sn_pow_x4: pow / 2,
    sn_atan2_x4: atan2 / 2,
}

/// A math helper: symbol name, arity (1 or 2), and the scalar and four-lane functions.
pub struct MathHelper {
    /// Symbol name of the scalar function (`_x4` is appended for the four-lane one).
    pub name: &'static str,
    /// 1 or 2 f32 arguments; one f32 result.
    pub arity: usize,
    /// The scalar function.
    pub ptr: *const u8,
    /// The four-lane function ([`MathX4`]).
    pub x4: *const u8,
}

/// The math helpers, by the op they implement.
pub fn math_helper(name: &str) -> Option<MathHelper> {
    let (arity, ptr, x4): (usize, *const u8, MathX4) = match name {
        "sn_exp" => (1, sn_exp as *const u8, sn_exp_x4),
        "sn_log" => (1, sn_log as *const u8, sn_log_x4),
        "sn_sin" => (1, sn_sin as *const u8, sn_sin_x4),
        "sn_cos" => (1, sn_cos as *const u8, sn_cos_x4),
        "sn_tan" => (1, sn_tan as *const u8, sn_tan_x4),
        "sn_asin" => (1, sn_asin as *const u8, sn_asin_x4),
        "sn_acos" => (1, sn_acos as *const u8, sn_acos_x4),
        "sn_pow" => (2, sn_pow as *const u8, sn_pow_x4),
        "sn_atan2" => (2, sn_atan2 as *const u8, sn_atan2_x4),
        _ => return None,
    };
    Some(MathHelper {
        name: MATH_NAMES.iter().find(|n| **n == name)?,
        arity,
        ptr,
        x4: x4 as *const u8,
    })
}

/// Whether the batch entry calls the four-lane math helpers (else the scalar ones once per
/// lane: `SHADENET_SIMD=lanes`).
pub fn math_x4_enabled() -> bool {
    math_x4::Path::chosen() != math_x4::Path::Lanes
}

/// Every math helper's symbol name.
pub const MATH_NAMES: &[&str] = &[
    "sn_exp", "sn_log", "sn_sin", "sn_cos", "sn_tan", "sn_asin", "sn_acos", "sn_pow", "sn_atan2",
];

// ---- memory helpers ----

/// A scalar memory helper body: `(ctx, imm, args, out)` on slices.
type Body = fn(&CallCtx, u32, &[f32], &mut [f32]);

fn noise2(_: &CallCtx, _: u32, a: &[f32], o: &mut [f32]) {
    o[0] = noise::noise2(a[0], a[1]);
}
fn noise3(_: &CallCtx, _: u32, a: &[f32], o: &mut [f32]) {
    o[0] = noise::noise3([a[0], a[1], a[2]]);
}
fn fbm3(_: &CallCtx, _: u32, a: &[f32], o: &mut [f32]) {
    o[0] = noise::fbm3([a[0], a[1], a[2]], a[3].to_bits() as i32, a[4], a[5]);
}
/// The batch form of `noise3`: four lanes at once (`ops::noise_x4`, the scalar bits).
fn noise3_x4(a: &[[f32; LANES]; 3], o: &mut [[f32; LANES]; 1]) {
    o[0] = noise_x4::noise3_x4(*a);
}
/// The batch form of `fbm3`: four lanes at once, per-lane octaves, lacunarity and gain.
fn fbm3_x4(a: &[[f32; LANES]; 6], o: &mut [[f32; LANES]; 1]) {
    let octaves = a[3].map(|x| x.to_bits() as i32);
    o[0] = noise_x4::fbm3_x4([a[0], a[1], a[2]], octaves, a[4], a[5]);
}
fn cellnoise3(_: &CallCtx, _: u32, a: &[f32], o: &mut [f32]) {
    o[0] = noise::cellnoise3([a[0], a[1], a[2]]);
}
/// The batch form of `cellnoise3` (`ops::cell_hsv_x4`, the scalar bits).
fn cellnoise3_x4(a: &[[f32; LANES]; 3], o: &mut [[f32; LANES]; 1]) {
    o[0] = cell_hsv_x4::cellnoise3_x4(*a);
}
// OSL/MaterialX noise (`ops::osl_noise`): ints arrive as their bits.
fn int(x: f32) -> i32 {
    x.to_bits() as i32
}
fn osl_perlin2(_: &CallCtx, _: u32, a: &[f32], o: &mut [f32]) {
    o[0] = osl_noise::perlin2([a[0], a[1]]);
}
fn osl_perlin3(_: &CallCtx, _: u32, a: &[f32], o: &mut [f32]) {
    o[0] = osl_noise::perlin3([a[0], a[1], a[2]]);
}
fn osl_vperlin2(_: &CallCtx, _: u32, a: &[f32], o: &mut [f32]) {
    o.copy_from_slice(&osl_noise::vperlin2([a[0], a[1]]));
}
fn osl_vperlin3(_: &CallCtx, _: u32, a: &[f32], o: &mut [f32]) {
    o.copy_from_slice(&osl_noise::vperlin3([a[0], a[1], a[2]]));
}
fn osl_cell2(_: &CallCtx, _: u32, a: &[f32], o: &mut [f32]) {
    o[0] = osl_noise::cell2([a[0], a[1]]);
}
fn osl_cell3(_: &CallCtx, _: u32, a: &[f32], o: &mut [f32]) {
    o[0] = osl_noise::cell3([a[0], a[1], a[2]]);
}
fn osl_vcell2(_: &CallCtx, _: u32, a: &[f32], o: &mut [f32]) {
    o.copy_from_slice(&osl_noise::vcell2([a[0], a[1]]));
}
fn osl_vcell3(_: &CallCtx, _: u32, a: &[f32], o: &mut [f32]) {
    o.copy_from_slice(&osl_noise::vcell3([a[0], a[1], a[2]]));
}
fn osl_cell1(_: &CallCtx, _: u32, a: &[f32], o: &mut [f32]) {
    o[0] = osl_noise::cell1(a[0]);
}
fn osl_cell4(_: &CallCtx, _: u32, a: &[f32], o: &mut [f32]) {
    o[0] = osl_noise::cell4([a[0], a[1], a[2]], a[3]);
}
fn osl_vcell1(_: &CallCtx, _: u32, a: &[f32], o: &mut [f32]) {
    o.copy_from_slice(&osl_noise::vcell1(a[0]));
}
fn osl_vcell4(_: &CallCtx, _: u32, a: &[f32], o: &mut [f32]) {
    o.copy_from_slice(&osl_noise::vcell4([a[0], a[1], a[2]], a[3]));
}
fn osl_hash1(_: &CallCtx, _: u32, a: &[f32], o: &mut [f32]) {
    o[0] = osl_noise::hash1(a[0]);
}
fn osl_hash2(_: &CallCtx, _: u32, a: &[f32], o: &mut [f32]) {
    o[0] = osl_noise::hash2([a[0], a[1]]);
}
fn osl_hash3(_: &CallCtx, _: u32, a: &[f32], o: &mut [f32]) {
    o[0] = osl_noise::hash3([a[0], a[1], a[2]]);
}
fn osl_hash4(_: &CallCtx, _: u32, a: &[f32], o: &mut [f32]) {
    o[0] = osl_noise::hash4([a[0], a[1], a[2]], a[3]);
}
fn osl_vhash1(_: &CallCtx, _: u32, a: &[f32], o: &mut [f32]) {
    o.copy_from_slice(&osl_noise::vhash1(a[0]));
}
fn osl_vhash2(_: &CallCtx, _: u32, a: &[f32], o: &mut [f32]) {
    o.copy_from_slice(&osl_noise::vhash2([a[0], a[1]]));
}
fn osl_vhash3(_: &CallCtx, _: u32, a: &[f32], o: &mut [f32]) {
    o.copy_from_slice(&osl_noise::vhash3([a[0], a[1], a[2]]));
}
fn osl_vhash4(_: &CallCtx, _: u32, a: &[f32], o: &mut [f32]) {
    o.copy_from_slice(&osl_noise::vhash4([a[0], a[1], a[2]], a[3]));
}
fn osl_pperlin1(_: &CallCtx, _: u32, a: &[f32], o: &mut [f32]) {
    o[0] = osl_noise::pperlin1(a[0], a[1]);
}
fn osl_pperlin2(_: &CallCtx, _: u32, a: &[f32], o: &mut [f32]) {
    o[0] = osl_noise::pperlin2([a[0], a[1]], [a[2], a[3]]);
}
fn osl_pperlin3(_: &CallCtx, _: u32, a: &[f32], o: &mut [f32]) {
    o[0] = osl_noise::pperlin3([a[0], a[1], a[2]], [a[3], a[4], a[5]]);
}
fn osl_pperlin4(_: &CallCtx, _: u32, a: &[f32], o: &mut [f32]) {
    o[0] = osl_noise::pperlin4([a[0], a[1], a[2]], a[3], [a[4], a[5], a[6]], a[7]);
}
fn osl_vpperlin1(_: &CallCtx, _: u32, a: &[f32], o: &mut [f32]) {
    o.copy_from_slice(&osl_noise::vpperlin1(a[0], a[1]));
}
fn osl_vpperlin2(_: &CallCtx, _: u32, a: &[f32], o: &mut [f32]) {
    o.copy_from_slice(&osl_noise::vpperlin2([a[0], a[1]], [a[2], a[3]]));
}
fn osl_vpperlin3(_: &CallCtx, _: u32, a: &[f32], o: &mut [f32]) {
    o.copy_from_slice(&osl_noise::vpperlin3(
        [a[0], a[1], a[2]],
        [a[3], a[4], a[5]],
    ));
}
fn osl_vpperlin4(_: &CallCtx, _: u32, a: &[f32], o: &mut [f32]) {
    let (p, pp) = ([a[0], a[1], a[2]], [a[4], a[5], a[6]]);
    o.copy_from_slice(&osl_noise::vpperlin4(p, a[3], pp, a[7]));
}
fn osl_simplex1(_: &CallCtx, _: u32, a: &[f32], o: &mut [f32]) {
    o[0] = osl_simplex::simplex1(a[0], 0);
}
fn osl_simplex2(_: &CallCtx, _: u32, a: &[f32], o: &mut [f32]) {
    o[0] = osl_simplex::simplex2([a[0], a[1]], 0);
}
fn osl_simplex3(_: &CallCtx, _: u32, a: &[f32], o: &mut [f32]) {
    o[0] = osl_simplex::simplex3([a[0], a[1], a[2]], 0);
}
fn osl_simplex4(_: &CallCtx, _: u32, a: &[f32], o: &mut [f32]) {
    o[0] = osl_simplex::simplex4([a[0], a[1], a[2]], a[3], 0);
}
fn osl_vsimplex1(_: &CallCtx, _: u32, a: &[f32], o: &mut [f32]) {
    o.copy_from_slice(&osl_simplex::vsimplex1(a[0]));
}
fn osl_vsimplex2(_: &CallCtx, _: u32, a: &[f32], o: &mut [f32]) {
    o.copy_from_slice(&osl_simplex::vsimplex2([a[0], a[1]]));
}
fn osl_vsimplex3(_: &CallCtx, _: u32, a: &[f32], o: &mut [f32]) {
    o.copy_from_slice(&osl_simplex::vsimplex3([a[0], a[1], a[2]]));
}
fn osl_vsimplex4(_: &CallCtx, _: u32, a: &[f32], o: &mut [f32]) {
    o.copy_from_slice(&osl_simplex::vsimplex4([a[0], a[1], a[2]], a[3]));
}
fn osl_perlin1(_: &CallCtx, _: u32, a: &[f32], o: &mut [f32]) {
    o[0] = osl_noise::perlin1(a[0]);
}
fn osl_perlin4(_: &CallCtx, _: u32, a: &[f32], o: &mut [f32]) {
    o[0] = osl_noise::perlin4([a[0], a[1], a[2]], a[3]);
}
fn osl_vperlin1(_: &CallCtx, _: u32, a: &[f32], o: &mut [f32]) {
    o.copy_from_slice(&osl_noise::vperlin1(a[0]));
}
fn osl_vperlin4(_: &CallCtx, _: u32, a: &[f32], o: &mut [f32]) {
    o.copy_from_slice(&osl_noise::vperlin4([a[0], a[1], a[2]], a[3]));
}
fn mx_fractal2(_: &CallCtx, _: u32, a: &[f32], o: &mut [f32]) {
    o[0] = osl_noise::fractal2([a[0], a[1]], int(a[2]), a[3], a[4]);
}
fn mx_fractal3(_: &CallCtx, _: u32, a: &[f32], o: &mut [f32]) {
    o[0] = osl_noise::fractal3([a[0], a[1], a[2]], int(a[3]), a[4], a[5]);
}
fn mx_vfractal2(_: &CallCtx, _: u32, a: &[f32], o: &mut [f32]) {
    o.copy_from_slice(&osl_noise::vfractal2([a[0], a[1]], int(a[2]), a[3], a[4]));
}
fn mx_vfractal3(_: &CallCtx, _: u32, a: &[f32], o: &mut [f32]) {
    let p = [a[0], a[1], a[2]];
    o.copy_from_slice(&osl_noise::vfractal3(p, int(a[3]), a[4], a[5]));
}
fn mx_worley2(_: &CallCtx, _: u32, a: &[f32], o: &mut [f32]) {
    o[0] = osl_noise::worley2([a[0], a[1]], a[2], int(a[3]), int(a[4]));
}
fn mx_worley2_v2(_: &CallCtx, _: u32, a: &[f32], o: &mut [f32]) {
    o.copy_from_slice(&osl_noise::worley2_v2(
        [a[0], a[1]],
        a[2],
        int(a[3]),
        int(a[4]),
    ));
}
fn mx_worley2_v3(_: &CallCtx, _: u32, a: &[f32], o: &mut [f32]) {
    o.copy_from_slice(&osl_noise::worley2_v3(
        [a[0], a[1]],
        a[2],
        int(a[3]),
        int(a[4]),
    ));
}
fn mx_worley3(_: &CallCtx, _: u32, a: &[f32], o: &mut [f32]) {
    o[0] = osl_noise::worley3([a[0], a[1], a[2]], a[3], int(a[4]), int(a[5]));
}
fn mx_worley3_v2(_: &CallCtx, _: u32, a: &[f32], o: &mut [f32]) {
    let p = [a[0], a[1], a[2]];
    o.copy_from_slice(&osl_noise::worley3_v2(p, a[3], int(a[4]), int(a[5])));
}
fn mx_worley3_v3(_: &CallCtx, _: u32, a: &[f32], o: &mut [f32]) {
    let p = [a[0], a[1], a[2]];
    o.copy_from_slice(&osl_noise::worley3_v3(p, a[3], int(a[4]), int(a[5])));
}
/// Batch forms of the OSL/MaterialX noises: four lanes at once (`ops::osl_noise_x4`, the
/// scalar bits); `name(args: A) -> O expr` writes `expr`, the `O` results' lanes.
macro_rules! osl_x4 {
    ($($name:ident($a:ident: $args:literal) -> $outs:literal $e:expr;)*) => {$(
        fn $name($a: &[[f32; LANES]; $args], o: &mut [[f32; LANES]; $outs]) {
            *o = $e;
        }
    )*};
}
osl_x4! {
    osl_perlin2_x4(a: 2) -> 1 [x4::perlin2_x4(*a)];
    osl_perlin3_x4(a: 3) -> 1 [x4::perlin3_x4(*a)];
    osl_vperlin2_x4(a: 2) -> 3 x4::vperlin2_x4(*a);
    osl_vperlin3_x4(a: 3) -> 3 x4::vperlin3_x4(*a);
    osl_cell2_x4(a: 2) -> 1 [x4::cell2_x4(*a)];
    osl_cell3_x4(a: 3) -> 1 [x4::cell3_x4(*a)];
    osl_vcell2_x4(a: 2) -> 3 x4::vcell2_x4(*a);
    osl_vcell3_x4(a: 3) -> 3 x4::vcell3_x4(*a);
    mx_fractal2_x4(a: 5) -> 1 [x4::fractal2_x4(p2(a), ints(a[2]), a[3], a[4])];
    mx_fractal3_x4(a: 6) -> 1 [x4::fractal3_x4(p3(a), ints(a[3]), a[4], a[5])];
    mx_vfractal2_x4(a: 5) -> 3 x4::vfractal2_x4(p2(a), ints(a[2]), a[3], a[4]);
    mx_vfractal3_x4(a: 6) -> 3 x4::vfractal3_x4(p3(a), ints(a[3]), a[4], a[5]);
    mx_worley2_x4(a: 5) -> 1 [x4::worley2_x4(p2(a), a[2], ints(a[3]), ints(a[4]))];
    mx_worley2_v2_x4(a: 5) -> 2 x4::worley2_v2_x4(p2(a), a[2], ints(a[3]), ints(a[4]));
    mx_worley2_v3_x4(a: 5) -> 3 x4::worley2_v3_x4(p2(a), a[2], ints(a[3]), ints(a[4]));
    mx_worley3_x4(a: 6) -> 1 [x4::worley3_x4(p3(a), a[3], ints(a[4]), ints(a[5]))];
    mx_worley3_v2_x4(a: 6) -> 2 x4::worley3_v2_x4(p3(a), a[3], ints(a[4]), ints(a[5]));
    mx_worley3_v3_x4(a: 6) -> 3 x4::worley3_v3_x4(p3(a), a[3], ints(a[4]), ints(a[5]));
}
/// The first two argument slots of a batch call (a 2D point's lanes).
fn p2<const N: usize>(a: &[[f32; LANES]; N]) -> [[f32; LANES]; 2] {
    [a[0], a[1]]
}
/// The first three argument slots of a batch call (a 3D point's lanes).
fn p3<const N: usize>(a: &[[f32; LANES]; N]) -> [[f32; LANES]; 3] {
    [a[0], a[1], a[2]]
}
/// An int argument's lanes (ints arrive as their bits).
fn ints(x: [f32; LANES]) -> [i32; LANES] {
    x.map(int)
}
fn rgb_to_hsv(_: &CallCtx, _: u32, a: &[f32], o: &mut [f32]) {
    o.copy_from_slice(&ops::rgb_to_hsv([a[0], a[1], a[2]]));
}
fn ggx_albedo(_: &CallCtx, _: u32, a: &[f32], o: &mut [f32]) {
    o.copy_from_slice(&ops::ggx_albedo::ggx_albedo(a[0], a[1]));
}
fn dielectric_albedo(_: &CallCtx, _: u32, a: &[f32], o: &mut [f32]) {
    o[0] = ops::dielectric_albedo::dielectric_albedo(a[0], a[1], a[2]);
}
fn sheen_albedo(_: &CallCtx, _: u32, a: &[f32], o: &mut [f32]) {
    o.copy_from_slice(&ops::sheen_albedo::sheen_albedo(a[0], a[1]));
}
fn hsv_to_rgb(_: &CallCtx, _: u32, a: &[f32], o: &mut [f32]) {
    o.copy_from_slice(&ops::hsv_to_rgb([a[0], a[1], a[2]]));
}
/// The batch form of `rgb_to_hsv` (`ops::cell_hsv_x4`, the scalar bits).
fn rgb_to_hsv_x4(a: &[[f32; LANES]; 3], o: &mut [[f32; LANES]; 3]) {
    *o = cell_hsv_x4::rgb_to_hsv_x4(*a);
}
/// The batch form of `hsv_to_rgb` (`ops::cell_hsv_x4`, the scalar bits).
fn hsv_to_rgb_x4(a: &[[f32; LANES]; 3], o: &mut [[f32; LANES]; 3]) {
    *o = cell_hsv_x4::hsv_to_rgb_x4(*a);
}
/// The texture index and the sampling packed in a texture helper's immediate
/// ([`texture_imm`]).
fn texture_of(imm: u32) -> (u32, Sampling) {
    (imm & TEXTURE_INDEX_MASK, Sampling::from_bits(imm >> 24))
}

/// Texture indices a texture helper's immediate can carry (below bit 24).
pub const TEXTURE_INDEX_MASK: u32 = (1 << 24) - 1;

/// The immediate of a texture helper call: the texture index, and the sampling's bits
/// above bit 24; `None` for an index that does not fit.
pub fn texture_imm(texture: u32, sampling: Sampling) -> Option<u32> {
    (texture <= TEXTURE_INDEX_MASK).then(|| texture | sampling.bits() << 24)
}

/// A texture lookup: `a` = uv, ∂uv/∂x, ∂uv/∂y; `o` = RGBA.
fn texture(ctx: &CallCtx, imm: u32, a: &[f32], o: &mut [f32]) {
    // SAFETY: the material keeps its texture set alive while its code runs.
    let set = unsafe { &*ctx.textures };
    let (index, s) = texture_of(imm);
    let duv = [[a[2], a[3]], [a[4], a[5]]];
    let t = set
        .get(index)
        .map_or([0.0; 4], |t| t.lookup([a[0], a[1]], duv, s));
    o.copy_from_slice(&t);
}
/// The batch form of `texture`: the texture is looked up once for the four lanes, then
/// sampled per lane as the scalar form does.
fn texture_x4(ctx: &CallCtx, imm: u32, a: &[[f32; LANES]; 6], o: &mut [[f32; LANES]; 4]) {
    // SAFETY: the material keeps its texture set alive while its code runs.
    let set = unsafe { &*ctx.textures };
    let (index, s) = texture_of(imm);
    let tex = set.get(index);
    for lane in 0..LANES {
        let duv = [[a[2][lane], a[3][lane]], [a[4][lane], a[5][lane]]];
        let t = tex.map_or([0.0; 4], |t| t.lookup([a[0][lane], a[1][lane]], duv, s));
        for (dst, x) in o.iter_mut().zip(t) {
            dst[lane] = x;
        }
    }
}
/// Light sample number `imm` of the whole light list (lights in order, each contributing
/// `lights::sample_count` samples), seen from `a[0..3]` with the fragment's seed in
/// `a[3]`'s bits: `out[0..3]` = L, `out[3..6]` = Cl, `out[6]` = 1.0 if it gives a sample,
/// else 0.0, `out[7..10]` = the sample's `to` point (for `sn_visible`), `out[10]` = its
/// density (`light.pdf`).
fn light(ctx: &CallCtx, imm: u32, a: &[f32], o: &mut [f32]) {
    let found = light_of(ctx, imm)
        .and_then(|(li, l, k)| lights::sample(l, li, k, [a[0], a[1], a[2]], a[3].to_bits()));
    light_out(found, o);
}

/// Which light gives sample number `imm` of the whole list: its index, the light and the
/// sample's number among its own.
fn light_of(ctx: &CallCtx, imm: u32) -> Option<(u32, &lights::Light, u32)> {
    // SAFETY: the caller's environment outlives the call.
    let env = unsafe { &*ctx.env };
    let mut rest = imm;
    for (li, l) in env.lights.iter().enumerate() {
        let n = lights::sample_count(l);
        if rest < n {
            return Some((li as u32, l, rest));
        }
        rest -= n;
    }
    None
}

/// The batch form of `light`: the light is found once for the four lanes (the sample
/// number is the same for all), then sampled for the four lanes at once
/// (`lights::sample_x4`, the scalar bits).
fn light_x4(ctx: &CallCtx, imm: u32, a: &[[f32; LANES]; 4], o: &mut [[f32; LANES]; 11]) {
    let found = light_of(ctx, imm)
        .map(|(li, l, k)| lights::sample_x4(l, li, k, [a[0], a[1], a[2]], a[3].map(f32::to_bits)));
    let mut one = [0.0f32; 11];
    for lane in 0..LANES {
        light_out(found.and_then(|f| f[lane]), &mut one);
        for (dst, x) in o.iter_mut().zip(one) {
            dst[lane] = x;
        }
    }
}

/// A light sample (or none) as `light`'s results.
fn light_out(found: Option<lights::Sample<f32>>, o: &mut [f32]) {
    match found {
        Some(s) => {
            o[..3].copy_from_slice(&s.l);
            o[3..6].copy_from_slice(&s.cl);
            o[6] = 1.0;
            o[7..10].copy_from_slice(&s.to);
            o[10] = s.pdf;
        }
        None => o[6] = 0.0,
    }
}

/// `trace`: the direction in `a[0..3]`, the fragment's `P` in `a[3..6]`, its ray depth in
/// `a[6]`'s bits, the BSDF sample's density in `a[7]` (0 for none), the ray type in `imm`;
/// `out[0..3]` = the radiance (`runtime::interp::trace_radiance`: black without a scene).
fn trace(ctx: &CallCtx, imm: u32, a: &[f32], o: &mut [f32]) {
    let dir = [a[0], a[1], a[2]];
    let p = [a[3], a[4], a[5]];
    let depth = a[6].to_bits() as i32;
    let c = interp::trace_radiance(ctx.scene(), p, dir, imm as i32, depth, a[7]);
    o.copy_from_slice(&c);
}
/// `occlusion`: `n` in `a[0..3]`, the sample count in `a[3]`'s bits, the maximum distance
/// in `a[4]`, the fragment's `P` in `a[5..8]` and seed in `a[8]`'s bits; `out[0]` =
/// `runtime::interp::occlusion_value` (1 without a scene).
fn occlusion(ctx: &CallCtx, _: u32, a: &[f32], o: &mut [f32]) {
    let n = [a[0], a[1], a[2]];
    let p = [a[5], a[6], a[7]];
    let samples = a[3].to_bits() as i32;
    let seed = a[8].to_bits();
    o[0] = interp::occlusion_value(ctx.scene(), p, n, samples, a[4], seed);
}
/// `light.visible` of light-sample slot `slot`: the light loop's point in `a[0..3]`, the
/// sample's `to` in `a[3..6]`; `out[0]` = 1.0 if nothing blocks the segment
/// (`runtime::interp::sample_visible`: always without a scene), else 0.0. Asked once per
/// sample and call at the same point (the call's [`VisibilityMemo`]).
fn visible(ctx: &CallCtx, slot: u32, a: &[f32], o: &mut [f32]) {
    let p = [a[0], a[1], a[2]];
    let ask = || interp::sample_visible(ctx.scene(), p, [a[3], a[4], a[5]]);
    let open = match ctx.visibility() {
        Some(memo) if ctx.scene().is_some() => memo.get_or_ask(slot, 0, p, ask),
        _ => ask(),
    };
    o[0] = if open { 1.0 } else { 0.0 };
}

/// The batch form of `visible`: without a scene every sample is visible (as
/// `interp::sample_visible` says), so the four lanes are answered at once; with one, each
/// lane asks its fragment's services (a padding lane asks nothing), through its lane's memo.
fn visible_x4(ctx: &CallCtx, slot: u32, a: &[[f32; LANES]; 6], o: &mut [[f32; LANES]; 1]) {
    if ctx.scene().is_none() {
        o[0] = [1.0; LANES];
        return;
    }
    // SAFETY: a non-null `visibility_x4` points at the memos on the stack of the running
    // call.
    let memos = unsafe { ctx.visibility_x4.as_ref() };
    for lane in 0..LANES {
        let p = [a[0][lane], a[1][lane], a[2][lane]];
        let to = [a[3][lane], a[4][lane], a[5][lane]];
        let scene = ctx.lane_scene(lane);
        let ask = || interp::sample_visible(scene, p, to);
        let open = match memos {
            Some(m) if scene.is_some() => {
                m[lane].get_or_ask(slot, ctx.first.wrapping_add(lane as u32), p, ask)
            }
            _ => ask(),
        };
        o[0][lane] = if open { 1.0 } else { 0.0 };
    }
}

/// The batch form of `trace`: each lane traces with its fragment's services (black for a
/// padding lane or without a scene).
fn trace_x4(ctx: &CallCtx, imm: u32, a: &[[f32; LANES]; 8], o: &mut [[f32; LANES]; 3]) {
    for lane in 0..LANES {
        let at = |k: usize| a[k][lane];
        let (dir, p) = ([at(0), at(1), at(2)], [at(3), at(4), at(5)]);
        let depth = at(6).to_bits() as i32;
        let c = interp::trace_radiance(ctx.lane_scene(lane), p, dir, imm as i32, depth, at(7));
        for (dst, x) in o.iter_mut().zip(c) {
            dst[lane] = x;
        }
    }
}

/// The batch form of `occlusion`: each lane asks its fragment's services (1 for a padding
/// lane or without a scene).
fn occlusion_x4(ctx: &CallCtx, _: u32, a: &[[f32; LANES]; 9], o: &mut [[f32; LANES]; 1]) {
    for lane in 0..LANES {
        let at = |k: usize| a[k][lane];
        let (n, p) = ([at(0), at(1), at(2)], [at(5), at(6), at(7)]);
        let (samples, seed) = (at(3).to_bits() as i32, at(8).to_bits());
        o[0][lane] = interp::occlusion_value(ctx.lane_scene(lane), p, n, samples, at(4), seed);
    }
}

/// The immediate of an attribute helper call: the slot below bit 24 and the width (1 to
/// 4 floats) above; `None` for a slot that does not fit.
pub fn attribute_imm(slot: u32, width: usize) -> Option<u32> {
    (slot <= TEXTURE_INDEX_MASK && (1..=4).contains(&width)).then_some(slot | (width as u32) << 24)
}
/// Geometry attribute `imm & 0xffffff` read as `imm >> 24` floats: `a` = the default (4
/// slots, the width's first), `o` = the value (`runtime::interp::attribute_value`, the
/// interpreter's lookup).
fn attribute(ctx: &CallCtx, imm: u32, a: &[f32], o: &mut [f32]) {
    let n = (imm >> 24).clamp(1, 4) as usize;
    interp::attribute_value(ctx.scene(), imm & TEXTURE_INDEX_MASK, &a[..n], &mut o[..n]);
}
/// The batch form of `attribute`: each lane asks its own fragment's services.
fn attribute_x4(ctx: &CallCtx, imm: u32, a: &[[f32; LANES]; 4], o: &mut [[f32; LANES]; 4]) {
    let n = (imm >> 24).clamp(1, 4) as usize;
    for lane in 0..LANES {
        let default: [f32; 4] = std::array::from_fn(|k| a[k][lane]);
        let mut got = [0.0f32; 4];
        let scene = ctx.lane_scene(lane);
        interp::attribute_value(
            scene,
            imm & TEXTURE_INDEX_MASK,
            &default[..n],
            &mut got[..n],
        );
        for (dst, x) in o.iter_mut().zip(got) {
            dst[lane] = x;
        }
    }
}

/// Whether geometry attribute `imm & 0xffffff`, read as `imm >> 24` floats, is found: 1
/// or 0 in `o[0]` (`runtime::interp::attribute_found`, the interpreter's lookup).
fn attribute_found(ctx: &CallCtx, imm: u32, _: &[f32], o: &mut [f32]) {
    let n = (imm >> 24).clamp(1, 4) as usize;
    let found = interp::attribute_found(ctx.scene(), imm & TEXTURE_INDEX_MASK, n);
    o[0] = if found { 1.0 } else { 0.0 };
}
/// The batch form of `attribute_found`: each lane asks its own fragment's services.
fn attribute_found_x4(ctx: &CallCtx, imm: u32, _: &[[f32; LANES]; 0], o: &mut [[f32; LANES]; 1]) {
    let n = (imm >> 24).clamp(1, 4) as usize;
    for (lane, dst) in o[0].iter_mut().enumerate() {
        let found = interp::attribute_found(ctx.lane_scene(lane), imm & TEXTURE_INDEX_MASK, n);
        *dst = if found { 1.0 } else { 0.0 };
    }
}

/// `probe`: field `ProbeField::ALL[imm]` of the probe ray (origin, direction, minimum and
/// maximum distance in the arguments) through the runtime's one lookup.
fn probe(ctx: &CallCtx, imm: u32, a: &[f32], o: &mut [f32]) {
    o.copy_from_slice(&probe_lane(ctx.scene(), imm, a));
}
/// The batch form of `probe`: each lane asks its own fragment's services.
fn probe_x4(ctx: &CallCtx, imm: u32, a: &[[f32; LANES]; 8], o: &mut [[f32; LANES]; 3]) {
    for lane in 0..LANES {
        let args: [f32; 8] = std::array::from_fn(|k| a[k][lane]);
        let r = probe_lane(ctx.lane_scene(lane), imm, &args);
        for (dst, x) in o.iter_mut().zip(r) {
            dst[lane] = x;
        }
    }
}
fn probe_lane(scene: Option<&dyn SceneServices>, imm: u32, a: &[f32]) -> [f32; 3] {
    let Some(&field) = ProbeField::ALL.get(imm as usize) else {
        return [0.0; 3];
    };
    interp::probe_field::<f32>(
        scene,
        field,
        [a[0], a[1], a[2]],
        [a[3], a[4], a[5]],
        a[6],
        a[7],
    )
}

/// The illuminance loop's trip count: every light's samples.
pub fn light_samples(env: &ShadeEnv) -> u32 {
    env.lights.iter().map(lights::sample_count).sum()
}
fn ambient(ctx: &CallCtx, _: u32, _: &[f32], o: &mut [f32]) {
    // SAFETY: the caller's environment outlives the call.
    let env = unsafe { &*ctx.env };
    o.copy_from_slice(&lights::ambient::<f32>(&env.lights));
}
/// The environment's space matrices as f32, as `runtime::interp::transform` converts them:
/// camera m, camera inverse, object m, object inverse (16 floats each, row-major).
fn matrices(ctx: &CallCtx, _: u32, _: &[f32], o: &mut [f32]) {
    // SAFETY: the caller's environment outlives the call.
    let env = unsafe { &*ctx.env };
    let ms = [env.camera.m, env.camera.inv, env.object.m, env.object.inv];
    for (dst, m) in o.chunks_mut(16).zip(ms) {
        for (d, x) in dst.iter_mut().zip(m) {
            *d = x as f32;
        }
    }
}

/// A memory helper: symbol, argument and result counts (floats per lane), whether its
/// results are the same for every lane (computed once in the batch entry), and the scalar
/// and batch functions.
pub struct MemHelperDesc {
    /// Symbol of the scalar version (`_x4` is appended for the batch one).
    pub name: &'static str,
    /// Argument floats.
    pub args: usize,
    /// Result floats.
    pub outs: usize,
    /// Scalar version.
    pub scalar: MemHelper,
    /// Batch version.
    pub batch: MemHelper,
}

unsafe fn call_scalar<const A: usize, const O: usize>(
    f: Body,
    ctx: *const CallCtx,
    imm: u32,
    args: *const f32,
    out: *mut f32,
) {
    // SAFETY: compiled code passes `A` readable and `O` writable floats and a live context.
    let (ctx, args, out) = unsafe {
        (
            &*ctx,
            std::slice::from_raw_parts(args, A),
            std::slice::from_raw_parts_mut(out, O),
        )
    };
    f(ctx, imm, args, out);
}

unsafe fn call_batch<const A: usize, const O: usize>(
    f: Body,
    ctx: *const CallCtx,
    imm: u32,
    args: *const f32,
    out: *mut f32,
) {
    // SAFETY: compiled code passes `A * 4` readable and `O * 4` writable floats and a live
    // context.
    let (ctx, args, out) = unsafe {
        (
            &*ctx,
            std::slice::from_raw_parts(args, A * LANES),
            std::slice::from_raw_parts_mut(out, O * LANES),
        )
    };
    let mut a = [0.0f32; 64];
    let mut o = [0.0f32; 64];
    for lane in 0..LANES {
        for k in 0..A {
            a[k] = args[k * LANES + lane];
        }
        f(ctx, imm, &a[..A], &mut o[..O]);
        for k in 0..O {
            out[k * LANES + lane] = o[k];
        }
    }
}

macro_rules! batch_fn {
    ($name:ident, $args:literal, $outs:literal) => {
        pub unsafe extern "C" fn batch(c: *const CallCtx, i: u32, a: *const f32, o: *mut f32) {
            // SAFETY: forwarded from compiled code, see `call_batch`.
            unsafe { call_batch::<$args, $outs>(super::super::$name, c, i, a, o) }
        }
    };
    ($name:ident, $args:literal, $outs:literal, ctx $batch:ident) => {
        pub unsafe extern "C" fn batch(c: *const CallCtx, i: u32, a: *const f32, o: *mut f32) {
            // SAFETY: compiled code passes a live context, `A * 4` readable and `O * 4`
            // writable floats.
            unsafe {
                super::super::$batch(
                    &*c,
                    i,
                    &*(a as *const [[f32; LANES]; $args]),
                    &mut *(o as *mut [[f32; LANES]; $outs]),
                )
            }
        }
    };
    ($name:ident, $args:literal, $outs:literal, $batch:ident) => {
        pub unsafe extern "C" fn batch(_: *const CallCtx, _: u32, a: *const f32, o: *mut f32) {
            // SAFETY: compiled code passes `A * 4` readable and `O * 4` writable floats.
            unsafe {
                super::super::$batch(
                    &*(a as *const [[f32; LANES]; $args]),
                    &mut *(o as *mut [[f32; LANES]; $outs]),
                )
            }
        }
    };
}

macro_rules! mem_helpers {
    ($($name:ident: $args:literal -> $outs:literal $(=> $($batch:ident)+)?),* $(,)?) => {
        mod mem {
            use super::*;
            $(
                pub mod $name {
                    use super::*;
                    pub unsafe extern "C" fn scalar(c: *const CallCtx, i: u32, a: *const f32, o: *mut f32) {
                        // SAFETY: forwarded from compiled code, see `call_scalar`.
                        unsafe { call_scalar::<$args, $outs>(super::super::$name, c, i, a, o) }
                    }
                    batch_fn!($name, $args, $outs $(, $($batch)+)?);
                }
            )*
        }
        /// Every memory helper.
        pub const MEM_HELPERS: &[MemHelperDesc] = &[
            $(MemHelperDesc {
                name: concat!("sn_", stringify!($name)),
                args: $args,
                outs: $outs,
                scalar: mem::$name::scalar,
                batch: mem::$name::batch,
            }),*
        ];
    };
}

mem_helpers! {
    noise2: 2 -> 1,
    noise3: 3 -> 1 => noise3_x4,
    fbm3: 6 -> 1 => fbm3_x4,
    cellnoise3: 3 -> 1 => cellnoise3_x4,
    rgb_to_hsv: 3 -> 3 => rgb_to_hsv_x4,
    hsv_to_rgb: 3 -> 3 => hsv_to_rgb_x4,
    ggx_albedo: 2 -> 2,
    dielectric_albedo: 3 -> 1,
    sheen_albedo: 2 -> 2,
    osl_perlin2: 2 -> 1 => osl_perlin2_x4,
    osl_perlin3: 3 -> 1 => osl_perlin3_x4,
    osl_vperlin2: 2 -> 3 => osl_vperlin2_x4,
    osl_vperlin3: 3 -> 3 => osl_vperlin3_x4,
    osl_cell2: 2 -> 1 => osl_cell2_x4,
    osl_cell3: 3 -> 1 => osl_cell3_x4,
    osl_vcell2: 2 -> 3 => osl_vcell2_x4,
    osl_vcell3: 3 -> 3 => osl_vcell3_x4,
    osl_cell1: 1 -> 1,
    osl_cell4: 4 -> 1,
    osl_vcell1: 1 -> 3,
    osl_vcell4: 4 -> 3,
    osl_perlin1: 1 -> 1,
    osl_perlin4: 4 -> 1,
    osl_vperlin1: 1 -> 3,
    osl_vperlin4: 4 -> 3,
    osl_hash1: 1 -> 1,
    osl_hash2: 2 -> 1,
    osl_hash3: 3 -> 1,
    osl_hash4: 4 -> 1,
    osl_vhash1: 1 -> 3,
    osl_vhash2: 2 -> 3,
    osl_vhash3: 3 -> 3,
    osl_vhash4: 4 -> 3,
    osl_pperlin1: 2 -> 1,
    osl_pperlin2: 4 -> 1,
    osl_pperlin3: 6 -> 1,
    osl_pperlin4: 8 -> 1,
    osl_vpperlin1: 2 -> 3,
    osl_vpperlin2: 4 -> 3,
    osl_vpperlin3: 6 -> 3,
    osl_vpperlin4: 8 -> 3,
    osl_simplex1: 1 -> 1,
    osl_simplex2: 2 -> 1,
    osl_simplex3: 3 -> 1,
    osl_simplex4: 4 -> 1,
    osl_vsimplex1: 1 -> 3,
    osl_vsimplex2: 2 -> 3,
    osl_vsimplex3: 3 -> 3,
    osl_vsimplex4: 4 -> 3,
    mx_fractal2: 5 -> 1 => mx_fractal2_x4,
    mx_fractal3: 6 -> 1 => mx_fractal3_x4,
    mx_vfractal2: 5 -> 3 => mx_vfractal2_x4,
    mx_vfractal3: 6 -> 3 => mx_vfractal3_x4,
    mx_worley2: 5 -> 1 => mx_worley2_x4,
    mx_worley2_v2: 5 -> 2 => mx_worley2_v2_x4,
    mx_worley2_v3: 5 -> 3 => mx_worley2_v3_x4,
    mx_worley3: 6 -> 1 => mx_worley3_x4,
    mx_worley3_v2: 6 -> 2 => mx_worley3_v2_x4,
    mx_worley3_v3: 6 -> 3 => mx_worley3_v3_x4,
    texture: 6 -> 4 => ctx texture_x4,
    light: 4 -> 11 => ctx light_x4,
    trace: 8 -> 3 => ctx trace_x4,
    occlusion: 9 -> 1 => ctx occlusion_x4,
    attribute: 4 -> 4 => ctx attribute_x4,
    attribute_found: 0 -> 1 => ctx attribute_found_x4,
    probe: 8 -> 3 => ctx probe_x4,
    visible: 6 -> 1 => ctx visible_x4,
    ambient: 0 -> 3,
    matrices: 0 -> 64,
}

/// The memory helper called `name` (`sn_noise3`, …).
pub fn mem_helper(name: &str) -> Option<&'static MemHelperDesc> {
    MEM_HELPERS.iter().find(|h| h.name == name)
}
