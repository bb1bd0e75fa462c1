// shadenet WGSL library: the sn_* functions the expressions of emit::op_expr call.
//
// Every function mirrors one function of graph/src/ops (DESIGN §7) with the same sequence of
// IEEE operations, so that a device doing IEEE f32 arithmetic without contraction (Mesa's
// lavapipe) gives the CPU's bits for everything but the transcendentals (exp, log, sin, cos,
// tan, asin, acos, atan2, pow), which call the device's own functions (their measured error is
// in the documentation of gpu/src/emit.rs).
//
// Rules followed throughout:
// - NaN and infinity are tested on the bits (sn_is_nan, sn_is_inf, sn_is_finite), never with
//   `x != x`, which a driver assuming finite arithmetic may fold away.
// - Nothing divides by zero or converts an out-of-range float to an int at run time where the
//   result is used: the total rules pick the result with `select` or an early return.
// - Integer arithmetic that may overflow goes through u32 (wrapping by definition).
// - WGSL has no inf/NaN literals: they are made with bitcast.

// ---- bits ----

fn sn_is_nan(x: f32) -> bool {
    return (bitcast<u32>(x) & 0x7fffffffu) > 0x7f800000u;
}

// A signaling NaN: exponent all ones, quiet bit clear, payload non-zero.
fn sn_is_snan(x: f32) -> bool {
    let b = bitcast<u32>(x) & 0x7fffffffu;
    return b > 0x7f800000u && (b & 0x00400000u) == 0u;
}

fn sn_is_inf(x: f32) -> bool {
    return (bitcast<u32>(x) & 0x7fffffffu) == 0x7f800000u;
}

fn sn_is_finite(x: f32) -> bool {
    return (bitcast<u32>(x) & 0x7f800000u) != 0x7f800000u;
}

fn sn_inf() -> f32 {
    return bitcast<f32>(0x7f800000u);
}

fn sn_nan() -> f32 {
    return bitcast<f32>(0x7fc00000u);
}

// The magnitude of m with the sign of s.
fn sn_copysign(m: f32, s: f32) -> f32 {
    return bitcast<f32>((bitcast<u32>(m) & 0x7fffffffu) | (bitcast<u32>(s) & 0x80000000u));
}

// ---- the key: a run-time zero the compiler cannot see through ----
//
// Mesa rewrites float expressions as if they were real numbers wherever the same SSA value
// appears twice: `a - a` becomes 0 (NaN for an infinite a), `a * b + a * c` becomes
// `a * (b + c)` (a different rounding); and wherever it sees a constant: `x * 0.0` becomes 0,
// `(x * 2.0) * 0.5` becomes x. The same value appears twice when an IR op reads one value
// twice (`sub %x, %x`), when two IR values compute the same thing (the compiler merges them)
// or when a vector's components are one value (`splat`). A function that could meet that
// takes the kernel's key `k` (`sn_keep`: a uniform that is 0 at run time) and passes an
// operand through sn_o*, which the compiler cannot prove equal to anything else.

fn sn_o(x: f32, k: u32) -> f32 {
    return bitcast<f32>(bitcast<u32>(x) ^ k);
}

fn sn_o2(x: vec2<f32>, k: u32) -> vec2<f32> {
    return bitcast<vec2<f32>>(bitcast<vec2<u32>>(x) ^ vec2<u32>(k));
}

fn sn_o3(x: vec3<f32>, k: u32) -> vec3<f32> {
    return bitcast<vec3<f32>>(bitcast<vec3<u32>>(x) ^ vec3<u32>(k));
}

fn sn_o4(x: vec4<f32>, k: u32) -> vec4<f32> {
    return bitcast<vec4<f32>>(bitcast<vec4<u32>>(x) ^ vec4<u32>(k));
}

// ---- total float ops (ops::div, fmod, sqrt, log, asin, acos, fract, pow) ----

// a / b, 0 where b == 0 (either zero).
fn sn_div(a: f32, b: f32) -> f32 {
    return select(a / b, 0.0f, b == 0.0f);
}

// a - b * floor(a / b), 0 where b == 0.
fn sn_mod(a: f32, b: f32) -> f32 {
    return select(a - b * floor(a / b), 0.0f, b == 0.0f);
}

// sqrt(x), 0 for x < 0; sqrt(±0) = ±0 and sqrt(NaN) = NaN as IEEE says (lavapipe's sqrt
// gives +0 for both: it takes the square root of max(x, 0)).
fn sn_sqrt(x: f32) -> f32 {
    if (x == 0.0f || sn_is_nan(x)) {
        return x;
    }
    return select(sqrt(x), 0.0f, x < 0.0f);
}

// x - floor(x) (WGSL's fract may clamp below 1; this may round up to 1, as the CPU does).
fn sn_fract(x: f32) -> f32 {
    return x - floor(x);
}

// ---- transcendentals ----
//
// exp, log, asin, acos, atan2 and pow are ports of FreeBSD msun's float functions (fdlibm,
// Copyright (C) 1993 by Sun Microsystems, Inc.: "Permission to use, copy, modify, and
// distribute this software is freely granted, provided that this notice is preserved."):
// only IEEE + - * / sqrt and bit operations, so they give the same bits on every device that
// does IEEE arithmetic without contraction, about 1 ulp from the correctly rounded result
// (the measured distance to the CPU's functions is in the documentation of emit.rs). WGSL's
// built-ins for these are approximations of unspecified accuracy (lavapipe's asin is 4e-4
// off, its log of a subnormal 15 off, its pow thousands of ulps). sin, cos and tan stay the
// device's.

// expf (e_expf.c): every input, NaN and infinities included.
fn sn_exp(x_in: f32) -> f32 {
    var x = x_in;
    let hx0 = bitcast<u32>(x);
    let neg = (hx0 >> 31u) == 1u;
    let hx = hx0 & 0x7fffffffu;
    if (hx >= 0x42b17218u) { // |x| >= 88.721...
        if (hx > 0x7f800000u) {
            return x; // NaN
        }
        if (hx == 0x7f800000u) {
            return select(x, 0.0f, neg); // exp(±inf) = inf, 0
        }
        if (x > 88.72168f) {
            return sn_inf(); // overflow
        }
        if (x < -103.972084f) {
            return 0.0f; // underflow
        }
    }
    var hi = 0.0f;
    var lo = 0.0f;
    var k = 0i;
    if (hx > 0x3eb17218u) { // |x| > 0.5 ln2: argument reduction
        if (hx < 0x3f851592u) { // and |x| < 1.5 ln2
            hi = x - select(0.69314575f, -0.69314575f, neg);
            lo = select(1.4286068e-06f, -1.4286068e-06f, neg);
            k = select(1i, -1i, neg);
        } else {
            k = i32(1.442695f * x + select(0.5f, -0.5f, neg));
            let t = f32(k);
            hi = x - t * 0.69314575f; // exact
            lo = t * 1.4286068e-06f;
        }
        x = hi - lo;
    } else if (hx < 0x39000000u) { // |x| < 2^-14
        return 1.0f + x;
    }
    let t = x * x;
    let c = x - t * (0.16666625f + t * -0.0027667333f);
    if (k == 0i) {
        return 1.0f - ((x * c) / (c - 2.0f) - x);
    }
    let y = 1.0f - ((lo - (x * c) / (2.0f - c)) - hi);
    if (k >= -125i) {
        // 2^k as 2^min(k, 127), then times 2 for k = 128 (y * 2^128 stays finite for y < 1).
        let twopk = bitcast<f32>(u32(0x3f800000i + (min(k, 127i) << 23u)));
        return select(y * twopk, (y * twopk) * 2.0f, k == 128i);
    }
    // subnormal result: 2^(k + 100), then 2^-100 (one rounding)
    let twopk = bitcast<f32>(u32(0x3f800000i + ((k + 100i) << 23u)));
    return (y * twopk) * 7.888609e-31f;
}

// logf (e_logf.c) for x > 0 (subnormals and +inf included). k: the key.
fn sn_log_pos(x_in: f32, kk: u32) -> f32 {
    var x = x_in;
    var ix = bitcast<i32>(x);
    var k = 0i;
    if (ix < 0x00800000i) { // subnormal: scale up
        k = -25i;
        x = x * 33554432.0f;
        ix = bitcast<i32>(x);
    }
    if (ix >= 0x7f800000i) {
        return x; // +inf
    }
    k = k + ((ix >> 23u) - 127i);
    ix = ix & 0x007fffffi;
    let i = (ix + (0x95f64i << 3u)) & 0x800000i;
    x = bitcast<f32>(ix | (i ^ 0x3f800000i)); // normalize x or x/2
    k = k + (i >> 23u);
    let f = x - 1.0f;
    let dk = f32(k);
    if ((0x007fffffi & (0x8000i + ix)) < 0xc000i) { // -2^-9 <= f < 2^-9
        if (f == 0.0f) {
            if (k == 0i) {
                return 0.0f;
            }
            return dk * 0.6931381f + sn_o(dk * 9.058001e-06f, kk);
        }
        let r = f * f * (0.5f - 0.33333334f * f);
        if (k == 0i) {
            return f - r;
        }
        return dk * 0.6931381f - ((r - dk * 9.058001e-06f) - f);
    }
    let s = f / (2.0f + f);
    let z = s * s;
    let w = z * z;
    let i2 = (ix - (0x6147ai << 3u)) | ((0x6b851i << 3u) - ix);
    let t1 = w * (0.40000972f + w * 0.24279079f);
    let t2 = z * (0.6666666f + w * 0.28498787f);
    let r = t2 + t1;
    if (i2 > 0i) {
        let hfsq = 0.5f * f * f;
        if (k == 0i) {
            return f - (hfsq - s * (hfsq + r));
        }
        return dk * 0.6931381f - ((hfsq - (s * (hfsq + r) + dk * 9.058001e-06f)) - f);
    }
    if (k == 0i) {
        return f - s * (f - r);
    }
    return dk * 0.6931381f - ((s * (f - r) - dk * 9.058001e-06f) - f);
}

// ops::log: ln(x), ln(f32::MIN_POSITIVE) (as f32: -87.33655, 0xc2aeac50) for x <= 0; NaN
// stays NaN.
fn sn_log(x: f32, k: u32) -> f32 {
    if (x <= 0.0f) {
        return bitcast<f32>(0xc2aeac50u);
    }
    if (sn_is_nan(x)) {
        return x;
    }
    return sn_log_pos(x, k);
}

// clamp(x, -1, 1) as ops::clamp_unit writes it (NaN stays NaN).
fn sn_clamp_unit(x: f32) -> f32 {
    return select(select(x, 1.0f, x > 1.0f), -1.0f, x < -1.0f);
}

// The rational approximation of asinf/acosf: R(t) = p(t) / q(t).
fn sn_asin_r(t: f32) -> f32 {
    let p = t * (0.16666667f + t * (-0.32556581f + t * (0.20121253f + t * (-0.040055536f
        + t * (0.000791535f + t * 3.479331e-05f)))));
    let q = 1.0f + t * (-2.403395f + t * (2.0209458f + t * (-0.688284f + t * 0.077038154f)));
    return p / q;
}

// asinf (e_asinf.c) of the clamped argument.
fn sn_asin(x_in: f32) -> f32 {
    let x = sn_clamp_unit(x_in);
    let hx = bitcast<i32>(x);
    let ix = hx & 0x7fffffffi;
    if (ix >= 0x3f800000i) { // |x| = 1, or NaN
        if (ix == 0x3f800000i) {
            return sn_copysign(1.5707964f, x); // ±pi/2
        }
        return x;
    }
    if (ix < 0x3f000000i) { // |x| < 0.5
        if (ix < 0x32000000i) { // |x| < 2^-27
            return x;
        }
        return x + x * sn_asin_r(x * x);
    }
    let t = (1.0f - abs(x)) * 0.5f;
    let r = sn_asin_r(t);
    let s = sqrt(t);
    var res: f32;
    if (ix >= 0x3f79999ai) { // |x| > 0.975
        res = 1.5707963f - (2.0f * (s + s * r) - 7.5497894e-08f);
    } else {
        let w = bitcast<f32>(bitcast<i32>(s) & bitcast<i32>(0xfffff000u));
        let c = (t - w * w) / (s + w);
        let p = 2.0f * s * r - (7.5497894e-08f - 2.0f * c);
        let q = 0.7853982f - 2.0f * w;
        res = 0.7853982f - (p - q);
    }
    return select(-res, res, hx > 0i);
}

