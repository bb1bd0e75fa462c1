//! Radiance `.hdr` files (RGBE): our own reader — flat or new-style run-length-encoded
//! scanlines — and writer, shared by the tracer's environment maps and the texture system.
//!
//! [`read`] checks the size the header gives through its caller's check before it allocates
//! a texel. This module owns the format only: file access is [`crate::input`]'s, the size
//! limits are the callers'.

/// One header line: the bytes up to the next newline (without it) and the rest.
fn line(bytes: &[u8]) -> Option<(&[u8], &[u8])> {
    let end = bytes.iter().position(|&b| b == b'\n')?;
    Some((&bytes[..end], &bytes[end + 1..]))
}

/// A decoded image: width, height and texels (linear RGB, rows from the top).
pub type Decoded = (u32, u32, Vec<[f32; 3]>);

/// Decodes a Radiance `.hdr` file: a `#?` header with `FORMAT=32-bit_rle_rgbe` (or no
/// format line), a blank line, `-Y height +X width` (rows from the top, the standard
/// orientation; others are refused), then RGBE scanlines, flat or new-style run-length
/// encoded. A texel `(R, G, B, E)` decodes to `R · 2^(E − 136)` (and so on); `E = 0` is black.
///
/// `check` is given the header's width and height before anything is allocated for them;
/// its error is returned as is.
pub fn read(
    bytes: &[u8],
    check: impl FnOnce(u32, u32) -> Result<(), String>,
) -> Result<Decoded, String> {
    let bad = |m: &str| Err(format!("not a Radiance .hdr file: {m}"));
    if !bytes.starts_with(b"#?") {
        return bad("it does not start with `#?`");
    }
    let mut rest = bytes;
    loop {
        let Some((l, r)) = line(rest) else {
            return bad("the header does not end");
        };
        rest = r;
        if l.is_empty() {
            break;
        }
        if let Some(f) = l.strip_prefix(b"FORMAT=")
            && f != b"32-bit_rle_rgbe"
        {
            return Err(format!(
                "unsupported pixel format `{}` (only 32-bit_rle_rgbe)",
                String::from_utf8_lossy(f)
            ));
        }
    }
    let Some((res, data)) = line(rest) else {
        return bad("no resolution line");
    };
    let res = String::from_utf8_lossy(res);
    let parts: Vec<&str> = res.split_ascii_whitespace().collect();
    let (height, width) = match parts.as_slice() {
        ["-Y", h, "+X", w] => match (h.parse::<u32>(), w.parse::<u32>()) {
            (Ok(h), Ok(w)) => (h, w),
            _ => return Err(format!("bad resolution line `{res}`")),
        },
        _ => {
            return Err(format!(
                "resolution line `{res}`: only `-Y height +X width` (rows from the top) is read"
            ));
        }
    };
    check(width, height)?;
    let mut texels = Vec::with_capacity(width as usize * height as usize);
    let mut at = 0usize;
    let mut row = vec![[0u8; 4]; width as usize];
    for y in 0..height {
        at = scanline(data, at, &mut row).map_err(|m| format!("scanline {y}: {m}"))?;
        texels.extend(row.iter().map(|&p| rgbe_to_rgb(p)));
    }
    Ok((width, height, texels))
}

/// Reads one scanline of `row.len()` RGBE texels from `data` at `at`; the offset after it.
fn scanline(data: &[u8], mut at: usize, row: &mut [[u8; 4]]) -> Result<usize, String> {
    let w = row.len();
    let eof = || "the file ends early".to_string();
    let head = data.get(at..at + 4).ok_or_else(eof)?;
    let rle = (8..0x8000).contains(&w) && head[0] == 2 && head[1] == 2 && head[2] < 128;
    if !rle {
        for p in row.iter_mut() {
            let b = data.get(at..at + 4).ok_or_else(eof)?;
            p.copy_from_slice(b);
            at += 4;
        }
        return Ok(at);
    }
    if ((head[2] as usize) << 8 | head[3] as usize) != w {
        return Err("the run-length scanline's width does not match the image".into());
    }
    at += 4;
    for c in 0..4 {
        let mut x = 0;
        while x < w {
            let n = *data.get(at).ok_or_else(eof)? as usize;
            at += 1;
            if n > 128 {
                let (n, v) = (n - 128, *data.get(at).ok_or_else(eof)?);
                at += 1;
                if x + n > w {
                    return Err("a run overflows the scanline".into());
                }
                row[x..x + n].iter_mut().for_each(|p| p[c] = v);
                x += n;
            } else {
                if n == 0 || x + n > w {
                    return Err("a literal run is empty or overflows the scanline".into());
                }
                let src = data.get(at..at + n).ok_or_else(eof)?;
                row[x..x + n]
                    .iter_mut()
                    .zip(src)
                    .for_each(|(p, v)| p[c] = *v);
                at += n;
                x += n;
            }
        }
    }
    Ok(at)
}

