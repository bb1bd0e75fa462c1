//! OSL's `format`, `printf`, `warning` and `error`: C's printf
//! conversions on shading values. It owns the meaning of a format string: the conversions
//! `%d %i %u %o %x %X %c` (ints), `%f %F %e %E %g %G` (floats; an int argument widens), `%s`
//! (strings) and `%%`, each with C's flags (`-+ 0#`), width and precision; an aggregate
//! argument (a point, color or matrix) is its components, each formatted by the same
//! conversion and separated by a space, as OSL prints them. A conversion that does not fit
//! its argument, a missing or a surplus argument, and an unknown conversion are errors that
//! say which. It must not know where strings come from (the front end's constants).

use crate::types::{ConstValue, Type};

/// One argument of [`format`].
#[derive(Clone, Debug, PartialEq)]
pub enum Arg {
    /// An int.
    Int(i64),
    /// A float (formatted as the f32 the shader holds: callers round).
    Float(f64),
    /// The components of an aggregate: a point, vector, normal, color or matrix.
    Floats(Vec<f64>),
    /// A string.
    Str(String),
}

/// One parsed conversion: flags, width, precision and the conversion letter.
#[derive(Clone, Copy, Default)]
struct Spec {
    left: bool,
    plus: bool,
    space: bool,
    zero: bool,
    alt: bool,
    width: usize,
    precision: Option<usize>,
    conv: char,
}

/// The most characters a width or a precision may ask for (larger ones are errors, so a
/// hostile format string cannot make a huge allocation).
const MAX_FIELD: usize = 1024;

/// `fmt` with its conversions replaced by `args`, in order.
pub fn format(fmt: &str, args: &[Arg]) -> Result<String, String> {
    walk(fmt, args.len(), "%", |out, k, spec| {
        convert(out, spec, &args[k])
    })
}

/// `fmt` with the conversions whose argument is known (`(arg, true)`) replaced by their
/// text — its `%` doubled, so that the result is a format again — and the others written
/// back as conversions for the arguments still to come at run time, in order. Every
/// conversion is checked against its argument (an unknown one against `arg`, a placeholder
/// of its kind), so the run-time [`format`] of the result cannot fail.
pub fn specialize(fmt: &str, args: &[(Arg, bool)]) -> Result<String, String> {
    walk(fmt, args.len(), "%%", |out, k, spec| {
        let (arg, known) = &args[k];
        let mut text = String::new();
        convert(&mut text, spec, arg)?;
        if *known {
            out.push_str(&text.replace('%', "%%"));
        } else {
            out.push_str(&spec.text());
        }
        Ok(())
    })
}

/// Copies `fmt` to a new string with `%%` as `percent` and each conversion written by
/// `conv(out, index, spec)` for argument `index` of `n`; errors name the conversion.
fn walk(
    fmt: &str,
    n: usize,
    percent: &str,
    mut conv: impl FnMut(&mut String, usize, Spec) -> Result<(), String>,
) -> Result<String, String> {
    let mut out = String::new();
    let mut chars = fmt.chars().peekable();
    let mut index = 0;
    while let Some(c) = chars.next() {
        if c != '%' {
            out.push(c);
            continue;
        }
        if chars.peek() == Some(&'%') {
            chars.next();
            out.push_str(percent);
            continue;
        }
        let spec = parse_spec(&mut chars)?;
        index += 1;
        if index > n {
            return Err(format!(
                "conversion {index} (`%{}`) has no argument",
                spec.conv
            ));
        }
        conv(&mut out, index - 1, spec)
            .map_err(|why| format!("conversion {index} (`%{}`) {why}", spec.conv))?;
    }
    if n > index {
        return Err(format!("{n} arguments but {index} conversions"));
    }
    Ok(out)
}