// acosf (e_acosf.c) of the clamped argument.
fn sn_acos(x_in: f32) -> f32 {
    let x = sn_clamp_unit(x_in);
    let hx = bitcast<i32>(x);
    let ix = hx & 0x7fffffffi;
    if (ix >= 0x3f800000i) { // |x| = 1, or NaN
        if (ix == 0x3f800000i) {
            return select(3.1415927f, 0.0f, hx > 0i); // acos(1) = 0, acos(-1) = pi
        }
        return x;
    }
    if (ix < 0x3f000000i) { // |x| < 0.5
        if (ix <= 0x32800000i) { // |x| <= 2^-26
            return 1.5707964f;
        }
        let r = x * sn_asin_r(x * x);
        return 1.5707963f - (x - (7.5497894e-08f - r));
    }
    if (hx < 0i) { // x <= -0.5
        let z = (1.0f + x) * 0.5f;
        let s = sqrt(z);
        let w = sn_asin_r(z) * s - 7.5497894e-08f;
        return 3.1415925f - 2.0f * (s + w);
    }
    // x >= 0.5
    let z = (1.0f - x) * 0.5f;
    let s = sqrt(z);
    let df = bitcast<f32>(bitcast<i32>(s) & bitcast<i32>(0xfffff000u));
    let c = (z - df * df) / (s + df);
    let w = sn_asin_r(z) * s + c;
    return 2.0f * (df + w);
}

const SN_ATAN_HI = array<f32, 4>(0.4636476f, 0.7853981f, 0.9827937f, 1.5707963f);
const SN_ATAN_LO = array<f32, 4>(5.0121582e-09f, 3.7748947e-08f, 3.4473217e-08f, 7.5497894e-08f);

// atanf (s_atanf.c, fdlibm's 11-term polynomial) of a finite x.
fn sn_atan(x_in: f32) -> f32 {
    let hx = bitcast<i32>(x_in);
    let ix = hx & 0x7fffffffi;
    if (ix >= 0x4c800000i) { // |x| >= 2^26
        return sn_copysign(1.5707964f, x_in);
    }
    var x = x_in;
    var id = -1i;
    if (ix < 0x3ee00000i) { // |x| < 0.4375
        if (ix < 0x39800000i) { // |x| < 2^-12
            return x;
        }
    } else {
        x = abs(x);
        if (ix < 0x3f980000i) { // |x| < 1.1875
            if (ix < 0x3f300000i) { // 7/16 <= |x| < 11/16
                id = 0i;
                x = (2.0f * x - 1.0f) / (2.0f + x);
            } else { // 11/16 <= |x| < 19/16
                id = 1i;
                x = (x - 1.0f) / (x + 1.0f);
            }
        } else if (ix < 0x401c0000i) { // |x| < 2.4375
            id = 2i;
            x = (x - 1.5f) / (1.0f + 1.5f * x);
        } else { // 2.4375 <= |x| < 2^26
            id = 3i;
            x = -1.0f / x;
        }
    }
    let z = x * x;
    let w = z * z;
    let s1 = z * (0.33333334f + w * (0.14285715f + w * (0.09090887f + w * (0.06661073f
        + w * (0.04976878f + w * 0.01628582f)))));
    let s2 = w * (-0.2f + w * (-0.111111104f + w * (-0.07691876f + w * (-0.058335703f
        + w * -0.03653157f))));
    if (id < 0i) {
        return x - x * (s1 + s2);
    }
    let r = SN_ATAN_HI[id] - ((x * (s1 + s2) - SN_ATAN_LO[id]) - x);
    return select(r, -r, hx < 0i);
}

// Rust's f32::atan2 (C99 Annex F special cases written out), e_atan2f.c for finite non-zero
// operands.
fn sn_atan2(y: f32, x: f32) -> f32 {
    if (sn_is_nan(x) || sn_is_nan(y)) {
        return sn_nan();
    }
    let pi = 3.1415927f;
    let half_pi = 1.5707964f;
    if (y == 0.0f) {
        // ±0 towards +x (x > 0 or x = +0), ±π towards -x (x < 0 or x = -0).
        if (x > 0.0f || (x == 0.0f && bitcast<u32>(x) == 0u)) {
            return y;
        }
        return sn_copysign(pi, y);
    }
    if (x == 0.0f) {
        return sn_copysign(half_pi, y);
    }
    if (sn_is_inf(x)) {
        if (sn_is_inf(y)) {
            return sn_copysign(select(2.3561945f, 0.7853982f, x > 0.0f), y);
        }
        return sn_copysign(select(pi, 0.0f, x > 0.0f), y);
    }
    if (sn_is_inf(y)) {
        return sn_copysign(half_pi, y);
    }
    if (x == 1.0f) {
        return sn_atan(y);
    }
    let ix = bitcast<i32>(x) & 0x7fffffffi;
    let iy = bitcast<i32>(y) & 0x7fffffffi;
    // 2 * sign(x) + sign(y)
    let m = select(0i, 1i, y < 0.0f) | select(0i, 2i, x < 0.0f);
    let k = (iy - ix) >> 23u;
    var z: f32;
    var mm = m;
    if (k > 26i) { // |y / x| > 2^26
        z = 1.5707964f; // pi_o_2 + 0.5 * pi_lo
        mm = m & 1i;
    } else if (k < -26i && x < 0.0f) { // 0 > |y| / x > -2^-26
        z = 0.0f;
    } else {
        z = sn_atan(abs(y / x));
    }
    switch (mm) {
        case 0i: {
            return z;
        }
        case 1i: {
            return -z;
        }
        case 2i: {
            return pi - (z - -8.742278e-08f);
        }
        default: {
            return (z - -8.742278e-08f) - pi;
        }
    }
}

// Whether b is an odd integer (every float of magnitude >= 2^24 is an even integer).
fn sn_is_odd_integer(b: f32) -> bool {
    if (!(abs(b) < 16777216.0f)) {
        return false;
    }
    return trunc(b) == b && (i32(b) & 1) != 0;
}

// x * 2^n with one rounding (scalbnf for a normal x and a result that may be subnormal).
fn sn_scalbn(x: f32, n: i32) -> f32 {
    let ix = bitcast<i32>(x);
    let k = ((ix & 0x7f800000i) >> 23u) + n;
    if (k > 0i) {
        return bitcast<f32>((ix & bitcast<i32>(0x807fffffu)) | (k << 23u));
    }
    if (k <= -25i) {
        return sn_copysign(0.0f, x);
    }
    // subnormal: exponent k + 25, then 2^-25
    return bitcast<f32>((ix & bitcast<i32>(0x807fffffu)) | ((k + 25i) << 23u)) * 2.9802322e-08f;
}

// powf (e_powf.c) for a finite base ax > 0, ax != 1, and a finite exponent y != 0. k: the key.
fn sn_pow_pos(ax_in: f32, y: f32, kk: u32) -> f32 {
    let hy = bitcast<i32>(y);
    let iy = hy & 0x7fffffffi;
    if (iy == 0x3f800000i) { // y = ±1
        return select(ax_in, 1.0f / ax_in, hy < 0i);
    }
    if (hy == 0x40000000i) { // y = 2
        return ax_in * ax_in;
    }
    if (hy == 0x3f000000i) { // y = 0.5
        return sqrt(ax_in);
    }
    var ax = ax_in;
    var ix = bitcast<i32>(ax);
    var t1: f32;
    var t2: f32;
    if (iy > 0x4d000000i) { // |y| > 2^27
        // over/underflow if x is not close to one
        if (ix < 0x3f7ffff8i) {
            return select(0.0f, sn_inf(), hy < 0i);
        }
        if (ix > 0x3f800007i) {
            return select(0.0f, sn_inf(), hy > 0i);
        }
        // |1 - x| <= 2^-20: log(x) by x - x^2/2 + x^3/3 - x^4/4
        let t = ax - 1.0f;
        let w = (t * t) * (0.5f - t * (0.33333334f - t * 0.25f));
        let u = 1.442688f * t;
        let v = t * 7.0526075e-06f - w * 1.442695f;
        t1 = bitcast<f32>(bitcast<i32>(u + v) & bitcast<i32>(0xfffff000u));
        t2 = v - (t1 - u);
    } else {
        var n = 0i;
        if (ix < 0x00800000i) { // subnormal
            ax = ax * 16777216.0f;
            n = -24i;
            ix = bitcast<i32>(ax);
        }
        n = n + ((ix >> 23u) - 0x7fi);
        let j = ix & 0x007fffffi;
        ix = j | 0x3f800000i; // normalize
        var k = 0i;
        if (j <= 0x1cc471i) { // |x| < sqrt(3/2)
            k = 0i;
        } else if (j < 0x5db3d7i) { // |x| < sqrt(3)
            k = 1i;
        } else {
            k = 0i;
            n = n + 1i;
            ix = ix - 0x00800000i;
        }
        ax = bitcast<f32>(ix);
        let bp = select(1.0f, 1.5f, k == 1i);
        let dp_h = select(0.0f, 0.58496094f, k == 1i);
        let dp_l = select(0.0f, 1.5632208e-06f, k == 1i);
        // s = s_h + s_l = (x - 1) / (x + 1) or (x - 1.5) / (x + 1.5)
        let u = ax - bp;
        let v = 1.0f / (ax + bp);
        let s = u * v;
        let s_h = bitcast<f32>(bitcast<i32>(s) & bitcast<i32>(0xfffff000u));
        // t_h = ax + bp, high part
        let t_h = bitcast<f32>((((ix >> 1u) & bitcast<i32>(0xfffff000u)) | 0x20000000i) + 0x00400000i
            + (k << 21u));
        let t_l = ax - (t_h - bp);
        let s_l = v * ((u - s_h * t_h) - s_h * t_l);
        // log(ax)
        var s2 = s * s;
        var r = s2 * s2 * (0.6f + s2 * (0.42857143f + s2 * (0.33333334f + s2 * (0.27272812f
            + s2 * (0.23066075f + s2 * 0.20697501f)))));
        r = r + s_l * (s_h + s);
        s2 = s_h * s_h;
        let t_h2 = bitcast<f32>(bitcast<i32>(3.0f + s2 + r) & bitcast<i32>(0xfffff000u));
        let t_l2 = r - ((t_h2 - 3.0f) - s2);
        // u + v = s * (1 + ...)
        let u2 = s_h * t_h2;
        let v2 = s_l * t_h2 + t_l2 * s;
        // 2 / (3 log2) * (s + ...)
        let p_h = bitcast<f32>(bitcast<i32>(u2 + v2) & bitcast<i32>(0xfffff000u));
        let p_l = v2 - (p_h - u2);
        let z_h = 0.96191406f * p_h; // cp_h + cp_l = 2 / (3 log 2)
        let z_l = -0.000117368574f * p_h + p_l * 0.9617967f + dp_l;
        // log2(ax) = (s + ...) * 2 / (3 log 2) = n + dp_h + z_h + z_l
        let t = f32(n);
        t1 = bitcast<f32>(bitcast<i32>(((z_h + z_l) + dp_h) + t) & bitcast<i32>(0xfffff000u));
        t2 = z_l - (((t1 - t) - dp_h) - z_h);
    }
    // (y1 + y2) * (t1 + t2), y split
    let y1 = bitcast<f32>(hy & bitcast<i32>(0xfffff000u));
    let p_l = (y - y1) * t1 + y * t2;
    var p_h = y1 * t1;
    let z = p_l + p_h;
    let j = bitcast<i32>(z);
    if (j > 0x43000000i) { // z > 128
        return sn_inf();
    } else if (j == 0x43000000i) { // z == 128
        if (p_l + 4.2995666e-08f > z - sn_o(p_h, kk)) {
            return sn_inf();
        }
    } else if ((j & 0x7fffffffi) > 0x43160000i) { // z < -150
        return 0.0f;
    } else if (j == bitcast<i32>(0xc3160000u)) { // z == -150
        if (p_l <= z - sn_o(p_h, kk)) {
            return 0.0f;
        }
    }
    // 2^(p_h + p_l)
    let i = j & 0x7fffffffi;
    var k2 = (i >> 23u) - 0x7fi;
    var n2 = 0i;
    if (i > 0x3f000000i) { // |z| > 0.5: n = [z + 0.5]
        n2 = j + (0x00800000i >> u32(k2 + 1i));
        k2 = ((n2 & 0x7fffffffi) >> 23u) - 0x7fi; // new k for n
        let t = bitcast<f32>(n2 & ~(0x007fffffi >> u32(k2)));
        n2 = ((n2 & 0x007fffffi) | 0x00800000i) >> u32(23i - k2);
        if (j < 0i) {
            n2 = -n2;
        }
        p_h = p_h - t;
    }
    let t = bitcast<f32>(bitcast<i32>(p_l + p_h) & bitcast<i32>(0xffff8000u));
    let u = t * 0.69314575f;
    let v = (p_l - (t - p_h)) * 0.6931472f + t * 1.4286065e-06f;
    let z2 = u + v;
    let w = v - (z2 - sn_o(u, kk));
    let tt = z2 * z2;
    let tt1 = z2 - tt * (0.16666667f + tt * (-0.0027777778f + tt * (6.613756e-05f
        + tt * (-1.6533902e-06f + tt * 4.138137e-08f))));
    let r = (z2 * tt1) / (tt1 - 2.0f) - (w + z2 * w);
    let z3 = 1.0f - (r - z2);
    let jj = bitcast<i32>(z3) + (n2 << 23u);
    if ((jj >> 23u) <= 0i) { // subnormal output
        return sn_scalbn(z3, n2);
    }
    return bitcast<f32>(jj);
}

