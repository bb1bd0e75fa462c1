// Texture lookups: runtime::texture's filter.rs (closest, bilinear, trilinear, anisotropic;
// wrap modes periodic, clamp, mirror, black) in WGSL, operation for operation in the same
// order. Reads the kernel's bindings
//   sn_texels: array<vec4<f32>>: every level of every texture (linear RGBA, rows top to
//              bottom, finest level first);
//   sn_tex_info: array<vec4<u32>>: row t < the texture count: (first level row, level count,
//              0, 0) of texture t; level rows: (first texel, width, height, 0).
// `uv = (0, 0)` is the image's bottom-left corner. `sampling` is ir::Sampling::bits: the
// filter in bits 0–1 (closest, bilinear, trilinear, anisotropic), the u and v wrap modes in
// bits 2–3 and 4–5 (periodic, clamp, mirror, black). Needs lib.wgsl (sn_f2i, sn_is_finite,
// sn_is_nan, sn_iadd).
//
// Differences from the CPU, all continuous in uv and the derivatives (the filters are):
// the level of detail takes WGSL's log2, not the CPU's series (a few ulps apart); and the
// CPU adds 1 to a lattice coordinate in i64, this code in wrapping i32, which differs only
// for |x| or |y| >= 2^31 texels.

const SN_TEX_MAX_ANISOTROPY: f32 = 16.0f;
const SN_TEX_MAX_PROBE: i32 = 8i;
const SN_TEX_MAX_TEXELS: f32 = 1048576.0f;

// x.rem_euclid(n) for 0 < n < 2^31.
fn sn_wrap(x: i32, n: i32) -> i32 {
    let r = x % n;
    return select(r, r + n, r < 0i);
}

// A texel index along an axis of n texels under wrap mode `mode`; -1 reads black.
fn sn_wrap1(i: i32, n: i32, mode: u32) -> i32 {
    switch mode {
        case 0u: {
            return sn_wrap(i, n);
        }
        case 1u: {
            return clamp(i, 0i, n - 1i);
        }
        case 2u: {
            let r = sn_wrap(i, 2i * n);
            return select(r, 2i * n - 1i - r, r >= n);
        }
        default: {
            return select(-1i, i, i >= 0i && i < n);
        }
    }
}

fn sn_tex_fetch(level: vec4<u32>, x: i32, y: i32) -> vec4<f32> {
    if (x < 0i || y < 0i) {
        return vec4<f32>(0.0f);
    }
    return sn_texels[level.x + u32(y) * level.y + u32(x)];
}

// The level row `l` of texture `tex` (clamped to its last level).
fn sn_tex_level(tex: u32, l: u32) -> vec4<u32> {
    let head = sn_tex_info[tex];
    return sn_tex_info[head.x + min(l, head.y - 1u)];
}

fn sn_tex_closest(level: vec4<u32>, uv: vec2<f32>, wrap: vec2<u32>) -> vec4<f32> {
    let x = floor(uv.x * f32(level.y));
    let y = floor((1.0f - uv.y) * f32(level.z));
    let xi = sn_wrap1(sn_f2i(x), i32(level.y), wrap.x);
    let yi = sn_wrap1(sn_f2i(y), i32(level.z), wrap.y);
    return sn_tex_fetch(level, xi, yi);
}

fn sn_tex_bilinear(level: vec4<u32>, uv: vec2<f32>, wrap: vec2<u32>) -> vec4<f32> {
    let x = uv.x * f32(level.y) - 0.5f;
    let y = (1.0f - uv.y) * f32(level.z) - 0.5f;
    let x0 = floor(x);
    let y0 = floor(y);
    var fx = x - x0;
    var fy = y - y0;
    fx = select(0.0f, fx, sn_is_finite(fx));
    fy = select(0.0f, fy, sn_is_finite(fy));
    let xi = sn_f2i(x0);
    let yi = sn_f2i(y0);
    let w = i32(level.y);
    let h = i32(level.z);
    let xa = sn_wrap1(xi, w, wrap.x);
    let xb = sn_wrap1(sn_iadd(xi, 1i), w, wrap.x);
    let ya = sn_wrap1(yi, h, wrap.y);
    let yb = sn_wrap1(sn_iadd(yi, 1i), h, wrap.y);
    let t00 = sn_tex_fetch(level, xa, ya);
    let t10 = sn_tex_fetch(level, xb, ya);
    let t01 = sn_tex_fetch(level, xa, yb);
    let t11 = sn_tex_fetch(level, xb, yb);
    let top = t00 + fx * (t10 - t00);
    let bottom = t01 + fx * (t11 - t01);
    return top + fy * (bottom - top);
}

