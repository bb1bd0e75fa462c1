//! OSL's string builtins — `concat`, `strlen`, `startswith`, `endswith`, `substr`,
//! `getchar`, `stoi`, `stof` and `format` — on the compile-time strings this front end has
//! (a string is a constant of the shader or its group, never a per-fragment value): each
//! call is evaluated while lowering, with OSL's meaning (byte lengths and offsets,
//! `substr`'s negative start from the end, `getchar`'s 0 outside the string, `stoi`/`stof`
//! reading the number the string starts with, 0 if none, as C's `strtol`/`strtod`). Their
//! number arguments must be constants too; `format` takes C's conversions
//! ([`shadenet_graph::ops::printf`]) on constant arguments. It owns these builtins'
//! meaning; it must not print (printing is an effect the IR does not have yet).

use super::{Lower, Ty, Val};
use crate::source::Span;
use shadenet_graph::ConstValue;
use shadenet_graph::ir::Builder;
use shadenet_graph::ops::printf::{self, Arg};

/// The string builtins of this module.
pub(crate) const NAMES: &[&str] = &[
    "concat",
    "strlen",
    "startswith",
    "endswith",
    "substr",
    "getchar",
    "stoi",
    "stof",
    "format",
];

impl<'a> Lower<'a> {
    /// OSL's string builtin `name` on `args`, or `None` when `name` is not one.
    pub(crate) fn string_builtin(
        &mut self,
        b: &mut Builder,
        name: &str,
        args: &[(Val, Span)],
        span: Span,
    ) -> Option<Val> {
        if !NAMES.contains(&name) {
            return None;
        }
        let mut known = Vec::with_capacity(args.len());
        for (k, (v, at)) in args.iter().enumerate() {
            let c = match v {
                Val::Str(s) => ConstValue::String(s.clone()),
                Val::V { v, .. } => match shadenet_graph::opt::fold::constant(b.program(), *v) {
                    Some(c) => c,
                    None => {
                        self.error(
                            format!(
                                "`{name}`'s argument {} is known only while shading: strings and what makes them are compile-time here",
                                k + 1
                            ),
                            *at,
                            "not a constant",
                        );
                        return Some(Self::poison(b, Ty::Float));
                    }
                },
                other => {
                    let msg = format!("`{name}` does not take {}", super::an(other.type_name()));
                    self.error(msg, *at, "here");
                    return Some(Self::poison(b, Ty::Float));
                }
            };
            known.push(c);
        }
        match evaluate(name, &known) {
            Ok(ConstValue::String(s)) => Some(Val::Str(s)),
            Ok(c) => {
                let ty = if matches!(c, ConstValue::Int(_)) {
                    Ty::Int
                } else {
                    Ty::Float
                };
                Some(Val::V {
                    v: b.constant(c),
                    ty,
                    varying: false,
                })
            }
            Err(why) => {
                self.error(format!("`{name}`: {why}"), span, "here");
                Some(Self::poison(b, Ty::Float))
            }
        }
    }
}

/// `name` on compile-time arguments: a string, an int or a float, or why it does not
/// apply.
fn evaluate(name: &str, args: &[ConstValue]) -> Result<ConstValue, String> {
    let s = |k: usize| match args.get(k) {
        Some(ConstValue::String(s)) => Ok(s.as_str()),
        _ => Err(format!("argument {} must be a string", k + 1)),
    };
    let int = |k: usize| match args.get(k) {
        Some(ConstValue::Int(i)) => Ok(*i),
        _ => Err(format!("argument {} must be an int", k + 1)),
    };
    let arity = |n: &[usize]| {
        if n.contains(&args.len()) {
            Ok(())
        } else {
            let counts: Vec<String> = n.iter().map(|c| c.to_string()).collect();
            Err(format!(
                "takes {} arguments, not {}",
                counts.join(" or "),
                args.len()
            ))
        }
    };
    Ok(match name {
        "concat" => {
            let mut out = String::new();
            for k in 0..args.len() {
                out.push_str(s(k)?);
            }
            ConstValue::String(out)
        }
        "strlen" => {
            arity(&[1])?;
            ConstValue::Int(s(0)?.len().min(i32::MAX as usize) as i32)
        }
        "startswith" | "endswith" => {
            arity(&[2])?;
            let (x, affix) = (s(0)?.as_bytes(), s(1)?.as_bytes());
            let hit = if name == "startswith" {
                x.starts_with(affix)
            } else {
                x.ends_with(affix)
            };
            ConstValue::Int(i32::from(hit))
        }
        "substr" => {
            arity(&[2, 3])?;
            let x = s(0)?.as_bytes();
            let len = x.len() as i64;
            let length = if args.len() == 3 { int(2)? as i64 } else { len };
            ConstValue::String(substr(x, int(1)? as i64, length))
        }
        "getchar" => {
            arity(&[2])?;
            let (x, n) = (s(0)?.as_bytes(), int(1)?);
            // C's `char` is signed on the machines OSL runs on.
            let c = usize::try_from(n).ok().and_then(|n| x.get(n));
            ConstValue::Int(c.map_or(0, |c| i32::from(*c as i8)))
        }
        "stoi" => {
            arity(&[1])?;
            ConstValue::Int(stoi(s(0)?))
        }
        "stof" => {
            arity(&[1])?;
            ConstValue::Float(f64::from(stof(s(0)?) as f32))
        }
        _ => {
            let fmt = s(0)?;
            let rest: Vec<Arg> = args[1..].iter().map(printf::const_arg).collect();
            ConstValue::String(printf::format(fmt, &rest)?)
        }
    })
}