/// `2^k` for `k` in f64's normal range, exactly.
fn exp2i(k: i32) -> f64 {
    f64::from_bits(((k + 1023) as u64) << 52)
}

fn rgbe_to_rgb([r, g, b, e]: [u8; 4]) -> [f32; 3] {
    if e == 0 {
        return [0.0; 3];
    }
    let f = exp2i(e as i32 - 136);
    [r, g, b].map(|c| (c as f64 * f) as f32)
}

/// The RGBE texel of a linear RGB value: the largest channel's exponent shared, mantissas
/// truncated to 8 bits; negative and non-finite channels count as 0, values below 2^−127
/// become black and values of 2^128 or more saturate.
pub fn rgb_to_rgbe(rgb: [f32; 3]) -> [u8; 4] {
    let c = rgb.map(|x| {
        if x.is_finite() && x > 0.0 {
            x as f64
        } else {
            0.0
        }
    });
    let m = c[0].max(c[1]).max(c[2]);
    if m == 0.0 {
        return [0; 4];
    }
    // m = mantissa · 2^e with mantissa in [0.5, 1).
    let e = ((m.to_bits() >> 52) & 0x7ff) as i32 - 1022;
    if e < -127 {
        return [0; 4];
    }
    if e > 127 {
        return [255, 255, 255, 255];
    }
    let scale = exp2i(8 - e);
    let [r, g, b] = c.map(|x| (x * scale).floor().min(255.0) as u8);
    [r, g, b, (e + 128) as u8]
}

/// A Radiance `.hdr` file of `width × height` texels (rows from the top), scanlines
/// run-length encoded where the width allows (8 to 32767). [`read`] reads it back to
/// the RGBE-rounded values.
pub fn write_hdr(width: u32, height: u32, texels: &[[f32; 3]]) -> Vec<u8> {
    let mut out =
        format!("#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\n-Y {height} +X {width}\n").into_bytes();
    let w = width as usize;
    let rle = (8..0x8000).contains(&w);
    for row in texels.chunks_exact(w.max(1)).take(height as usize) {
        let px: Vec<[u8; 4]> = row.iter().map(|&t| rgb_to_rgbe(t)).collect();
        if !rle {
            px.iter().for_each(|p| out.extend_from_slice(p));
            continue;
        }
        out.extend_from_slice(&[2, 2, (w >> 8) as u8, (w & 0xff) as u8]);
        for c in 0..4 {
            let ch: Vec<u8> = px.iter().map(|p| p[c]).collect();
            encode_channel(&ch, &mut out);
        }
    }
    out
}

/// Run-length encodes one channel of a scanline: runs of 4 or more equal bytes as
/// `128 + n, value` (n ≤ 127), the rest as `n, bytes…` (n ≤ 128).
fn encode_channel(ch: &[u8], out: &mut Vec<u8>) {
    let run_at = |i: usize| {
        let n = ch[i..]
            .iter()
            .take(127)
            .take_while(|&&b| b == ch[i])
            .count();
        (n >= 4).then_some(n)
    };
    let mut i = 0;
    while i < ch.len() {
        if let Some(n) = run_at(i) {
            out.extend_from_slice(&[128 + n as u8, ch[i]]);
            i += n;
            continue;
        }
        let start = i;
        while i < ch.len() && i - start < 128 && run_at(i).is_none() {
            i += 1;
        }
        out.push((i - start) as u8);
        out.extend_from_slice(&ch[start..i]);
    }
}