// Bilinear in the levels floor(lod) and the next, blended by lod's fraction.
fn sn_tex_trilinear(tex: u32, uv: vec2<f32>, lod: f32, wrap: vec2<u32>) -> vec4<f32> {
    let count = sn_tex_info[tex].y;
    let l0 = floor(lod);
    let level = min(u32(max(sn_f2i(l0), 0i)), count - 1u);
    var t = 0.0f;
    if (level + 1u < count) {
        t = lod - l0;
    }
    let a = sn_tex_bilinear(sn_tex_level(tex, level), uv, wrap);
    if (t <= 0.0f) {
        return a;
    }
    let b = sn_tex_bilinear(sn_tex_level(tex, level + 1u), uv, wrap);
    return a + t * (b - a);
}

// log2(width) within [0, levels - 1] (0 below one texel and for NaN).
fn sn_tex_lod(tex: u32, width: f32) -> f32 {
    let levels = f32(sn_tex_info[tex].y - 1u);
    if (!(width >= 1.0f)) {
        return 0.0f;
    }
    return min(log2(width), levels);
}

// A derivative component clamped to ±2^20 texels (NaN → 0).
fn sn_tex_clamp(x: f32) -> f32 {
    if (sn_is_nan(x)) {
        return 0.0f;
    }
    return clamp(x, -SN_TEX_MAX_TEXELS, SN_TEX_MAX_TEXELS);
}

fn sn_texture(tex: u32, sampling: u32, uv: vec2<f32>, dx: vec2<f32>, dy: vec2<f32>) -> vec4<f32> {
    let mode = sampling & 3u;
    let wrap = vec2<u32>((sampling >> 2u) & 3u, (sampling >> 4u) & 3u);
    let base = sn_tex_level(tex, 0u);
    if (mode == 0u) {
        return sn_tex_closest(base, uv, wrap);
    }
    if (mode == 1u) {
        return sn_tex_bilinear(base, uv, wrap);
    }
    // The derivatives in level-0 texels.
    let w = f32(base.y);
    let h = f32(base.z);
    let a = vec2<f32>(sn_tex_clamp(dx.x * w), sn_tex_clamp(dx.y * h));
    let b = vec2<f32>(sn_tex_clamp(dy.x * w), sn_tex_clamp(dy.y * h));
    let la2 = a.x * a.x + a.y * a.y;
    let lb2 = b.x * b.x + b.y * b.y;
    var major = b;
    var lmaj2 = lb2;
    if (la2 >= lb2) {
        major = a;
        lmaj2 = la2;
    }
    if (mode == 2u) {
        // log2 of the length is half the log2 of its square.
        var lod = 0.0f;
        if (lmaj2 >= 1.0f) {
            lod = 0.5f * log2(lmaj2);
        }
        return sn_tex_trilinear(tex, uv, min(lod, f32(sn_tex_info[tex].y - 1u)), wrap);
    }
    let lmaj = sqrt(lmaj2);
    // Anisotropic: the width across the major axis is the parallelogram's area over it.
    let area = abs(a.x * b.y - a.y * b.x);
    var lmin = 0.0f;
    if (lmaj > 0.0f) {
        lmin = area / lmaj;
    }
    let probe = max(max(lmin, lmaj / SN_TEX_MAX_ANISOTROPY), 1.0f);
    let lod = sn_tex_lod(tex, probe);
    let len = lmaj / probe;
    let half = len * 0.5f;
    let kmax = clamp(sn_f2i(floor(half + 0.5f)), 0i, SN_TEX_MAX_PROBE);
    if (kmax == 0i) {
        return sn_tex_trilinear(tex, uv, lod, wrap);
    }
    // One probe width along the major axis, in uv.
    let step = vec2<f32>(major.x / w / len, major.y / h / len);
    var acc = vec4<f32>(0.0f);
    var total = 0.0f;
    for (var k = -kmax; k <= kmax; k++) {
        let kf = f32(k);
        let lo = max(kf - 0.5f, -half);
        let hi = min(kf + 0.5f, half);
        if (hi <= lo) {
            continue;
        }
        let weight = hi - lo;
        let at = (lo + hi) * 0.5f;
        let p = vec2<f32>(uv.x + step.x * at, uv.y + step.y * at);
        acc = acc + weight * sn_tex_trilinear(tex, p, lod, wrap);
        total = total + weight;
    }
    return acc / total;
}