// ops::pow: 0 for a negative base with a non-integer exponent, 0 for 0^negative; otherwise
// Rust's powf, its special cases (C99 Annex F) written out, sn_pow_pos for a finite non-zero
// base and a finite exponent, negated for a negative base and an odd integer exponent.
fn sn_pow(a: f32, b: f32, k: u32) -> f32 {
    if (a < 0.0f && (sn_is_nan(b) || trunc(b) != b)) {
        return 0.0f;
    }
    if (a == 0.0f && b < 0.0f) {
        return 0.0f;
    }
    if (sn_is_snan(a) || sn_is_snan(b)) {
        return sn_nan(); // glibc: a signaling NaN gives NaN, even for pow(sNaN, 0), pow(1, sNaN)
    }
    if (b == 0.0f || a == 1.0f) {
        return 1.0f; // pow(x, ±0) = 1 and pow(1, y) = 1, a quiet NaN included
    }
    if (sn_is_nan(a) || sn_is_nan(b)) {
        return sn_nan();
    }
    let ax = abs(a);
    if (sn_is_inf(b)) {
        if (ax == 1.0f) {
            return 1.0f; // pow(-1, ±inf) = 1
        }
        return select(0.0f, sn_inf(), (ax < 1.0f) == (b < 0.0f));
    }
    let odd = sn_is_odd_integer(b);
    if (ax == 0.0f) {
        // b > 0 here: ±0 for an odd integer exponent, +0 otherwise.
        return select(0.0f, a, odd);
    }
    var r: f32;
    if (sn_is_inf(ax)) {
        r = select(sn_inf(), 0.0f, b < 0.0f);
    } else if (ax == 1.0f) {
        r = 1.0f; // (-1)^integer
    } else {
        r = sn_pow_pos(ax, b, k);
    }
    return select(r, -r, a < 0.0f && odd);
}

// ---- integers (wrapping; division and modulo by zero give 0) ----

fn sn_ineg(a: i32) -> i32 {
    return bitcast<i32>(0u - bitcast<u32>(a));
}

fn sn_iabs(a: i32) -> i32 {
    return select(a, sn_ineg(a), a < 0i);
}

// a.wrapping_div(b), 0 where b == 0 (i32::MIN / -1 = i32::MIN).
fn sn_idiv(a: i32, b: i32) -> i32 {
    if (b == 0i) {
        return 0i;
    }
    if (b == -1i) {
        return sn_ineg(a);
    }
    return a / b;
}

// a.wrapping_rem_euclid(b), 0 where b == 0.
fn sn_imod(a: i32, b: i32) -> i32 {
    if (b == 0i || b == -1i) {
        return 0i; // x rem -1 is 0 (and i32::MIN % -1 must not run)
    }
    let r = a % b; // truncated: the sign of a
    if (r < 0i) {
        return bitcast<i32>(bitcast<u32>(r) + bitcast<u32>(sn_iabs(b)));
    }
    return r;
}

// Rust `x as i32`: truncation toward zero, saturating, NaN -> 0.
fn sn_f2i(x: f32) -> i32 {
    if (sn_is_nan(x)) {
        return 0i;
    }
    if (x >= 2147483648.0f) {
        return 2147483647i;
    }
    if (x < -2147483648.0f) {
        return bitcast<i32>(0x80000000u);
    }
    return i32(x);
}

// ---- vectors and matrices (sums left to right, as ops::dot) ----

// 0 + p, as the CPU's sums start: +0 for either zero, p otherwise. Written on the bits:
// Mesa folds a literal `0.0 + p` to p, which keeps a -0.
fn sn_plus_zero(p: f32) -> f32 {
    return bitcast<f32>(bitcast<u32>(p) & select(0xffffffffu, 0x7fffffffu, p == 0.0f));
}

fn sn_dot2(a: vec2<f32>, b: vec2<f32>) -> f32 {
    return sn_plus_zero(a.x * b.x) + a.y * b.y;
}

fn sn_dot3(a: vec3<f32>, b: vec3<f32>) -> f32 {
    return (sn_plus_zero(a.x * b.x) + a.y * b.y) + a.z * b.z;
}

fn sn_dot4(a: vec4<f32>, b: vec4<f32>) -> f32 {
    return ((sn_plus_zero(a.x * b.x) + a.y * b.y) + a.z * b.z) + a.w * b.w;
}

fn sn_length2(v: vec2<f32>) -> f32 {
    return sn_sqrt(sn_dot2(v, v));
}

fn sn_length3(v: vec3<f32>) -> f32 {
    return sn_sqrt(sn_dot3(v, v));
}

fn sn_length4(v: vec4<f32>) -> f32 {
    return sn_sqrt(sn_dot4(v, v));
}

fn sn_normalize2(v: vec2<f32>) -> vec2<f32> {
    let l = sn_length2(v);
    return vec2<f32>(sn_div(v.x, l), sn_div(v.y, l));
}

fn sn_normalize3(v: vec3<f32>) -> vec3<f32> {
    let l = sn_length3(v);
    return vec3<f32>(sn_div(v.x, l), sn_div(v.y, l), sn_div(v.z, l));
}

fn sn_normalize4(v: vec4<f32>) -> vec4<f32> {
    let l = sn_length4(v);
    return vec4<f32>(sn_div(v.x, l), sn_div(v.y, l), sn_div(v.z, l), sn_div(v.w, l));
}

// ops::cross; the second product of each component through the key (k: see sn_o), so that
// no product shares an operand the compiler could factor out with the other.
fn sn_cross(a: vec3<f32>, b: vec3<f32>, k: u32) -> vec3<f32> {
    return vec3<f32>(
        a.y * b.z - sn_o(a.z * b.y, k),
        a.z * b.x - sn_o(a.x * b.z, k),
        a.x * b.y - sn_o(a.y * b.x, k),
    );
}

// M * (p, 1), M row-major (rows are the array's elements), the w row ignored; summed left to
// right, every product after the first through the key (see sn_cross).
fn sn_mul_point(m: array<vec4<f32>, 4>, p: vec3<f32>, k: u32) -> vec3<f32> {
    return vec3<f32>(
        ((m[0].x * p.x + sn_o(m[0].y * p.y, k)) + sn_o(m[0].z * p.z, k)) + m[0].w,
        ((m[1].x * p.x + sn_o(m[1].y * p.y, k)) + sn_o(m[1].z * p.z, k)) + m[1].w,
        ((m[2].x * p.x + sn_o(m[2].y * p.y, k)) + sn_o(m[2].z * p.z, k)) + m[2].w,
    );
}

// M * (v, 0).
fn sn_mul_vector(m: array<vec4<f32>, 4>, v: vec3<f32>, k: u32) -> vec3<f32> {
    return vec3<f32>(
        (m[0].x * v.x + sn_o(m[0].y * v.y, k)) + sn_o(m[0].z * v.z, k),
        (m[1].x * v.x + sn_o(m[1].y * v.y, k)) + sn_o(m[1].z * v.z, k),
        (m[2].x * v.x + sn_o(m[2].y * v.y, k)) + sn_o(m[2].z * v.z, k),
    );
}

// ---- GGX directional albedo (ops::ggx_albedo) ----

// The albedo tables live in the storage buffer `sn_tables` (`emit::albedo_tables`, the CPU's
// tables end to end), which a kernel binds when its library reads it: as `var<private>`
// arrays every invocation would hold a copy, and lavapipe took minutes to compile a kernel
// with them. The GGX table, (A, B) pairs at 32 √cos θo nodes by 32 α^¼ nodes, is at 0.

// A coordinate clamped to [0, 1] (NaN to 0) on an axis of n nodes: (node, fraction).
fn sn_ggx_axis(x: f32, n: i32) -> vec2<f32> {
    let a = select(0.0f, x, x > 0.0f);
    let b = select(1.0f, a, a < 1.0f);
    let s = b * f32(n - 1i);
    let k = min(max(sn_f2i(floor(s)), 0i), n - 2i);
    return vec2<f32>(f32(k), s - f32(k));
}

// ops::ggx_albedo::bilinear: the table at `base` (node (i, j) at base + (j·row + i)·stride)
// interpolated at the axis positions x and y ((node, fraction) each), in the CPU's order.
fn sn_table_bilinear(base: i32, row: i32, stride: i32, x: vec2<f32>, y: vec2<f32>) -> f32 {
    let i = i32(x.x);
    let j = i32(y.x);
    let a = sn_tables[base + (j * row + i) * stride];
    let b = sn_tables[base + (j * row + i + 1i) * stride];
    let c = sn_tables[base + ((j + 1i) * row + i) * stride];
    let d = sn_tables[base + ((j + 1i) * row + i + 1i) * stride];
    let lo = a + (b - a) * x.y;
    let hi = c + (d - c) * x.y;
    return lo + (hi - lo) * y.y;
}

// ops::ggx_albedo::ggx_albedo: bilinear in √cos θo and α^¼.
fn sn_ggx_albedo(c: f32, alpha: f32) -> vec2<f32> {
    let x = sn_ggx_axis(sn_sqrt(c), 32i);
    let y = sn_ggx_axis(sn_sqrt(sn_sqrt(alpha)), 32i);
    return vec2<f32>(sn_table_bilinear(0i, 32i, 2i, x, y), sn_table_bilinear(1i, 32i, 2i, x, y));
}

// ---- dielectric directional albedo (ops::dielectric_albedo) ----

// 16 √cos θo nodes by 16 α^¼ nodes by 13 F0^¼ nodes, in `sn_tables` after the GGX table
// (at 2048).

// ops::dielectric_albedo::dielectric_albedo: trilinear in √cos θo, α^¼ and √(|η − 1|/(η + 1)).
fn sn_dielectric_albedo(c: f32, alpha: f32, etap: f32) -> f32 {
    let x = sn_ggx_axis(sn_sqrt(c), 16i);
    let y = sn_ggx_axis(sn_sqrt(sn_sqrt(alpha)), 16i);
    let e0 = select(0.0f, etap, etap > 0.0f);
    let e = select(1e30f, e0, e0 < 1e30f);
    let z = sn_ggx_axis(sn_sqrt(abs(e - 1.0f) / (e + 1.0f)), 13i);
    let k = i32(z.x);
    let p0 = sn_table_bilinear(2048i + k * 256i, 16i, 1i, x, y);
    let p1 = sn_table_bilinear(2048i + (k + 1i) * 256i, 16i, 1i, x, y);
    return p0 + (p1 - p0) * z.y;
}

// ---- sheen directional albedo (ops::sheen_albedo) ----

// (E, G) pairs, 32 √cos θo nodes by 12 (r^(1/32) − r₀^(1/32))/(1 − r₀^(1/32)) nodes
// (r₀ = 0.005), in `sn_tables` after the dielectric table (at 2048 + 3328 = 5376).