impl Spec {
    /// The conversion as a format writes it (`%-8.3f`; C's length modifiers, which mean
    /// nothing here, left out).
    fn text(&self) -> String {
        let mut t = String::from("%");
        for (on, c) in [
            (self.left, '-'),
            (self.plus, '+'),
            (self.space, ' '),
            (self.zero, '0'),
            (self.alt, '#'),
        ] {
            if on {
                t.push(c);
            }
        }
        if self.width > 0 {
            t += &self.width.to_string();
        }
        if let Some(p) = self.precision {
            t += &format!(".{p}");
        }
        t.push(self.conv);
        t
    }
}

/// A constant as a message formats it: floats as the f32 the shader holds, bools as ints.
pub fn const_arg(c: &ConstValue) -> Arg {
    match c {
        ConstValue::Bool(b) => Arg::Int(i64::from(*b)),
        ConstValue::Int(i) => Arg::Int(i64::from(*i)),
        ConstValue::String(s) => Arg::Str(s.clone()),
        ConstValue::Float(x) => Arg::Float(f64::from(*x as f32)),
        c => Arg::Floats(c.floats().iter().map(|x| f64::from(*x as f32)).collect()),
    }
}

/// A zero of the kind a value of type `ty` is formatted as (to check a conversion against an
/// argument known only while shading); `None` for the types no message shows (closures;
/// strings are known at compile time, and spliced in).
pub fn placeholder(ty: Type) -> Option<Arg> {
    match ty {
        Type::Int | Type::Bool => Some(Arg::Int(0)),
        Type::Float => Some(Arg::Float(0.0)),
        t if t.is_vector() || t.is_matrix() => Some(Arg::Floats(vec![0.0; t.width()])),
        _ => None,
    }
}

/// The flags, width, precision and letter after a `%`.
fn parse_spec(chars: &mut std::iter::Peekable<std::str::Chars>) -> Result<Spec, String> {
    let mut s = Spec::default();
    while let Some(&c) = chars.peek() {
        match c {
            '-' => s.left = true,
            '+' => s.plus = true,
            ' ' => s.space = true,
            '0' => s.zero = true,
            '#' => s.alt = true,
            _ => break,
        }
        chars.next();
    }
    s.width = number(chars)?.unwrap_or(0);
    if chars.peek() == Some(&'.') {
        chars.next();
        s.precision = Some(number(chars)?.unwrap_or(0));
    }
    // C's length modifiers mean nothing here (OSL accepts and ignores them).
    while matches!(chars.peek(), Some('l' | 'h')) {
        chars.next();
    }
    s.conv = match chars.next() {
        Some(c) if "diuoxXcfFeEgGs".contains(c) => c,
        Some(c) => return Err(format!("unknown conversion `%{c}`")),
        None => return Err("the format ends inside a conversion".into()),
    };
    Ok(s)
}

/// A decimal field (width or precision), at most [`MAX_FIELD`].
fn number(chars: &mut std::iter::Peekable<std::str::Chars>) -> Result<Option<usize>, String> {
    let mut n: Option<usize> = None;
    while let Some(d) = chars.peek().and_then(|c| c.to_digit(10)) {
        chars.next();
        let v = n.unwrap_or(0) * 10 + d as usize;
        if v > MAX_FIELD {
            return Err(format!("a width or precision above {MAX_FIELD}"));
        }
        n = Some(v);
    }
    Ok(n)
}

/// Appends `arg` converted by `spec`.
fn convert(out: &mut String, spec: Spec, arg: &Arg) -> Result<(), String> {
    match (spec.conv, arg) {
        ('s', Arg::Str(s)) => {
            let s = match spec.precision {
                Some(p) => s.chars().take(p).collect(),
                None => s.clone(),
            };
            pad(out, spec, "", &s);
        }
        ('s', _) => return Err("takes a string".into()),
        (_, Arg::Str(_)) => return Err("does not take a string".into()),
        ('d' | 'i' | 'u' | 'o' | 'x' | 'X' | 'c', Arg::Int(i)) => int(out, spec, *i),
        ('d' | 'i' | 'u' | 'o' | 'x' | 'X' | 'c', _) => {
            return Err("takes an int".into());
        }
        (_, Arg::Int(i)) => float(out, spec, *i as f64),
        (_, Arg::Float(x)) => float(out, spec, *x),
        (_, Arg::Floats(xs)) => {
            for (k, x) in xs.iter().enumerate() {
                if k > 0 {
                    out.push(' ');
                }
                float(out, spec, *x);
            }
        }
    }
    Ok(())
}