/// OSL's `substr`: a negative start counts from the end; start and length are clamped to
/// the string.
fn substr(x: &[u8], start: i64, length: i64) -> String {
    let len = x.len() as i64;
    let b = if start < 0 { start + len } else { start }.clamp(0, len);
    let e = (b + length.clamp(0, len)).min(len);
    String::from_utf8_lossy(&x[b as usize..e as usize]).into_owned()
}

/// C's `strtol(s, 0, 10)` clamped to an int: the leading whitespace, a sign and the digits
/// the string starts with; 0 without digits.
fn stoi(s: &str) -> i32 {
    let t = s.trim_start();
    let (neg, digits) = match t.as_bytes().first() {
        Some(b'-') => (true, &t[1..]),
        Some(b'+') => (false, &t[1..]),
        _ => (false, t),
    };
    let mut v: i64 = 0;
    for d in digits.bytes().take_while(u8::is_ascii_digit) {
        v = (v * 10 + i64::from(d - b'0')).min(1 << 32);
    }
    let v = if neg { -v } else { v };
    v.clamp(i64::from(i32::MIN), i64::from(i32::MAX)) as i32
}

/// C's `strtod`: the longest prefix (after whitespace) that is a decimal number with an
/// optional sign, point and exponent, or `inf`/`nan`; 0 without one.
fn stof(s: &str) -> f64 {
    let t = s.trim_start().as_bytes();
    let mut k = 0;
    if matches!(t.first(), Some(b'+' | b'-')) {
        k += 1;
    }
    let lower = |n: usize| -> String {
        t.get(k..(k + n).min(t.len()))
            .map(|w| String::from_utf8_lossy(w).to_ascii_lowercase())
            .unwrap_or_default()
    };
    let neg = t.first() == Some(&b'-');
    if lower(3) == "inf" {
        return if neg {
            f64::NEG_INFINITY
        } else {
            f64::INFINITY
        };
    }
    if lower(3) == "nan" {
        return f64::NAN;
    }
    let digits = |k: &mut usize| {
        let s = *k;
        while t.get(*k).is_some_and(u8::is_ascii_digit) {
            *k += 1;
        }
        *k - s
    };
    let mut n = digits(&mut k);
    if t.get(k) == Some(&b'.') {
        k += 1;
        n += digits(&mut k);
    }
    if n == 0 {
        return 0.0;
    }
    let mantissa_end = k;
    if matches!(t.get(k), Some(b'e' | b'E')) {
        let mut e = k + 1;
        if matches!(t.get(e), Some(b'+' | b'-')) {
            e += 1;
        }
        if digits(&mut e) > 0 {
            k = e;
        } else {
            k = mantissa_end;
        }
    }
    std::str::from_utf8(&t[..k])
        .ok()
        .and_then(|w| w.parse::<f64>().ok())
        .unwrap_or(0.0)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn substr_counts_bytes_and_clamps() {
        assert_eq!(substr(b"hello", 1, 3), "ell");
        assert_eq!(substr(b"hello", -3, 2), "ll");
        assert_eq!(substr(b"hello", 3, 99), "lo");
        assert_eq!(substr(b"hello", 9, 2), "");
        assert_eq!(substr(b"hello", -99, 2), "he");
        assert_eq!(substr(b"hello", 1, -1), "");
    }

    #[test]
    fn numbers_at_the_start_of_a_string() {
        assert_eq!(stoi("42"), 42);
        assert_eq!(stoi("  -17abc"), -17);
        assert_eq!(stoi("+8"), 8);
        assert_eq!(stoi("x1"), 0);
        assert_eq!(stoi("99999999999"), i32::MAX);
        assert_eq!(stoi("-99999999999"), i32::MIN);
        assert_eq!(stof("1.5"), 1.5);
        assert_eq!(stof(" -2.5e2xyz"), -250.0);
        assert_eq!(stof(".5"), 0.5);
        assert_eq!(stof("3e"), 3.0);
        assert_eq!(stof("abc"), 0.0);
        assert_eq!(stof("-inf"), f64::NEG_INFINITY);
        assert!(stof("nan").is_nan());
    }
}