// ops::sheen_albedo::sheen_albedo: bilinear in √cos θo and
// (r^(1/32) − r₀^(1/32))/(1 − r₀^(1/32)), five square roots and no logarithm.
fn sn_sheen_albedo(c: f32, roughness: f32) -> vec2<f32> {
    let x = sn_ggx_axis(sn_sqrt(c), 32i);
    let r = select(0.005f, roughness, roughness > 0.005f);
    let y = sn_ggx_axis((sn_sqrt(sn_sqrt(sn_sqrt(sn_sqrt(sn_sqrt(r))))) - SN_SHEEN_ROOT_MIN) * SN_SHEEN_INV_SPAN, 12i);
    return vec2<f32>(
        sn_table_bilinear(5376i, 32i, 2i, x, y),
        sn_table_bilinear(5377i, 32i, 2i, x, y),
    );
}

// ---- noise (ops::noise) ----

// Ken Perlin's reference permutation (Improved Noise, 2002): `emit::library()` writes
// the CPU's table (`ops::noise::PERM`) in place of SN_PERM_ENTRIES.
var<private> SN_PERM: array<i32, 256> = array<i32, 256>(SN_PERM_ENTRIES);

fn sn_perm(i: i32) -> i32 {
    return SN_PERM[i & 255i];
}

// Wrapping i32 addition.
fn sn_iadd(a: i32, b: i32) -> i32 {
    return bitcast<i32>(bitcast<u32>(a) + bitcast<u32>(b));
}

fn sn_fade(t: f32) -> f32 {
    return t * t * t * (t * (t * 6.0f - 15.0f) + 10.0f);
}

fn sn_lerp(t: f32, a: f32, b: f32) -> f32 {
    return a + t * (b - a);
}

fn sn_grad(hash: i32, x: f32, y: f32, z: f32) -> f32 {
    let h = hash & 15i;
    let u = select(y, x, h < 8i);
    let v = select(select(z, x, h == 12i || h == 14i), y, h < 4i);
    return select(-u, u, (h & 1i) == 0i) + select(-v, v, (h & 2i) == 0i);
}

// The fractional offset in a lattice cell (0 for a non-finite coordinate).
fn sn_cell_frac(x: f32) -> f32 {
    let frac = x - floor(x);
    return select(0.0f, frac, sn_is_finite(frac));
}

fn sn_noise3(p: vec3<f32>) -> f32 {
    let xi = sn_f2i(floor(p.x));
    let yi = sn_f2i(floor(p.y));
    let zi = sn_f2i(floor(p.z));
    let x = sn_cell_frac(p.x);
    let y = sn_cell_frac(p.y);
    let z = sn_cell_frac(p.z);
    let u = sn_fade(x);
    let v = sn_fade(y);
    let w = sn_fade(z);
    let a = sn_iadd(sn_perm(xi), yi);
    let aa = sn_iadd(sn_perm(a), zi);
    let ab = sn_iadd(sn_perm(sn_iadd(a, 1i)), zi);
    let b = sn_iadd(sn_perm(sn_iadd(xi, 1i)), yi);
    let ba = sn_iadd(sn_perm(b), zi);
    let bb = sn_iadd(sn_perm(sn_iadd(b, 1i)), zi);
    return sn_lerp(
        w,
        sn_lerp(
            v,
            sn_lerp(u, sn_grad(sn_perm(aa), x, y, z), sn_grad(sn_perm(ba), x - 1.0f, y, z)),
            sn_lerp(
                u,
                sn_grad(sn_perm(ab), x, y - 1.0f, z),
                sn_grad(sn_perm(bb), x - 1.0f, y - 1.0f, z),
            ),
        ),
        sn_lerp(
            v,
            sn_lerp(
                u,
                sn_grad(sn_perm(sn_iadd(aa, 1i)), x, y, z - 1.0f),
                sn_grad(sn_perm(sn_iadd(ba, 1i)), x - 1.0f, y, z - 1.0f),
            ),
            sn_lerp(
                u,
                sn_grad(sn_perm(sn_iadd(ab, 1i)), x, y - 1.0f, z - 1.0f),
                sn_grad(sn_perm(sn_iadd(bb, 1i)), x - 1.0f, y - 1.0f, z - 1.0f),
            ),
        ),
    );
}

// grad(hash, x, y, +0) with the IEEE result of the `+ 0` terms written out (see sn_noise2).
fn sn_grad_z0(hash: i32, x: f32, y: f32) -> f32 {
    let h = hash & 15i;
    let u = select(y, x, h < 8i);
    let su = select(-u, u, (h & 1i) == 0i);
    if (h < 4i || h == 12i || h == 14i) {
        let v = select(x, y, h < 4i);
        return su + select(-v, v, (h & 2i) == 0i);
    }
    // v = z = +0: su + (+0) (+0 for either zero) or su + (-0) (su).
    return select(su, sn_plus_zero(su), (h & 2i) == 0i);
}

// noise3(x, y, 0), the same IEEE operations with the constant z = +0 evaluated by hand:
// Mesa folds `a + 0.0` to `a` and `0.0 * a` to `0.0`, which would change signed zeros where
// the CPU adds or multiplies an exact zero (z, fade(z) = +0).
fn sn_noise2(p: vec2<f32>) -> f32 {
    let xi = sn_f2i(floor(p.x));
    let yi = sn_f2i(floor(p.y));
    let x = sn_cell_frac(p.x);
    let y = sn_cell_frac(p.y);
    let u = sn_fade(x);
    let v = sn_fade(y);
    // zi = 0: perm(.) + zi = perm(.)
    let a = sn_iadd(sn_perm(xi), yi);
    let aa = sn_perm(a);
    let ab = sn_perm(sn_iadd(a, 1i));
    let b = sn_iadd(sn_perm(sn_iadd(xi, 1i)), yi);
    let ba = sn_perm(b);
    let bb = sn_perm(sn_iadd(b, 1i));
    let front = sn_lerp(
        v,
        sn_lerp(u, sn_grad_z0(sn_perm(aa), x, y), sn_grad_z0(sn_perm(ba), x - 1.0f, y)),
        sn_lerp(
            u,
            sn_grad_z0(sn_perm(ab), x, y - 1.0f),
            sn_grad_z0(sn_perm(bb), x - 1.0f, y - 1.0f),
        ),
    );
    // z - 1 = -1 (a non-zero constant: no fold changes these).
    let back = sn_lerp(
        v,
        sn_lerp(
            u,
            sn_grad(sn_perm(sn_iadd(aa, 1i)), x, y, -1.0f),
            sn_grad(sn_perm(sn_iadd(ba, 1i)), x - 1.0f, y, -1.0f),
        ),
        sn_lerp(
            u,
            sn_grad(sn_perm(sn_iadd(ab, 1i)), x, y - 1.0f, -1.0f),
            sn_grad(sn_perm(sn_iadd(bb, 1i)), x - 1.0f, y - 1.0f, -1.0f),
        ),
    );
    // lerp(w, front, back) with w = fade(+0) = +0: front + (+0) * (back - front), where
    // (+0) * d is a zero with the sign of d (NaN for a NaN d).
    let d = back - front;
    let zd = select(bitcast<f32>(bitcast<u32>(d) & 0x80000000u), d, sn_is_nan(d));
    return front + zd;
}

// Σ_{i < octaves} gain^i · noise3(p · lacunarity^i), octaves clamped to [0, 16].
fn sn_fbm3(p: vec3<f32>, octaves: i32, lacunarity: f32, gain: f32) -> f32 {
    var sum = 0.0f;
    var amp = 1.0f;
    var freq = 1.0f;
    let n = clamp(octaves, 0i, 16i);
    for (var i = 0i; i < n; i++) {
        sum = sum + amp * sn_noise3(p * freq);
        amp = amp * gain;
        freq = freq * lacunarity;
    }
    return sum;
}

// A value in [0, 1) constant over each unit cell floor(p): 24 bits of an integer hash.
fn sn_cellnoise3(p: vec3<f32>) -> f32 {
    var h = 0x9e3779b9u;
    for (var k = 0i; k < 3i; k++) {
        let i = bitcast<u32>(sn_f2i(floor(p[k])));
        h = h ^ (i * 0x85ebca6bu);
        h = ((h << 13u) | (h >> 19u)) * 0xc2b2ae35u;
    }
    h = h ^ (h >> 16u);
    h = h * 0x7feb352du;
    h = h ^ (h >> 15u);
    h = h * 0x846ca68bu;
    h = h ^ (h >> 16u);
    return f32(h >> 8u) / 16777216.0f;
}

// ---- OSL / MaterialX noise (ops::osl_noise), ported line by line ----

// x rotated left by k (0 < k < 32).
fn sn_rotl(x: u32, k: u32) -> u32 {
    return (x << k) | (x >> (32u - k));
}

// OpenImageIO bjhash::bjmix.
fn sn_bjmix(a_in: u32, b_in: u32, c_in: u32) -> vec3<u32> {
    var a = a_in;
    var b = b_in;
    var c = c_in;
    a -= c; a ^= sn_rotl(c, 4u); c += b;
    b -= a; b ^= sn_rotl(a, 6u); a += c;
    c -= b; c ^= sn_rotl(b, 8u); b += a;
    a -= c; a ^= sn_rotl(c, 16u); c += b;
    b -= a; b ^= sn_rotl(a, 19u); a += c;
    c -= b; c ^= sn_rotl(b, 4u); b += a;
    return vec3<u32>(a, b, c);
}

// OpenImageIO bjhash::bjfinal.
fn sn_bjfinal(a_in: u32, b_in: u32, c_in: u32) -> u32 {
    var a = a_in;
    var b = b_in;
    var c = c_in;
    c ^= b; c -= sn_rotl(b, 14u);
    a ^= c; a -= sn_rotl(c, 11u);
    b ^= a; b -= sn_rotl(a, 25u);
    c ^= b; c -= sn_rotl(b, 16u);
    a ^= c; a -= sn_rotl(c, 4u);
    b ^= a; b -= sn_rotl(a, 14u);
    c ^= b; c -= sn_rotl(b, 24u);
    return c;
}

// OSL inthash of two and three keys (start value 0xdeadbeef + (len << 2) + 13).
fn sn_inthash2(x: u32, y: u32) -> u32 {
    let s = 0xdeadbeefu + 21u;
    return sn_bjfinal(s + x, s + y, s);
}

fn sn_inthash3(x: u32, y: u32, z: u32) -> u32 {
    let s = 0xdeadbeefu + 25u;
    return sn_bjfinal(s + x, s + y, s + z);
}

// OSL bits_to_01: the f32 nearest h (one rounding: f32(h >> 8) * 256 and f32(h & 255) are
// exact, their sum rounds once), times 2^-32.
fn sn_bits_to_01(h: u32) -> f32 {
    return (f32(h >> 8u) * 256.0f + f32(h & 255u)) * 2.3283064365386963e-10f;
}

// f32(i) rounded to nearest (the same split as sn_bits_to_01; `i >> 8` is arithmetic).
fn sn_itof(i: i32) -> f32 {
    return f32(i >> 8u) * 256.0f + f32(i & 255i);
}

// OSL ifloor as an unsigned hash key (saturating, NaN -> 0).
fn sn_osl_ifloor(x: f32) -> u32 {
    return bitcast<u32>(sn_f2i(floor(x)));
}

fn sn_osl_grad2(hash: u32, x: f32, y: f32) -> f32 {
    let h = hash & 7u;
    let u = select(y, x, h < 4u);
    let v = 2.0f * select(x, y, h < 4u);
    return select(u, -u, (h & 1u) != 0u) + select(v, -v, (h & 2u) != 0u);
}

fn sn_osl_grad3(hash: u32, x: f32, y: f32, z: f32) -> f32 {
    let h = hash & 15u;
    let u = select(y, x, h < 8u);
    let v = select(select(z, x, h == 12u || h == 14u), y, h < 4u);
    return select(u, -u, (h & 1u) != 0u) + select(v, -v, (h & 2u) != 0u);
}

// OIIO::bilerp.
fn sn_osl_bilerp(v0: f32, v1: f32, v2: f32, v3: f32, s: f32, t: f32) -> f32 {
    let s1 = 1.0f - s;
    return (1.0f - t) * (v0 * s1 + v1 * s) + t * (v2 * s1 + v3 * s);
}