/// `body` with its sign prefix, padded to the width (zeros after the sign where asked and
/// numeric).
fn pad(out: &mut String, spec: Spec, sign: &str, body: &str) {
    let len = sign.chars().count() + body.chars().count();
    let fill = spec.width.saturating_sub(len);
    if spec.left {
        out.push_str(sign);
        out.push_str(body);
        out.extend(std::iter::repeat_n(' ', fill));
    } else if spec.zero && spec.conv != 's' && spec.conv != 'c' {
        out.push_str(sign);
        out.extend(std::iter::repeat_n('0', fill));
        out.push_str(body);
    } else {
        out.extend(std::iter::repeat_n(' ', fill));
        out.push_str(sign);
        out.push_str(body);
    }
}

/// The sign prefix of a number: `-`, or `+`/space where the flags ask.
fn sign(spec: Spec, negative: bool) -> &'static str {
    if negative {
        "-"
    } else if spec.plus {
        "+"
    } else if spec.space {
        " "
    } else {
        ""
    }
}

/// An int conversion (`%c`: the character of that code, `?` for none).
fn int(out: &mut String, spec: Spec, i: i64) {
    let u = i as u32 as u64;
    let (negative, body) = match spec.conv {
        'd' | 'i' => (i < 0, i.unsigned_abs().to_string()),
        'u' => (false, u.to_string()),
        'o' => (
            false,
            format!("{}{u:o}", if spec.alt && u != 0 { "0" } else { "" }),
        ),
        'x' => (
            false,
            format!("{}{u:x}", if spec.alt && u != 0 { "0x" } else { "" }),
        ),
        'X' => (
            false,
            format!("{}{u:X}", if spec.alt && u != 0 { "0X" } else { "" }),
        ),
        _ => {
            let c = char::from_u32(u as u32).unwrap_or('?');
            pad(out, spec, "", &c.to_string());
            return;
        }
    };
    // A precision is the least number of digits (and turns off zero padding).
    let body = match spec.precision {
        Some(p) if body.len() < p => format!("{}{body}", "0".repeat(p - body.len())),
        _ => body,
    };
    let spec = Spec {
        zero: spec.zero && spec.precision.is_none(),
        ..spec
    };
    let s = if matches!(spec.conv, 'd' | 'i') {
        sign(spec, negative)
    } else {
        ""
    };
    pad(out, spec, s, &body);
}

/// A float conversion: `%f`, `%e`, `%g` (and upper case) as C prints them.
fn float(out: &mut String, spec: Spec, x: f64) {
    let negative = x.is_sign_negative() && !x.is_nan();
    let a = x.abs();
    let upper = spec.conv.is_ascii_uppercase();
    if !a.is_finite() {
        let body = if a.is_nan() { "nan" } else { "inf" };
        let body = if upper {
            body.to_ascii_uppercase()
        } else {
            body.into()
        };
        let spec = Spec {
            zero: false,
            ..spec
        };
        pad(out, spec, sign(spec, negative), &body);
        return;
    }
    let p = spec.precision.unwrap_or(6);
    let body = match spec.conv.to_ascii_lowercase() {
        'f' => fixed(a, p, spec.alt),
        'e' => exponent(a, p, spec.alt),
        _ => general(a, p, spec.alt),
    };
    let body = if upper {
        body.to_ascii_uppercase()
    } else {
        body
    };
    pad(out, spec, sign(spec, negative), &body);
}

/// `%.pf` of a non-negative finite `a` (`#`: the point even without decimals).
fn fixed(a: f64, p: usize, alt: bool) -> String {
    let s = format!("{a:.p$}");
    if alt && p == 0 { format!("{s}.") } else { s }
}

