//! OSL's bitwise operators (issue 22): `&`, `|`, `^`, `<<`, `>>`, `~` and their compound
//! assignments on ints, lowered to the IR's `bitand`, `bitor`, `bitxor`, `shl`, `shr` and
//! `bitnot`. Checked against Rust's operators on hard operand pairs — folded at compile time
//! and computed while shading — and a lookup3-style hash written as a shader run by the
//! interpreter and the JIT's scalar and batch entries bit for bit. (Every back end's op
//! table, the GPU's included, takes the new ops in `tests/backends.rs` and
//! `gpu/tests/emit.rs`.)

mod common;
use common::*;
use shadenet::graph::ir::{BinOp, Op, UnOp};
use shadenet::graph::opt::{self, Specialization};
use shadenet::lang::Dialect;

/// Operand pairs: signs, zero, the extremes, and shift counts beyond 31 and negative.
const PAIRS: &[(i32, i32)] = &[
    (0, 0),
    (1, 31),
    (-1, 1),
    (0x1234_5678, 4),
    (-123_456_789, 7),
    (i32::MIN, 1),
    (i32::MAX, 30),
    (-8, 33),
    (5, -1),
    (0x0f0f_0f0f, 100),
    (-2, i32::MIN),
];

/// What the IR's ops give (shift counts: their low five bits), as Rust computes them.
fn want(a: i32, b: i32) -> [i32; 6] {
    [
        a & b,
        a | b,
        a ^ b,
        a.wrapping_shl(b as u32),
        a.wrapping_shr(b as u32),
        !a,
    ]
}

/// The six results as twelve exact floats (16-bit halves, so f32 holds them).
fn halves(x: [i32; 6]) -> Vec<f64> {
    x.iter()
        .flat_map(|v| [f64::from(*v & 0xffff), f64::from((*v >> 16) & 0xffff)])
        .collect()
}

/// A shader with the six results of `a` and `b` in its outputs `o0`…`o5` as halves; with
/// `varying`, the operands are read through `u` (0.5 on the plane fragment) so that they are
/// not known at compile time.
fn shader(a: i32, b: i32, varying: bool) -> String {
    let (x, y) = if varying {
        (
            format!("({a} + int(u - 0.5))"),
            format!("({b} + int(u * 0.5))"),
        )
    } else {
        (format!("({a})"), format!("({b})"))
    };
    let exprs = [
        format!("{x} & {y}"),
        format!("{x} | {y}"),
        format!("{x} ^ {y}"),
        format!("{x} << {y}"),
        format!("{x} >> {y}"),
        format!("~{x}"),
    ];
    let outs: Vec<String> = (0..6).map(|k| format!("output color o{k} = 0")).collect();
    let body: Vec<String> = exprs
        .iter()
        .enumerate()
        .map(|(k, e)| {
            format!("int r{k} = {e}; o{k} = color(r{k} & 0xffff, (r{k} >> 16) & 0xffff, 0);")
        })
        .collect();
    format!("shader s({}) {{ {} }}", outs.join(", "), body.join(" "))
}

#[test]
fn bitwise_operators_are_cs() {
    for &(a, b) in PAIRS {
        for varying in [false, true] {
            let src = shader(a, b, varying);
            let p = compile_shader(&src, Dialect::Osl).unwrap_or_else(|e| panic!("{e}\n{src}"));
            // As written, and optimized: the constant folder computes the constant cases.
            let (folded, _) = opt::run(&p, &Specialization::default());
            let bit_ops = folded
                .exprs
                .iter()
                .filter(|e| {
                    matches!(
                        e.op,
                        Op::Unary(UnOp::BitNot, _)
                            | Op::Binary(
                                BinOp::BitAnd
                                    | BinOp::BitOr
                                    | BinOp::BitXor
                                    | BinOp::Shl
                                    | BinOp::Shr,
                                ..
                            )
                    )
                })
                .count();
            assert_eq!(bit_ops == 0, !varying, "{bit_ops} bit ops left\n{src}");
            for (p, how) in [(&p, "as written"), (&folded, "optimized")] {
                let o = run_program(p, &plane_fragment(), &[], u32::MAX);
                let got = |get: &dyn Fn(&str) -> Vec<f64>| -> Vec<f64> {
                    (0..6)
                        .flat_map(|k| get(&format!("o{k}"))[..2].to_vec())
                        .collect()
                };
                let what = format!("a = {a}, b = {b}, varying {varying}, {how}");
                assert_eq!(got(&|n| o.get(n)), halves(want(a, b)), "{what} (f64)");
                assert_eq!(got(&|n| o.get32(n)), halves(want(a, b)), "{what} (f32)");
            }
        }
    }
}