// OIIO::trilerp.
fn sn_osl_trilerp(v: array<f32, 8>, s: f32, t: f32, r: f32) -> f32 {
    let s1 = 1.0f - s;
    let t1 = 1.0f - t;
    let r1 = 1.0f - r;
    return r1 * (t1 * (v[0] * s1 + v[1] * s) + t * (v[2] * s1 + v[3] * s))
        + r * (t1 * (v[4] * s1 + v[5] * s) + t * (v[6] * s1 + v[7] * s));
}

// The hashes of a 2D cell's corners, in bilerp's order.
fn sn_osl_corners2(x: u32, y: u32) -> vec4<u32> {
    return vec4<u32>(
        sn_inthash2(x, y),
        sn_inthash2(x + 1u, y),
        sn_inthash2(x, y + 1u),
        sn_inthash2(x + 1u, y + 1u),
    );
}

// The hashes of a 3D cell's corners, in trilerp's order (bit 0: x + 1, bit 1: y + 1,
// bit 2: z + 1).
fn sn_osl_corners3(x: u32, y: u32, z: u32) -> array<u32, 8> {
    var h: array<u32, 8>;
    for (var k = 0u; k < 8u; k++) {
        h[k] = sn_inthash3(x + (k & 1u), y + ((k >> 1u) & 1u), z + ((k >> 2u) & 1u));
    }
    return h;
}

// f - 1 where bit `bit` of corner k is set, f otherwise.
fn sn_osl_off(f: f32, k: u32, bit: u32) -> f32 {
    return select(f, f - 1.0f, ((k >> bit) & 1u) == 1u);
}

// bilerp of the 2D gradients of byte `shift / 8` of each corner hash (shift 0 and mask
// 0xffffffff: the scalar noise).
fn sn_osl_perlin2_of(h: vec4<u32>, shift: u32, mask: u32, fx: f32, fy: f32) -> f32 {
    let r = sn_osl_bilerp(
        sn_osl_grad2((h.x >> shift) & mask, fx, fy),
        sn_osl_grad2((h.y >> shift) & mask, fx - 1.0f, fy),
        sn_osl_grad2((h.z >> shift) & mask, fx, fy - 1.0f),
        sn_osl_grad2((h.w >> shift) & mask, fx - 1.0f, fy - 1.0f),
        sn_fade(fx),
        sn_fade(fy),
    );
    return 0.6616f * r;
}

fn sn_osl_perlin3_of(h: array<u32, 8>, shift: u32, mask: u32, f: vec3<f32>) -> f32 {
    var g: array<f32, 8>;
    for (var k = 0u; k < 8u; k++) {
        g[k] = sn_osl_grad3(
            (h[k] >> shift) & mask,
            sn_osl_off(f.x, k, 0u),
            sn_osl_off(f.y, k, 1u),
            sn_osl_off(f.z, k, 2u),
        );
    }
    return 0.9820f * sn_osl_trilerp(g, sn_fade(f.x), sn_fade(f.y), sn_fade(f.z));
}

fn sn_osl_perlin2(p: vec2<f32>) -> f32 {
    let h = sn_osl_corners2(sn_osl_ifloor(p.x), sn_osl_ifloor(p.y));
    return sn_osl_perlin2_of(h, 0u, 0xffffffffu, sn_cell_frac(p.x), sn_cell_frac(p.y));
}

fn sn_osl_perlin3(p: vec3<f32>) -> f32 {
    let h = sn_osl_corners3(sn_osl_ifloor(p.x), sn_osl_ifloor(p.y), sn_osl_ifloor(p.z));
    let f = vec3<f32>(sn_cell_frac(p.x), sn_cell_frac(p.y), sn_cell_frac(p.z));
    return sn_osl_perlin3_of(h, 0u, 0xffffffffu, f);
}

// OSL HashVector's sliceup: component c from byte c of each corner hash.
fn sn_osl_vperlin2_of(h: vec4<u32>, p: vec2<f32>) -> vec3<f32> {
    let fx = sn_cell_frac(p.x);
    let fy = sn_cell_frac(p.y);
    return vec3<f32>(
        sn_osl_perlin2_of(h, 0u, 255u, fx, fy),
        sn_osl_perlin2_of(h, 8u, 255u, fx, fy),
        sn_osl_perlin2_of(h, 16u, 255u, fx, fy),
    );
}

fn sn_osl_vperlin2(p: vec2<f32>) -> vec3<f32> {
    return sn_osl_vperlin2_of(sn_osl_corners2(sn_osl_ifloor(p.x), sn_osl_ifloor(p.y)), p);
}

fn sn_osl_vperlin3_of(h: array<u32, 8>, p: vec3<f32>) -> vec3<f32> {
    let f = vec3<f32>(sn_cell_frac(p.x), sn_cell_frac(p.y), sn_cell_frac(p.z));
    return vec3<f32>(
        sn_osl_perlin3_of(h, 0u, 255u, f),
        sn_osl_perlin3_of(h, 8u, 255u, f),
        sn_osl_perlin3_of(h, 16u, 255u, f),
    );
}

fn sn_osl_vperlin3(p: vec3<f32>) -> vec3<f32> {
    let h = sn_osl_corners3(sn_osl_ifloor(p.x), sn_osl_ifloor(p.y), sn_osl_ifloor(p.z));
    return sn_osl_vperlin3_of(h, p);
}

// OSL inthashVec of one to four keys (component c hashed as one more key; three and four
// keys share one bjmix): cell noise hashes the floors, hash noise the bits.
fn sn_osl_vhash_keys1(x: u32) -> vec3<f32> {
    return vec3<f32>(
        sn_bits_to_01(sn_inthash2(x, 0u)),
        sn_bits_to_01(sn_inthash2(x, 1u)),
        sn_bits_to_01(sn_inthash2(x, 2u)),
    );
}

fn sn_osl_vhash_keys2(x: u32, y: u32) -> vec3<f32> {
    return vec3<f32>(
        sn_bits_to_01(sn_inthash3(x, y, 0u)),
        sn_bits_to_01(sn_inthash3(x, y, 1u)),
        sn_bits_to_01(sn_inthash3(x, y, 2u)),
    );
}

// Three keys: one bjmix, then bjfinal(a + component, b, c).
fn sn_osl_vhash_keys3(k: vec3<u32>) -> vec3<f32> {
    let s = 0xdeadbeefu + 29u;
    let m = sn_bjmix(s + k.x, s + k.y, s + k.z);
    return vec3<f32>(
        sn_bits_to_01(sn_bjfinal(m.x, m.y, m.z)),
        sn_bits_to_01(sn_bjfinal(m.x + 1u, m.y, m.z)),
        sn_bits_to_01(sn_bjfinal(m.x + 2u, m.y, m.z)),
    );
}

// Four keys (five with the component): one bjmix of x, y, z, then bjfinal(a + w, b +
// component, c).
fn sn_osl_vhash_keys4(k: vec3<u32>, w: u32) -> vec3<f32> {
    let s = 0xdeadbeefu + 33u;
    let m = sn_bjmix(s + k.x, s + k.y, s + k.z);
    let a = m.x + w;
    return vec3<f32>(
        sn_bits_to_01(sn_bjfinal(a, m.y, m.z)),
        sn_bits_to_01(sn_bjfinal(a, m.y + 1u, m.z)),
        sn_bits_to_01(sn_bjfinal(a, m.y + 2u, m.z)),
    );
}

fn sn_osl_ifloor3(p: vec3<f32>) -> vec3<u32> {
    return vec3<u32>(sn_osl_ifloor(p.x), sn_osl_ifloor(p.y), sn_osl_ifloor(p.z));
}

fn sn_osl_cell1(x: f32) -> f32 {
    return sn_bits_to_01(sn_osl_inthash1(sn_osl_ifloor(x)));
}

fn sn_osl_cell2(p: vec2<f32>) -> f32 {
    return sn_bits_to_01(sn_inthash2(sn_osl_ifloor(p.x), sn_osl_ifloor(p.y)));
}

fn sn_osl_cell3(p: vec3<f32>) -> f32 {
    let k = sn_osl_ifloor3(p);
    return sn_bits_to_01(sn_inthash3(k.x, k.y, k.z));
}

fn sn_osl_cell4(p: vec3<f32>, t: f32) -> f32 {
    let k = sn_osl_ifloor3(p);
    return sn_bits_to_01(sn_osl_inthash4(k.x, k.y, k.z, sn_osl_ifloor(t)));
}

fn sn_osl_vcell1(x: f32) -> vec3<f32> {
    return sn_osl_vhash_keys1(sn_osl_ifloor(x));
}

fn sn_osl_vcell2(p: vec2<f32>) -> vec3<f32> {
    return sn_osl_vhash_keys2(sn_osl_ifloor(p.x), sn_osl_ifloor(p.y));
}

fn sn_osl_vcell3(p: vec3<f32>) -> vec3<f32> {
    return sn_osl_vhash_keys3(sn_osl_ifloor3(p));
}

fn sn_osl_vcell4(p: vec3<f32>, t: f32) -> vec3<f32> {
    return sn_osl_vhash_keys4(sn_osl_ifloor3(p), sn_osl_ifloor(t));
}

// OSL 1D grad: x times one of +-1 ... +-8.
fn sn_osl_grad1(hash: u32, x: f32) -> f32 {
    let h = hash & 15u;
    let g = f32(1u + (h & 7u));
    return select(g, -g, (h & 8u) != 0u) * x;
}

// OSL 4D grad: the dot product with a vector to one of the hypercube's edges.
fn sn_osl_grad4(hash: u32, x: f32, y: f32, z: f32, w: f32) -> f32 {
    let h = hash & 31u;
    let u = select(y, x, h < 24u);
    let v = select(z, y, h < 16u);
    let s = select(w, z, h < 8u);
    return select(u, -u, (h & 1u) != 0u) + select(v, -v, (h & 2u) != 0u)
        + select(s, -s, (h & 4u) != 0u);
}

// OIIO::lerp: a (1 - t) + b t.
fn sn_osl_lerp(a: f32, b: f32, t: f32) -> f32 {
    return a * (1.0f - t) + b * t;
}

// OSL inthash of four keys (start 0xdeadbeef + 29): one bjmix, then bjfinal(a + w, b, c).
fn sn_osl_inthash4(x: u32, y: u32, z: u32, w: u32) -> u32 {
    let s = 0xdeadbeefu + 29u;
    let m = sn_bjmix(s + x, s + y, s + z);
    return sn_bjfinal(m.x + w, m.y, m.z);
}

// OSL inthash of one key (start 0xdeadbeef + 17).
fn sn_osl_inthash1(x: u32) -> u32 {
    let s = 0xdeadbeefu + 17u;
    return sn_bjfinal(s + x, s, s);
}

// 1D Perlin of byte `shift / 8` of the two corner hashes (mask 0xffffffff: the scalar).
fn sn_osl_perlin1_of(h0: u32, h1: u32, shift: u32, mask: u32, f: f32) -> f32 {
    let g0 = sn_osl_grad1((h0 >> shift) & mask, f);
    let g1 = sn_osl_grad1((h1 >> shift) & mask, f - 1.0f);
    return 0.25f * sn_osl_lerp(g0, g1, sn_fade(f));
}

fn sn_osl_perlin1(x: f32) -> f32 {
    let i = sn_osl_ifloor(x);
    return sn_osl_perlin1_of(sn_osl_inthash1(i), sn_osl_inthash1(i + 1u), 0u, 0xffffffffu,
        sn_cell_frac(x));
}

// Vector 1D Perlin: component c from byte c of the two corner hashes `h`.
fn sn_osl_vperlin1_of(h: vec2<u32>, f: f32) -> vec3<f32> {
    return vec3<f32>(
        sn_osl_perlin1_of(h.x, h.y, 0u, 255u, f),
        sn_osl_perlin1_of(h.x, h.y, 8u, 255u, f),
        sn_osl_perlin1_of(h.x, h.y, 16u, 255u, f),
    );
}

fn sn_osl_vperlin1(x: f32) -> vec3<f32> {
    let i = sn_osl_ifloor(x);
    let h = vec2<u32>(sn_osl_inthash1(i), sn_osl_inthash1(i + 1u));
    return sn_osl_vperlin1_of(h, sn_cell_frac(x));
}