/// `%.pe` of a non-negative finite `a`: one digit, the point, `p` digits, `e`, a sign and
/// at least two exponent digits.
fn exponent(a: f64, p: usize, alt: bool) -> String {
    let s = format!("{a:.p$e}");
    let (mantissa, exp) = s.split_once('e').unwrap_or((&s, "0"));
    let exp: i32 = exp.parse().unwrap_or(0);
    let point = if alt && p == 0 { "." } else { "" };
    let esign = if exp < 0 { '-' } else { '+' };
    format!("{mantissa}{point}e{esign}{:02}", exp.unsigned_abs())
}

/// `%.pg` of a non-negative finite `a`: `%e` where the exponent is below −4 or at least the
/// precision (0 counts as 1), else `%f`, with trailing zeros removed unless `#`.
fn general(a: f64, p: usize, alt: bool) -> String {
    let p = p.max(1);
    // The exponent `a` has once rounded to p significant digits.
    let e = if a == 0.0 {
        0
    } else {
        let s = format!("{a:.*e}", p - 1);
        s.split_once('e')
            .and_then(|(_, e)| e.parse::<i32>().ok())
            .unwrap_or(0)
    };
    let s = if e < -4 || e >= p as i32 {
        exponent(a, p - 1, alt)
    } else {
        fixed(a, (p as i32 - 1 - e).max(0) as usize, alt)
    };
    if alt {
        return s;
    }
    // Trailing zeros of the fraction go, then a bare point.
    let (num, exp) = match s.find('e') {
        Some(k) => (&s[..k], &s[k..]),
        None => (&s[..], ""),
    };
    let num = if num.contains('.') {
        num.trim_end_matches('0').trim_end_matches('.')
    } else {
        num
    };
    format!("{num}{exp}")
}

#[cfg(test)]
mod tests {
    use super::*;

    fn f(fmt: &str, args: &[Arg]) -> String {
        format(fmt, args).unwrap()
    }

    /// Known arguments become text; the others stay conversions, checked against their kind.
    #[test]
    fn specializing_splices_known_arguments_and_keeps_the_rest() {
        let args = [
            (Arg::Str("50%".into()), true),
            (Arg::Float(0.0), false),
            (Arg::Int(7), true),
            (Arg::Floats(vec![0.0; 3]), false),
        ];
        let s = specialize("%-4s|%+8.3f|%03d|%g%%\n", &args).unwrap();
        assert_eq!(s, "50%% |%+8.3f|007|%g%%\n");
        // The rest is formatted at run time, as the whole would have been.
        let run = [Arg::Float(2.5), Arg::Floats(vec![1.0, 2.0, 3.0])];
        let whole = [
            Arg::Str("50%".into()),
            Arg::Float(2.5),
            Arg::Int(7),
            Arg::Floats(vec![1.0, 2.0, 3.0]),
        ];
        assert_eq!(
            format(&s, &run).unwrap(),
            format("%-4s|%+8.3f|%03d|%g%%\n", &whole).unwrap()
        );
        // An unknown argument is checked against its placeholder.
        let e = specialize("%d", &[(Arg::Float(0.0), false)]).unwrap_err();
        assert!(e.contains("conversion 1 (`%d`) takes an int"), "{e}");
        assert!(specialize("%g %g", &[(Arg::Float(0.0), false)]).is_err());
        assert!(specialize("%g", &[]).is_err());
        // Flags survive the round trip.
        let s = specialize("%#-+ 012.4e", &[(Arg::Float(0.0), false)]).unwrap();
        assert_eq!(s, "%-+ 0#12.4e");
    }

