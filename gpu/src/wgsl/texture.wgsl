// Texture lookup: runtime::texture::Texture::sample in WGSL (bilinear, repeat wrapping,
// uv = (0, 0) at the bottom-left corner, rows stored top to bottom). Reads the kernel's
// bindings sn_texels: array<vec4<f32>> (every texture's texels, linear RGBA) and
// sn_tex_info: array<vec4<u32>> (per texture: first texel, width, height, 0). Needs lib.wgsl
// (sn_f2i, sn_is_finite, sn_iadd).
//
// One difference from the CPU: the CPU adds 1 to the lattice coordinate in i64, this code in
// wrapping i32, so the two read different texels only where floor(x) or floor(y) is
// i32::MAX, that is for |x| or |y| >= 2^31 texels (and then both read a valid texel).

// x.rem_euclid(n) for 0 < n < 2^31.
fn sn_wrap(x: i32, n: i32) -> i32 {
    let r = x % n;
    return select(r, r + n, r < 0i);
}

fn sn_texel(info: vec4<u32>, x: i32, y: i32) -> vec4<f32> {
    let w = i32(info.y);
    let h = i32(info.z);
    let i = u32(sn_wrap(y, h)) * info.y + u32(sn_wrap(x, w));
    return sn_texels[info.x + i];
}

// The sampling bits (ir::Sampling::bits) and the footprint (dx, dy) are read by the filtered
// lookup; this version reads the finest level bilinearly, as the CPU's does.
fn sn_texture(tex: u32, sampling: u32, uv: vec2<f32>, dx: vec2<f32>, dy: vec2<f32>) -> vec4<f32> {
    let info = sn_tex_info[tex];
    let x = uv.x * f32(info.y) - 0.5f;
    let y = (1.0f - uv.y) * f32(info.z) - 0.5f;
    let x0 = floor(x);
    let y0 = floor(y);
    var fx = x - x0;
    var fy = y - y0;
    fx = select(0.0f, fx, sn_is_finite(fx));
    fy = select(0.0f, fy, sn_is_finite(fy));
    let xi = sn_f2i(x0);
    let yi = sn_f2i(y0);
    let t00 = sn_texel(info, xi, yi);
    let t10 = sn_texel(info, sn_iadd(xi, 1i), yi);
    let t01 = sn_texel(info, xi, sn_iadd(yi, 1i));
    let t11 = sn_texel(info, sn_iadd(xi, 1i), sn_iadd(yi, 1i));
    let top = t00 + fx * (t10 - t00);
    let bottom = t01 + fx * (t11 - t01);
    return top + fy * (bottom - top);
}