// The hashes of a 4D cell's corners: trilerp's order at w, then at w + 1 (bit 3).
fn sn_osl_corners4(x: u32, y: u32, z: u32, w: u32) -> array<u32, 16> {
    var h: array<u32, 16>;
    for (var k = 0u; k < 16u; k++) {
        h[k] = sn_osl_inthash4(x + (k & 1u), y + ((k >> 1u) & 1u), z + ((k >> 2u) & 1u),
            w + ((k >> 3u) & 1u));
    }
    return h;
}

// lerp(trilerp(g[0..8]), trilerp(g[8..16]), fade(fw)) of the 4D gradients of byte
// `shift / 8` of each corner hash, times OSL's scale4.
fn sn_osl_perlin4_of(h: array<u32, 16>, shift: u32, mask: u32, f: vec4<f32>) -> f32 {
    var lo: array<f32, 8>;
    var hi: array<f32, 8>;
    for (var k = 0u; k < 8u; k++) {
        let x0 = sn_osl_off(f.x, k, 0u);
        let y0 = sn_osl_off(f.y, k, 1u);
        let z0 = sn_osl_off(f.z, k, 2u);
        lo[k] = sn_osl_grad4((h[k] >> shift) & mask, x0, y0, z0, f.w);
        hi[k] = sn_osl_grad4((h[k + 8u] >> shift) & mask, x0, y0, z0, f.w - 1.0f);
    }
    let u = sn_fade(f.x);
    let v = sn_fade(f.y);
    let t = sn_fade(f.z);
    let r = sn_osl_lerp(sn_osl_trilerp(lo, u, v, t), sn_osl_trilerp(hi, u, v, t), sn_fade(f.w));
    return 0.8344f * r;
}

fn sn_osl_perlin4(p: vec3<f32>, t: f32) -> f32 {
    let h = sn_osl_corners4(sn_osl_ifloor(p.x), sn_osl_ifloor(p.y), sn_osl_ifloor(p.z),
        sn_osl_ifloor(t));
    let f = vec4<f32>(sn_cell_frac(p.x), sn_cell_frac(p.y), sn_cell_frac(p.z), sn_cell_frac(t));
    return sn_osl_perlin4_of(h, 0u, 0xffffffffu, f);
}

fn sn_osl_vperlin4_of(h: array<u32, 16>, p: vec3<f32>, t: f32) -> vec3<f32> {
    let f = vec4<f32>(sn_cell_frac(p.x), sn_cell_frac(p.y), sn_cell_frac(p.z), sn_cell_frac(t));
    return vec3<f32>(
        sn_osl_perlin4_of(h, 0u, 255u, f),
        sn_osl_perlin4_of(h, 8u, 255u, f),
        sn_osl_perlin4_of(h, 16u, 255u, f),
    );
}

fn sn_osl_vperlin4(p: vec3<f32>, t: f32) -> vec3<f32> {
    let h = sn_osl_corners4(sn_osl_ifloor(p.x), sn_osl_ifloor(p.y), sn_osl_ifloor(p.z),
        sn_osl_ifloor(t));
    return sn_osl_vperlin4_of(h, p, t);
}

// Periodic Perlin noise (psnoise): the corner keys wrap, OSL's imod(c + d, period) with
// period = max(1, ifloor(p)) (HashScalarPeriodic).
fn sn_osl_period(p: f32) -> i32 {
    return max(1i, sn_f2i(floor(p)));
}

fn sn_osl_key(c: u32, d: u32, period: i32) -> u32 {
    let r = (bitcast<i32>(c) + i32(d)) % period;
    return bitcast<u32>(select(r, r + period, r < 0i));
}

fn sn_osl_pperlin1_h(x: f32, px: f32) -> vec2<u32> {
    let i = sn_osl_ifloor(x);
    let per = sn_osl_period(px);
    return vec2<u32>(sn_osl_inthash1(sn_osl_key(i, 0u, per)), sn_osl_inthash1(sn_osl_key(i, 1u, per)));
}

fn sn_osl_pperlin1(x: f32, px: f32) -> f32 {
    let h = sn_osl_pperlin1_h(x, px);
    return sn_osl_perlin1_of(h.x, h.y, 0u, 0xffffffffu, sn_cell_frac(x));
}

fn sn_osl_vpperlin1(x: f32, px: f32) -> vec3<f32> {
    return sn_osl_vperlin1_of(sn_osl_pperlin1_h(x, px), sn_cell_frac(x));
}

fn sn_osl_pcorners2(p: vec2<f32>, pp: vec2<f32>) -> vec4<u32> {
    let x = sn_osl_ifloor(p.x);
    let y = sn_osl_ifloor(p.y);
    let px = sn_osl_period(pp.x);
    let py = sn_osl_period(pp.y);
    return vec4<u32>(
        sn_inthash2(sn_osl_key(x, 0u, px), sn_osl_key(y, 0u, py)),
        sn_inthash2(sn_osl_key(x, 1u, px), sn_osl_key(y, 0u, py)),
        sn_inthash2(sn_osl_key(x, 0u, px), sn_osl_key(y, 1u, py)),
        sn_inthash2(sn_osl_key(x, 1u, px), sn_osl_key(y, 1u, py)),
    );
}

fn sn_osl_pperlin2(p: vec2<f32>, pp: vec2<f32>) -> f32 {
    let h = sn_osl_pcorners2(p, pp);
    return sn_osl_perlin2_of(h, 0u, 0xffffffffu, sn_cell_frac(p.x), sn_cell_frac(p.y));
}

fn sn_osl_vpperlin2(p: vec2<f32>, pp: vec2<f32>) -> vec3<f32> {
    return sn_osl_vperlin2_of(sn_osl_pcorners2(p, pp), p);
}

fn sn_osl_pcorners3(p: vec3<f32>, pp: vec3<f32>) -> array<u32, 8> {
    let x = sn_osl_ifloor(p.x);
    let y = sn_osl_ifloor(p.y);
    let z = sn_osl_ifloor(p.z);
    let per = vec3<i32>(sn_osl_period(pp.x), sn_osl_period(pp.y), sn_osl_period(pp.z));
    var h: array<u32, 8>;
    for (var k = 0u; k < 8u; k++) {
        h[k] = sn_inthash3(sn_osl_key(x, k & 1u, per.x), sn_osl_key(y, (k >> 1u) & 1u, per.y),
            sn_osl_key(z, (k >> 2u) & 1u, per.z));
    }
    return h;
}

fn sn_osl_pperlin3(p: vec3<f32>, pp: vec3<f32>) -> f32 {
    let f = vec3<f32>(sn_cell_frac(p.x), sn_cell_frac(p.y), sn_cell_frac(p.z));
    return sn_osl_perlin3_of(sn_osl_pcorners3(p, pp), 0u, 0xffffffffu, f);
}

fn sn_osl_vpperlin3(p: vec3<f32>, pp: vec3<f32>) -> vec3<f32> {
    return sn_osl_vperlin3_of(sn_osl_pcorners3(p, pp), p);
}

fn sn_osl_pcorners4(p: vec3<f32>, t: f32, pp: vec3<f32>, pt: f32) -> array<u32, 16> {
    let c = vec4<u32>(sn_osl_ifloor(p.x), sn_osl_ifloor(p.y), sn_osl_ifloor(p.z), sn_osl_ifloor(t));
    let per = vec4<i32>(sn_osl_period(pp.x), sn_osl_period(pp.y), sn_osl_period(pp.z),
        sn_osl_period(pt));
    var h: array<u32, 16>;
    for (var k = 0u; k < 16u; k++) {
        h[k] = sn_osl_inthash4(sn_osl_key(c.x, k & 1u, per.x),
            sn_osl_key(c.y, (k >> 1u) & 1u, per.y), sn_osl_key(c.z, (k >> 2u) & 1u, per.z),
            sn_osl_key(c.w, (k >> 3u) & 1u, per.w));
    }
    return h;
}

fn sn_osl_pperlin4(p: vec3<f32>, t: f32, pp: vec3<f32>, pt: f32) -> f32 {
    let f = vec4<f32>(sn_cell_frac(p.x), sn_cell_frac(p.y), sn_cell_frac(p.z), sn_cell_frac(t));
    return sn_osl_perlin4_of(sn_osl_pcorners4(p, t, pp, pt), 0u, 0xffffffffu, f);
}

fn sn_osl_vpperlin4(p: vec3<f32>, t: f32, pp: vec3<f32>, pt: f32) -> vec3<f32> {
    return sn_osl_vperlin4_of(sn_osl_pcorners4(p, t, pp, pt), p, t);
}

// OSL hashnoise: cell noise of the coordinates' bits (HashNoise::transformToUint).
fn sn_osl_hash1(x: f32) -> f32 {
    return sn_bits_to_01(sn_osl_inthash1(bitcast<u32>(x)));
}

fn sn_osl_hash2(p: vec2<f32>) -> f32 {
    return sn_bits_to_01(sn_inthash2(bitcast<u32>(p.x), bitcast<u32>(p.y)));
}

fn sn_osl_hash3(p: vec3<f32>) -> f32 {
    let k = bitcast<vec3<u32>>(p);
    return sn_bits_to_01(sn_inthash3(k.x, k.y, k.z));
}

fn sn_osl_hash4(p: vec3<f32>, t: f32) -> f32 {
    let k = bitcast<vec3<u32>>(p);
    return sn_bits_to_01(sn_osl_inthash4(k.x, k.y, k.z, bitcast<u32>(t)));
}

fn sn_osl_vhash1(x: f32) -> vec3<f32> {
    return sn_osl_vhash_keys1(bitcast<u32>(x));
}

fn sn_osl_vhash2(p: vec2<f32>) -> vec3<f32> {
    return sn_osl_vhash_keys2(bitcast<u32>(p.x), bitcast<u32>(p.y));
}

fn sn_osl_vhash3(p: vec3<f32>) -> vec3<f32> {
    return sn_osl_vhash_keys3(bitcast<vec3<u32>>(p));
}

fn sn_osl_vhash4(p: vec3<f32>, t: f32) -> vec3<f32> {
    return sn_osl_vhash_keys4(bitcast<vec3<u32>>(p), bitcast<u32>(t));
}

// OSL simplex noise, line by line from graph/src/ops/osl_simplex.rs (OSL simplexnoise.cpp):
// corner hashes are bjfinal "scrambles" of the lattice coordinates and a seed (0 for float
// noise, 0, 1, 2 for the components of vector noise). Constants are the source's float
// literals; 2·G2, 2·G3, 3·G3, 2·G4, 3·G4, 4·G4 as the f32 products. The corner offsets
// `x0 - o + G` pass `o` through the key (Mesa folds `(x - 1) + c` into `x + (c - 1)`), as do
// the sums that skew the coordinates (a splatted point would read one value twice).
fn sn_osl_scramble(v0: u32, v1: u32, v2: u32) -> u32 {
    return sn_bjfinal(v0, v1, v2 ^ 0xdeadbeefu);
}

const SN_OSL_SGRAD2 = array<vec2<f32>, 8>(
    vec2<f32>(-1.0f, -1.0f), vec2<f32>(1.0f, 0.0f), vec2<f32>(-1.0f, 0.0f),
    vec2<f32>(1.0f, 1.0f), vec2<f32>(-1.0f, 1.0f), vec2<f32>(0.0f, -1.0f),
    vec2<f32>(0.0f, 1.0f), vec2<f32>(1.0f, -1.0f));

const SN_OSL_SGRAD3 = array<vec3<f32>, 16>(
    vec3<f32>(1.0f, 0.0f, 1.0f), vec3<f32>(0.0f, 1.0f, 1.0f), vec3<f32>(-1.0f, 0.0f, 1.0f),
    vec3<f32>(0.0f, -1.0f, 1.0f), vec3<f32>(1.0f, 0.0f, -1.0f), vec3<f32>(0.0f, 1.0f, -1.0f),
    vec3<f32>(-1.0f, 0.0f, -1.0f), vec3<f32>(0.0f, -1.0f, -1.0f), vec3<f32>(1.0f, -1.0f, 0.0f),
    vec3<f32>(1.0f, 1.0f, 0.0f), vec3<f32>(-1.0f, 1.0f, 0.0f), vec3<f32>(-1.0f, -1.0f, 0.0f),
    vec3<f32>(1.0f, 0.0f, 1.0f), vec3<f32>(-1.0f, 0.0f, 1.0f), vec3<f32>(0.0f, 1.0f, -1.0f),
    vec3<f32>(0.0f, -1.0f, -1.0f));