    /// What C's printf prints for these conversions (checked against glibc).
    #[test]
    #[allow(clippy::approx_constant)] // 3.14159 is a value to format, not π.
    fn conversions_are_cs() {
        use Arg::*;
        assert_eq!(
            f(
                "%d|%5d|%-5d|%05d|%+d|% d",
                &[Int(42), Int(-42), Int(7), Int(-7), Int(3), Int(3)]
            ),
            "42|  -42|7    |-0007|+3| 3"
        );
        assert_eq!(
            f(
                "%x %X %#x %o %#o %u %.3d",
                &[
                    Int(255),
                    Int(255),
                    Int(255),
                    Int(8),
                    Int(8),
                    Int(-1),
                    Int(7)
                ]
            ),
            "ff FF 0xff 10 010 4294967295 007"
        );
        assert_eq!(f("%c%c", &[Int(79), Int(75)]), "OK");
        assert_eq!(
            f(
                "%f %.2f %8.3f %-8.1f| %+.0f %#.0f",
                &[
                    Float(1.5),
                    Float(2.346),
                    Float(-3.14159),
                    Float(2.0),
                    Float(2.5),
                    Float(3.0)
                ]
            ),
            "1.500000 2.35   -3.142 2.0     | +2 3."
        );
        assert_eq!(
            f(
                "%e %.2E %e %e",
                &[Float(12345.678), Float(0.000123), Float(0.0), Float(1e-300)]
            ),
            "1.234568e+04 1.23E-04 0.000000e+00 1.000000e-300"
        );
        assert_eq!(
            f(
                "%g %g %g %g %g %g %G",
                &[
                    Float(0.0001),
                    Float(0.00001),
                    Float(123456.0),
                    Float(1234567.0),
                    Float(100.0),
                    Float(0.5),
                    Float(1e-10)
                ]
            ),
            "0.0001 1e-05 123456 1.23457e+06 100 0.5 1E-10"
        );
        assert_eq!(
            f(
                "%.3g %#g %g %.0g",
                &[Float(3.14159), Float(1.0), Float(9.9999999), Float(0.5)]
            ),
            "3.14 1.00000 10 0.5"
        );
        assert_eq!(
            f(
                "%f %e %G %5.1f",
                &[
                    Float(f64::INFINITY),
                    Float(-f64::INFINITY),
                    Float(f64::NAN),
                    Float(f64::NAN)
                ]
            ),
            "inf -inf NAN   nan"
        );
        assert_eq!(
            f(
                "%s|%5s|%-5s|%.2s|%%",
                &[
                    Str("ab".into()),
                    Str("ab".into()),
                    Str("ab".into()),
                    Str("abc".into())
                ]
            ),
            "ab|   ab|ab   |ab|%"
        );
        assert_eq!(f("%d%%", &[Int(5)]), "5%");
    }

    /// Aggregates print each component by the same conversion, separated by spaces; an
    /// int widens for a float conversion.
    #[test]
    fn aggregates_and_widening() {
        let c = Arg::Floats(vec![0.5, 0.25, 1.0]);
        assert_eq!(f("P = %g", std::slice::from_ref(&c)), "P = 0.5 0.25 1");
        assert_eq!(f("%.1f", &[c]), "0.5 0.2 1.0");
        assert_eq!(f("%f", &[Arg::Int(2)]), "2.000000");
    }

    /// Errors say which argument and why.
    #[test]
    fn mismatches_are_errors() {
        let e = |fmt: &str, args: &[Arg]| format(fmt, args).unwrap_err();
        assert_eq!(
            e("%d", &[Arg::Float(1.0)]),
            "conversion 1 (`%d`) takes an int"
        );
        assert_eq!(
            e("%f %s", &[Arg::Float(1.0), Arg::Int(1)]),
            "conversion 2 (`%s`) takes a string"
        );
        assert_eq!(
            e("%f", &[Arg::Str("x".into())]),
            "conversion 1 (`%f`) does not take a string"
        );
        assert_eq!(
            e("%f %f", &[Arg::Float(1.0)]),
            "conversion 2 (`%f`) has no argument"
        );
        assert_eq!(
            e("%f", &[Arg::Float(1.0), Arg::Float(2.0)]),
            "2 arguments but 1 conversions"
        );
        assert_eq!(e("%q", &[]), "unknown conversion `%q`");
        assert_eq!(e("abc %", &[]), "the format ends inside a conversion");
        assert!(e("%99999d", &[Arg::Int(1)]).contains("above 1024"));
    }
}