#[test]
fn compound_assignments_and_hex_literals() {
    let src = r#"shader s(output color out = 0) {
        int h = 0xdeadbeef;
        h ^= 0x5bd1e995;
        h <<= 3;
        h |= 5;
        h &= ~0xff00;
        h >>= 2;
        int a[2] = { 6, 3 };
        a[1] <<= a[0];
        out = color(h & 0xffff, (h >> 16) & 0xffff, a[1]);
    }"#;
    let p = compile_shader(src, Dialect::Osl).unwrap_or_else(|e| panic!("{e}"));
    let o = run_program(&p, &plane_fragment(), &[], u32::MAX);
    let mut h = 0xdead_beef_u32 as i32;
    h ^= 0x5bd1_e995;
    h <<= 3;
    h |= 5;
    h &= !0xff00;
    h >>= 2;
    let want = [
        f64::from(h & 0xffff),
        f64::from((h >> 16) & 0xffff),
        f64::from(3 << 6),
    ];
    assert_eq!(o.get("out"), want);
    assert_eq!(o.get32("out"), want);
}

/// A lookup3-style mix (Jenkins' `final`, rotations as shifts and masks since OSL's `>>` is
/// arithmetic) of each fragment's pixel: the JIT's scalar and batch entries give the
/// interpreter's bits on a grid.
#[test]
fn a_hash_shader_runs_on_the_jit_as_on_the_interpreter() {
    let src = r#"
        int rot(int x, int k) { return (x << k) | ((x >> (32 - k)) & ((1 << k) - 1)); }
        shader s(output color out = 0) {
            int a = int(u * 1000), b = int(v * 1000), c = 0xdeadbeef;
            c ^= b; c -= rot(b, 14);
            a ^= c; a -= rot(c, 11);
            b ^= a; b -= rot(a, 25);
            c ^= b; c -= rot(b, 16);
            a ^= c; a -= rot(c, 4);
            b ^= a; b -= rot(a, 14);
            c ^= b; c -= rot(b, 24);
            out = color(c & 0xfff, (c >> 12) & 0xfff, ~c >> 24);
        }"#;
    let p = compile_shader(src, Dialect::Osl).unwrap_or_else(|e| panic!("{e}"));
    let want = assert_jit_is_interp(&p, 9, 7);
    // The pixels differ (a hash that came out constant would say nothing).
    let distinct: std::collections::HashSet<_> = want.chunks(3).collect();
    assert!(distinct.len() > 50, "{} distinct pixels", distinct.len());
}

#[test]
fn bitwise_operators_want_ints() {
    for (dialect, body, want) in [
        (
            Dialect::Osl,
            "float x = 1.5 & 2;",
            "`&` takes two ints: not a float and an int",
        ),
        (
            Dialect::Osl,
            "int k = 1 << 2.0;",
            "`<<` takes two ints: not an int and a float",
        ),
        (
            Dialect::Osl,
            "color c = ~color(1);",
            "this operator does not apply to a color",
        ),
        (
            Dialect::Rsl,
            "float x = 1 | 2;",
            "`|` takes two ints: RSL has no integers",
        ),
    ] {
        let src = format!("surface s() {{ {body} }}");
        let err = compile_shader(&src, dialect).unwrap_err();
        assert!(err.contains(want), "{body}\n→ {err}");
    }
}