// OSL grad4lut: block h / 8 has its zero on axis h / 8, the other axes' signs are bits 2, 1,
// 0 of h (set: -1), the first of them the slowest.
fn sn_osl_sgrad4(h: u32) -> vec4<f32> {
    let zero = (h >> 3u) & 3u;
    var g = vec4<f32>(0.0f);
    var bit = 2i;
    for (var k = 0u; k < 4u; k++) {
        if (k != zero) {
            g[k] = select(1.0f, -1.0f, ((h >> u32(bit)) & 1u) != 0u);
            bit -= 1i;
        }
    }
    return g;
}

fn sn_osl_sgrad1(i: i32, seed: u32) -> f32 {
    let h = sn_osl_scramble(bitcast<u32>(i), seed, 0u);
    let g = 1.0f + f32(h & 7u);
    return select(g, -g, (h & 8u) != 0u);
}

fn sn_osl_simplex1_s(x: f32, seed: u32) -> f32 {
    let i0 = sn_f2i(floor(x));
    let x0 = sn_cell_frac(x);
    let x1 = x0 - 1.0f;
    let t0 = 1.0f - x0 * x0;
    let t20 = t0 * t0;
    let t40 = t20 * t20;
    let n0 = t40 * sn_osl_sgrad1(i0, seed) * x0;
    let t1 = 1.0f - x1 * x1;
    let t21 = t1 * t1;
    let t41 = t21 * t21;
    let n1 = t41 * sn_osl_sgrad1(i0 + 1i, seed) * x1;
    return 0.36f * (n0 + n1);
}

// A corner's t^4 (g . x), 0 outside its radius (t < 0 or NaN).
fn sn_osl_scorner2(x: vec2<f32>, h: u32) -> f32 {
    let t = 0.5f - x.x * x.x - x.y * x.y;
    let g = SN_OSL_SGRAD2[h & 7u];
    let t2 = t * t;
    let t4 = t2 * t2;
    return select(0.0f, t4 * (g.x * x.x + g.y * x.y), t >= 0.0f);
}

fn sn_osl_scorner3(x: vec3<f32>, h: u32) -> f32 {
    let t = 0.5f - x.x * x.x - x.y * x.y - x.z * x.z;
    let g = SN_OSL_SGRAD3[h & 15u];
    let t2 = t * t;
    let t4 = t2 * t2;
    return select(0.0f, t4 * (g.x * x.x + g.y * x.y + g.z * x.z), t >= 0.0f);
}

fn sn_osl_scorner4(x: vec4<f32>, h: u32) -> f32 {
    let t = 0.5f - x.x * x.x - x.y * x.y - x.z * x.z - x.w * x.w;
    let g = sn_osl_sgrad4(h & 31u);
    let t2 = t * t;
    let t4 = t2 * t2;
    return select(0.0f, t4 * (g.x * x.x + g.y * x.y + g.z * x.z + g.w * x.w), t >= 0.0f);
}

fn sn_osl_simplex2_s(p: vec2<f32>, seed: u32, k: u32) -> f32 {
    let g2 = 0.211324865f;
    let s = (p.x + sn_o(p.y, k)) * 0.366025403f;
    let i = sn_f2i(floor(p.x + s));
    let j = sn_f2i(floor(p.y + s));
    let t = sn_itof(i + j) * g2;
    let x0 = p.x - (sn_itof(i) - t);
    let y0 = p.y - (sn_itof(j) - t);
    let o = select(vec2<i32>(0i, 1i), vec2<i32>(1i, 0i), x0 > y0);
    let x1 = vec2<f32>(x0 - sn_o(f32(o.x), k) + g2, y0 - sn_o(f32(o.y), k) + g2);
    let one = sn_o(1.0f, k);
    let x2 = vec2<f32>(x0 - one + 0.42264974f, y0 - one + 0.42264974f);
    let n0 = sn_osl_scorner2(vec2<f32>(x0, y0),
        sn_osl_scramble(bitcast<u32>(i), bitcast<u32>(j), seed));
    let n1 = sn_osl_scorner2(x1, sn_osl_scramble(bitcast<u32>(i + o.x), bitcast<u32>(j + o.y),
        seed));
    let n2 = sn_osl_scorner2(x2, sn_osl_scramble(bitcast<u32>(i + 1i), bitcast<u32>(j + 1i),
        seed));
    return 64.0f * (n0 + n1 + n2);
}

fn sn_osl_shash3(c: vec3<i32>, seed: u32) -> u32 {
    let k = bitcast<vec3<u32>>(c);
    return sn_osl_scramble(k.x, k.y, sn_osl_scramble(k.z, seed, 0u));
}

fn sn_osl_simplex3_s(p: vec3<f32>, seed: u32, k: u32) -> f32 {
    let g3 = 0.166666667f;
    let s = (p.x + sn_o(p.y, k) + sn_o(p.z, k)) * 0.333333333f;
    let c = vec3<i32>(sn_f2i(floor(p.x + s)), sn_f2i(floor(p.y + s)), sn_f2i(floor(p.z + s)));
    let t = sn_itof(c.x + c.y + c.z) * g3;
    let x0 = p - (vec3<f32>(sn_itof(c.x), sn_itof(c.y), sn_itof(c.z)) - t);
    var o1: vec3<i32>;
    var o2: vec3<i32>;
    if (x0.x >= x0.y) {
        if (x0.y >= x0.z) {
            o1 = vec3<i32>(1i, 0i, 0i); o2 = vec3<i32>(1i, 1i, 0i);
        } else if (x0.x >= x0.z) {
            o1 = vec3<i32>(1i, 0i, 0i); o2 = vec3<i32>(1i, 0i, 1i);
        } else {
            o1 = vec3<i32>(0i, 0i, 1i); o2 = vec3<i32>(1i, 0i, 1i);
        }
    } else {
        if (x0.y < x0.z) {
            o1 = vec3<i32>(0i, 0i, 1i); o2 = vec3<i32>(0i, 1i, 1i);
        } else if (x0.x < x0.z) {
            o1 = vec3<i32>(0i, 1i, 0i); o2 = vec3<i32>(0i, 1i, 1i);
        } else {
            o1 = vec3<i32>(0i, 1i, 0i); o2 = vec3<i32>(1i, 1i, 0i);
        }
    }
    let x1 = x0 - sn_o3(vec3<f32>(o1), k) + g3;
    let x2 = x0 - sn_o3(vec3<f32>(o2), k) + 0.33333334f;
    let x3 = x0 - sn_o(1.0f, k) + 0.5f;
    let n0 = sn_osl_scorner3(x0, sn_osl_shash3(c, seed));
    let n1 = sn_osl_scorner3(x1, sn_osl_shash3(c + o1, seed));
    let n2 = sn_osl_scorner3(x2, sn_osl_shash3(c + o2, seed));
    let n3 = sn_osl_scorner3(x3, sn_osl_shash3(c + vec3<i32>(1i), seed));
    return 68.0f * (n0 + n1 + n2 + n3);
}

fn sn_osl_shash4(c: vec4<i32>, seed: u32) -> u32 {
    let k = bitcast<vec4<u32>>(c);
    return sn_osl_scramble(k.x, k.y, sn_osl_scramble(k.z, k.w, seed));
}

// 4D: OSL looks the corners' order up in a table of the six comparisons; for offsets without
// NaN its entries are each coordinate's rank (ties to the later coordinate), computed here
// (with a NaN offset every corner is outside its radius, whatever the order).
fn sn_osl_simplex4_s(p3: vec3<f32>, w: f32, seed: u32, k: u32) -> f32 {
    let g4 = 0.138196601f;
    let p = vec4<f32>(p3, w);
    let s = (p.x + sn_o(p.y, k) + sn_o(p.z, k) + sn_o(p.w, k)) * 0.309016994f;
    let c = vec4<i32>(sn_f2i(floor(p.x + s)), sn_f2i(floor(p.y + s)), sn_f2i(floor(p.z + s)),
        sn_f2i(floor(p.w + s)));
    let t = sn_itof(c.x + c.y + c.z + c.w) * g4;
    let x0 = p - (vec4<f32>(sn_itof(c.x), sn_itof(c.y), sn_itof(c.z), sn_itof(c.w)) - t);
    let xy = x0.x > x0.y;
    let xz = x0.x > x0.z;
    let yz = x0.y > x0.z;
    let xw = x0.x > x0.w;
    let yw = x0.y > x0.w;
    let zw = x0.z > x0.w;
    let rank = vec4<u32>(u32(xy) + u32(xz) + u32(xw), u32(!xy) + u32(yz) + u32(yw),
        u32(!xz) + u32(!yz) + u32(zw), u32(!xw) + u32(!yw) + u32(!zw));
    let o1 = select(vec4<i32>(0i), vec4<i32>(1i), rank >= vec4<u32>(3u));
    let o2 = select(vec4<i32>(0i), vec4<i32>(1i), rank >= vec4<u32>(2u));
    let o3 = select(vec4<i32>(0i), vec4<i32>(1i), rank >= vec4<u32>(1u));
    let x1 = x0 - sn_o4(vec4<f32>(o1), k) + g4;
    let x2 = x0 - sn_o4(vec4<f32>(o2), k) + 0.2763932f;
    let x3 = x0 - sn_o4(vec4<f32>(o3), k) + 0.41458982f;
    let x4 = x0 - sn_o(1.0f, k) + 0.5527864f;
    let n0 = sn_osl_scorner4(x0, sn_osl_shash4(c, seed));
    let n1 = sn_osl_scorner4(x1, sn_osl_shash4(c + o1, seed));
    let n2 = sn_osl_scorner4(x2, sn_osl_shash4(c + o2, seed));
    let n3 = sn_osl_scorner4(x3, sn_osl_shash4(c + o3, seed));
    let n4 = sn_osl_scorner4(x4, sn_osl_shash4(c + vec4<i32>(1i), seed));
    return 54.0f * (n0 + n1 + n2 + n3 + n4);
}

fn sn_osl_simplex1(x: f32, k: u32) -> f32 {
    return sn_osl_simplex1_s(x, 0u);
}

fn sn_osl_simplex2(p: vec2<f32>, k: u32) -> f32 {
    return sn_osl_simplex2_s(p, 0u, k);
}

fn sn_osl_simplex3(p: vec3<f32>, k: u32) -> f32 {
    return sn_osl_simplex3_s(p, 0u, k);
}

fn sn_osl_simplex4(p: vec3<f32>, t: f32, k: u32) -> f32 {
    return sn_osl_simplex4_s(p, t, 0u, k);
}

fn sn_osl_vsimplex1(x: f32, k: u32) -> vec3<f32> {
    return vec3<f32>(sn_osl_simplex1_s(x, 0u), sn_osl_simplex1_s(x, 1u),
        sn_osl_simplex1_s(x, 2u));
}

fn sn_osl_vsimplex2(p: vec2<f32>, k: u32) -> vec3<f32> {
    return vec3<f32>(sn_osl_simplex2_s(p, 0u, k), sn_osl_simplex2_s(p, 1u, k),
        sn_osl_simplex2_s(p, 2u, k));
}

fn sn_osl_vsimplex3(p: vec3<f32>, k: u32) -> vec3<f32> {
    return vec3<f32>(sn_osl_simplex3_s(p, 0u, k), sn_osl_simplex3_s(p, 1u, k),
        sn_osl_simplex3_s(p, 2u, k));
}

fn sn_osl_vsimplex4(p: vec3<f32>, t: f32, k: u32) -> vec3<f32> {
    return vec3<f32>(sn_osl_simplex4_s(p, t, 0u, k), sn_osl_simplex4_s(p, t, 1u, k),
        sn_osl_simplex4_s(p, t, 2u, k));
}

// MaterialX fractal noise: octaves clamped to [0, 32] (osl_noise::MAX_OCTAVES).
fn sn_mx_fractal2(p_in: vec2<f32>, octaves: i32, lacunarity: f32, diminish: f32) -> f32 {
    var p = p_in;
    var result = 0.0f;
    var amplitude = 1.0f;
    let n = clamp(octaves, 0i, 32i);
    for (var i = 0i; i < n; i++) {
        result = result + amplitude * sn_osl_perlin2(p);
        amplitude = amplitude * diminish;
        p = p * lacunarity;
    }
    return result;
}

fn sn_mx_fractal3(p_in: vec3<f32>, octaves: i32, lacunarity: f32, diminish: f32) -> f32 {
    var p = p_in;
    var result = 0.0f;
    var amplitude = 1.0f;
    let n = clamp(octaves, 0i, 32i);
    for (var i = 0i; i < n; i++) {
        result = result + amplitude * sn_osl_perlin3(p);
        amplitude = amplitude * diminish;
        p = p * lacunarity;
    }
    return result;
}

fn sn_mx_vfractal2(p_in: vec2<f32>, octaves: i32, lacunarity: f32, diminish: f32) -> vec3<f32> {
    var p = p_in;
    var result = vec3<f32>(0.0f);
    var amplitude = 1.0f;
    let n = clamp(octaves, 0i, 32i);
    for (var i = 0i; i < n; i++) {
        result = result + amplitude * sn_osl_vperlin2(p);
        amplitude = amplitude * diminish;
        p = p * lacunarity;
    }
    return result;
}

fn sn_mx_vfractal3(p_in: vec3<f32>, octaves: i32, lacunarity: f32, diminish: f32) -> vec3<f32> {
    var p = p_in;
    var result = vec3<f32>(0.0f);
    var amplitude = 1.0f;
    let n = clamp(octaves, 0i, 32i);
    for (var i = 0i; i < n; i++) {
        result = result + amplitude * sn_osl_vperlin3(p);
        amplitude = amplitude * diminish;
        p = p * lacunarity;
    }
    return result;
}

// MaterialX Worley noise. Constants and summed products pass through the key (k: see
// sn_o). Measured on lavapipe: it unrolls the 3x3 search of the 2D noise and reassociates
// the cell offsets, now constants, with the sums they enter (1-ulp differences in 2D only
// until `f32(x)` went through the key). The 0.5 of the jitter likewise: with a constant
// jitter of 1, (t - 0.5) + 0.5 could fold to t; the products are kept from fusing.

// mx_worley_cell_position: the jittered feature point of cell (cx + x, cy + y), relative to
// cell (cx, cy).
fn sn_mx_cell_position2(x: i32, y: i32, cx: i32, cy: i32, jitter: f32, k: u32) -> vec2<f32> {
    let half = sn_o(0.5f, k);
    let t = sn_osl_vcell2(vec2<f32>(sn_itof(sn_iadd(x, cx)), sn_itof(sn_iadd(y, cy))));
    let off = vec2<f32>(
        sn_o((t.x - half) * jitter, k) + half,
        sn_o((t.y - half) * jitter, k) + half,
    );
    return vec2<f32>(sn_o(f32(x), k) + off.x, sn_o(f32(y), k) + off.y);
}

fn sn_mx_cell_position3(c: vec3<i32>, cell: vec3<i32>, jitter: f32, k: u32) -> vec3<f32> {
    let half = sn_o(0.5f, k);
    let q = vec3<f32>(
        sn_itof(sn_iadd(c.x, cell.x)),
        sn_itof(sn_iadd(c.y, cell.y)),
        sn_itof(sn_iadd(c.z, cell.z)),
    );
    let t = sn_osl_vcell3(q);
    return vec3<f32>(
        sn_o(f32(c.x), k) + (sn_o((t.x - half) * jitter, k) + half),
        sn_o(f32(c.y), k) + (sn_o((t.y - half) * jitter, k) + half),
        sn_o(f32(c.z), k) + (sn_o((t.z - half) * jitter, k) + half),
    );
}

// GLSL max: a < b ? b : a.
fn sn_gmax(a: f32, b: f32) -> f32 {
    return select(a, b, a < b);
}

// mx_worley_distance's metric: 2 Manhattan, 3 Chebyshev, otherwise squared Euclidean.
fn sn_mx_metric2(d: vec2<f32>, metric: i32, k: u32) -> f32 {
    if (metric == 2i) {
        return abs(d.x) + abs(d.y);
    }
    if (metric == 3i) {
        return sn_gmax(abs(d.x), abs(d.y));
    }
    return sn_o(d.x * d.x, k) + sn_o(d.y * d.y, k);
}

fn sn_mx_metric3(d: vec3<f32>, metric: i32, k: u32) -> f32 {
    if (metric == 2i) {
        return (abs(d.x) + abs(d.y)) + abs(d.z);
    }
    if (metric == 3i) {
        return sn_gmax(sn_gmax(abs(d.x), abs(d.y)), abs(d.z));
    }
    return (sn_o(d.x * d.x, k) + sn_o(d.y * d.y, k)) + sn_o(d.z * d.z, k);
}

// The n (1, 2 or 3) nearest distances, sorted, and the nearest feature point relative to
// the point.
struct SnWorley {
    d: vec3<f32>,
    minpos: vec3<f32>,
}

fn sn_mx_worley_insert(w: SnWorley, n: u32, dist: f32, cellpos: vec3<f32>) -> SnWorley {
    var r = w;
    if (dist < r.d.x) {
        if (n > 2u) {
            r.d.z = r.d.y;
        }
        if (n > 1u) {
            r.d.y = r.d.x;
        }
        r.d.x = dist;
        r.minpos = cellpos;
    } else if (n > 1u && dist < r.d.y) {
        if (n > 2u) {
            r.d.z = r.d.y;
        }
        r.d.y = dist;
    } else if (n > 2u && dist < r.d.z) {
        r.d.z = dist;
    }
    return r;
}

fn sn_mx_worley2_search(p: vec2<f32>, jitter: f32, metric: i32, n: u32, k: u32) -> SnWorley {
    let cx = sn_f2i(floor(p.x));
    let cy = sn_f2i(floor(p.y));
    let lx = sn_cell_frac(p.x);
    let ly = sn_cell_frac(p.y);
    var w = SnWorley(vec3<f32>(1e6f), vec3<f32>(0.0f));
    for (var x = -1i; x <= 1i; x++) {
        for (var y = -1i; y <= 1i; y++) {
            let cp = sn_mx_cell_position2(x, y, cx, cy, jitter, k);
            let diff = vec2<f32>(cp.x - lx, cp.y - ly);
            w = sn_mx_worley_insert(w, n, sn_mx_metric2(diff, metric, k), vec3<f32>(diff, 0.0f));
        }
    }
    return w;
}

fn sn_mx_worley3_search(p: vec3<f32>, jitter: f32, metric: i32, n: u32, k: u32) -> SnWorley {
    let cell = vec3<i32>(sn_f2i(floor(p.x)), sn_f2i(floor(p.y)), sn_f2i(floor(p.z)));
    let l = vec3<f32>(sn_cell_frac(p.x), sn_cell_frac(p.y), sn_cell_frac(p.z));
    var w = SnWorley(vec3<f32>(1e6f), vec3<f32>(0.0f));
    for (var x = -1i; x <= 1i; x++) {
        for (var y = -1i; y <= 1i; y++) {
            for (var z = -1i; z <= 1i; z++) {
                let cp = sn_mx_cell_position3(vec3<i32>(x, y, z), cell, jitter, k);
                let diff = vec3<f32>(cp.x - l.x, cp.y - l.y, cp.z - l.z);
                w = sn_mx_worley_insert(w, n, sn_mx_metric3(diff, metric, k), diff);
            }
        }
    }
    return w;
}

// The distances at the end: square roots for metric 0.
fn sn_mx_worley_finish(d: vec3<f32>, metric: i32) -> vec3<f32> {
    if (metric == 0i) {
        return vec3<f32>(sn_sqrt(d.x), sn_sqrt(d.y), sn_sqrt(d.z));
    }
    return d;
}

fn sn_mx_worley2(p: vec2<f32>, jitter: f32, style: i32, metric: i32, k: u32) -> f32 {
    let w = sn_mx_worley2_search(p, jitter, metric, 1u, k);
    if (style == 1i) {
        return sn_osl_cell2(vec2<f32>(w.minpos.x + p.x, w.minpos.y + p.y));
    }
    return sn_mx_worley_finish(w.d, metric).x;
}

fn sn_mx_worley2_v2(p: vec2<f32>, jitter: f32, style: i32, metric: i32, k: u32) -> vec2<f32> {
    let w = sn_mx_worley2_search(p, jitter, metric, 2u, k);
    if (style == 1i) {
        return sn_osl_vcell2(vec2<f32>(w.minpos.x + p.x, w.minpos.y + p.y)).xy;
    }
    return sn_mx_worley_finish(w.d, metric).xy;
}

fn sn_mx_worley2_v3(p: vec2<f32>, jitter: f32, style: i32, metric: i32, k: u32) -> vec3<f32> {
    let w = sn_mx_worley2_search(p, jitter, metric, 3u, k);
    if (style == 1i) {
        return sn_osl_vcell2(vec2<f32>(w.minpos.x + p.x, w.minpos.y + p.y));
    }
    return sn_mx_worley_finish(w.d, metric);
}

fn sn_mx_worley3(p: vec3<f32>, jitter: f32, style: i32, metric: i32, k: u32) -> f32 {
    let w = sn_mx_worley3_search(p, jitter, metric, 1u, k);
    if (style == 1i) {
        let m = w.minpos;
        return sn_osl_cell3(vec3<f32>(m.x + p.x, m.y + p.y, m.z + p.z));
    }
    return sn_mx_worley_finish(w.d, metric).x;
}

fn sn_mx_worley3_v2(p: vec3<f32>, jitter: f32, style: i32, metric: i32, k: u32) -> vec2<f32> {
    let w = sn_mx_worley3_search(p, jitter, metric, 2u, k);
    if (style == 1i) {
        let m = w.minpos;
        return sn_osl_vcell3(vec3<f32>(m.x + p.x, m.y + p.y, m.z + p.z)).xy;
    }
    return sn_mx_worley_finish(w.d, metric).xy;
}

fn sn_mx_worley3_v3(p: vec3<f32>, jitter: f32, style: i32, metric: i32, k: u32) -> vec3<f32> {
    let w = sn_mx_worley3_search(p, jitter, metric, 3u, k);
    if (style == 1i) {
        let m = w.minpos;
        return sn_osl_vcell3(vec3<f32>(m.x + p.x, m.y + p.y, m.z + p.z));
    }
    return sn_mx_worley_finish(w.d, metric);
}

// ---- colour (ops::rgb_to_hsv, ops::hsv_to_rgb) ----

fn sn_min(a: f32, b: f32) -> f32 {
    return select(b, a, a < b);
}

fn sn_max(a: f32, b: f32) -> f32 {
    return select(b, a, a > b);
}

// ops::rgb_to_hsv (k: see sn_o; the components may be one value).
fn sn_rgb_to_hsv(c: vec3<f32>, k: u32) -> vec3<f32> {
    let r = c.x;
    let g = c.y;
    let b = c.z;
    let mx = sn_max(r, sn_max(g, b));
    let mn = sn_min(r, sn_min(g, b));
    let d = mx - sn_o(mn, k);
    var h: f32;
    if (d == 0.0f) {
        h = 0.0f;
    } else if (mx == r) {
        h = sn_mod(sn_div(g - sn_o(b, k), d), 6.0f);
    } else if (mx == g) {
        h = sn_div(b - sn_o(r, k), d) + 2.0f;
    } else {
        h = sn_div(r - sn_o(g, k), d) + 4.0f;
    }
    return vec3<f32>(sn_div(h, 6.0f), sn_div(d, mx), mx);
}

fn sn_hsv_to_rgb(c: vec3<f32>) -> vec3<f32> {
    let h = c.x;
    let s = c.y;
    let v = c.z;
    let h6 = sn_fract(h) * 6.0f;
    let sector = floor(h6);
    let f = h6 - sector;
    let p = v * (1.0f - s);
    let q = v * (1.0f - s * f);
    let t = v * (1.0f - s * (1.0f - f));
    switch (sn_f2i(sector)) {
        case 0i: {
            return vec3<f32>(v, t, p);
        }
        case 1i: {
            return vec3<f32>(q, v, p);
        }
        case 2i: {
            return vec3<f32>(p, v, t);
        }
        case 3i: {
            return vec3<f32>(p, q, v);
        }
        case 4i: {
            return vec3<f32>(t, p, v);
        }
        default: {
            return vec3<f32>(v, p, q);
        }
    }
}
