//! Constant folding and exact algebraic identities.
//!
//! **Folding.** An op all of whose operands are constants is evaluated once, here, with the
//! op semantics of [`crate::ops`] **in f32** (the shading precision), and replaced in place by
//! the constant (its handle and type stay). The operands are rounded to f32 exactly as the
//! interpreter rounds constants when it loads them, and the f32 result is stored widened to
//! f64 (exact), so the f32 interpreter reads back the very bits it would have computed: a
//! folded program shades bit-identically in f32. (The f64 reference should run the
//! unoptimized program.) Intrinsics (noise, colour conversions) are pure and fold too;
//! `mulpoint`/`mulvector` fold with the matrix rounded to f32, as the interpreter's matrix
//! table holds it; a `select` of matrices or strings picks its constant operand unchanged.
//!
//! **Messages.** A print op's constant arguments are formatted into its format (the same
//! text, formatted once here); the print itself stays.
//!
//! Never folded: what reads the fragment, the instance or the environment (`stream`,
//! `param`, `transform`, which needs the shading context's matrices, `component_enabled`,
//! `light.L`, `light.Cl`, `ambient`, `texture`), regions and their `proj`s (constant
//! conditions are the dead-branch pass's business).
//!
//! **Identities.** A value equal to one of its operands *for every input* — NaN, ±0 and
//! ±inf included — and of the same type is replaced by that operand (all its uses, through
//! [`Program::substitute`]; the value itself stays listed for DCE to remove). The constants
//! an identity tests are compared on their stored f64 bits, so each rule is exact in f32 and
//! in f64 alike:
//!
//! | rule | why it is exact |
//! |---|---|
//! | `x * 1`, `1 * x` (every component exactly `1.0`) | IEEE `x × 1 = x` for every x, sign of zero and infinities kept, NaN stays NaN |
//! | `x / 1` | `ops::div` only special-cases a zero divisor; `x ÷ 1 = x` in IEEE |
//! | `x - (+0.0)` | `x − (+0) = x`; for `x = −0`: `−0 − +0 = −0`. (Not `x − (−0)`: `−0 + 0 = +0`.) |
//! | `x + (−0.0)`, `(−0.0) + x` | `x + (−0) = x`, also `+0 + −0 = +0` and `−0 + −0 = −0`. (Not `x + 0.0`: `−0 + 0 = +0`.) |
//! | ints: `x + 0`, `0 + x`, `x - 0`, `x * 1`, `1 * x`, `x / 1` | wrapping arithmetic; no rounding |
//! | ints: `x * 0`, `0 * x` → the `0` operand | wrapping multiplication by 0 is 0 |
//! | `min(x, x)`, `max(x, x)` → `x` | `a < b ? a : b` with `a` and `b` the same value yields that value (NaN: the comparison is false, the second operand, the same NaN) |
//! | `select(c, x, x)` → `x` | both arms are the same value |
//! | `neg(neg(x))` → `x` | float negation flips the sign bit (NaN, ±0, ±inf included); int `wrapping_neg` is an involution (also on `i32::MIN`) |
//! | `not(not(b))` → `b` | bools |
//! | `and(b, b)`, `or(b, b)`, `and(b, true)`, `or(b, false)` (either side) → `b`; `and(b, false)`, `or(b, true)` → the constant | bools |
//! | `convert` to the operand's own type → the operand | `ops::convert` returns the value unchanged |
//! | `extract(construct(a, b, c), i)` → the i-th argument; `extract(splat(x), i)` → `x` | construct and splat store floats untouched |
//! | `construct(extract(v, 0), …, extract(v, n-1))` → `v` when `v` has the constructed type | the same floats in the same places |
//!
//! Deliberately **not** applied (not exact for every input): `x * 0` on floats (`inf * 0 =
//! NaN`, `-1 * 0 = -0`), `x - x` (`inf - inf = NaN`), `x + 0.0` on floats (`-0 + 0 = +0`),
//! `x / x` (`0/0` is `0` here, NaN/NaN is NaN), `0 / x` (`0/0 = 0` but `0/NaN = NaN`),
//! `x == x` (NaN). `pow(x, 1)` is left alone: `ops::pow` ends in the platform's `powf`,
//! whose result at exponent 1 is not specified by IEEE 754 to be `x`, so exactness would
//! depend on the libm (and on the GPU's `pow`). `mulpoint(identity, p)` is not `p` either
//! (`0 * inf = NaN`, `-0 + 0 = +0`).
//!
//! The pass reports one change per folded value and per identity whose value still had a
//! use, so it reports 0 exactly when it leaves the program as it found it.

use super::Specialization;
use crate::ir::{BinOp, Op, Program, UnOp, Value};
use crate::ops::{self, Val};
use crate::types::{ConstValue, Type};

/// Folds constants and applies exact identities; returns the number of values folded plus
/// the number of used values replaced by an identity.
pub fn run(p: &mut Program, _spec: &Specialization) -> usize {
    let order = p.listed();
    let used = used_values(p);
    let mut map: Vec<Option<Value>> = vec![None; p.exprs.len()];
    let mut changes = 0;
    let mut substituted = false;
    for v in order {
        let i = v.index();
        let (op, ty) = {
            let e = &p.exprs[i];
            if e.op.is_region() || matches!(e.op, Op::Const(_)) {
                continue;
            }
            let Some(ty) = e.ty else { continue };
            let mut op = e.op.clone();
            for o in op.operands_mut() {
                *o = resolve(&map, *o);
            }
            (op, ty)
        };
        if let Op::Print { .. } = op {
            if let Some(spliced) = splice_print(p, &op) {
                p.exprs[i].op = spliced;
                changes += 1;
            }
        } else if let Some(c) = fold(p, &op, ty) {
            p.exprs[i].op = Op::Const(c);
            changes += 1;
        } else if let Some(t) = identity(p, &map, &op, ty) {
            map[i] = Some(t);
            substituted = true;
            if used[i] {
                changes += 1;
            }
        }
    }
    if substituted {
        p.substitute(&map);
    }
    changes
}

/// Follows `map` from `v` to the value that replaces it (`v` itself if none does).
pub(super) fn resolve(map: &[Option<Value>], mut v: Value) -> Value {
    // Each step goes to an earlier value (an operand), so this terminates; the bound only
    // guards against a malformed map.
    for _ in 0..map.len() {
        match map.get(v.index()).copied().flatten() {
            Some(next) if next != v => v = next,
            _ => break,
        }
    }
    v
}

/// Which values are read by a listed value (operand or, for a region, yield) or an output:
/// exactly the values whose substitution changes the program.
pub(super) fn used_values(p: &Program) -> Vec<bool> {
    let mut used = vec![false; p.exprs.len()];
    for v in p.listed() {
        let op = p.op(v);
        op.for_each_operand(|a| {
            if let Some(u) = used.get_mut(a.index()) {
                *u = true;
            }
        });
        for b in op.blocks() {
            for y in &b.yields {
                if let Some(u) = used.get_mut(y.index()) {
                    *u = true;
                }
            }
        }
    }
    for o in &p.outputs {
        if let Some(u) = used.get_mut(o.value.index()) {
            *u = true;
        }
    }
    used
}

/// A print op with its constant arguments formatted into its format
/// ([`crate::ops::printf::specialize`]): the message is the same, formatted once here;
/// `None` when no argument is a constant (or, in an invalid program, the format does not
/// fit).
fn splice_print(p: &Program, op: &Op) -> Option<Op> {
    use crate::ops::printf;
    let Op::Print {
        severity,
        format,
        args,
    } = op
    else {
        return None;
    };
    if !args.iter().any(|a| konst(p, *a).is_some()) {
        return None;
    }
    let mut slots = Vec::with_capacity(args.len());
    let mut left = Vec::new();
    for &a in args {
        match konst(p, a) {
            Some(c) => slots.push((printf::const_arg(c), true)),
            None => {
                slots.push((printf::placeholder(p.ty(a))?, false));
                left.push(a);
            }
        }
    }
    Some(Op::Print {
        severity: *severity,
        format: printf::specialize(format, &slots).ok()?,
        args: left,
    })
}

/// The constant operand `v`, if it is one.
fn konst(p: &Program, v: Value) -> Option<&ConstValue> {
    match p.exprs.get(v.index()).map(|e| &e.op) {
        Some(Op::Const(c)) => Some(c),
        _ => None,
    }
}

/// `op` (operands already resolved) evaluated in f32 when every operand is a constant, as
/// a constant of type `ty`; `None` when it cannot or must not be folded.
fn fold(p: &Program, op: &Op, ty: Type) -> Option<ConstValue> {
    // Inputs, context-dependent ops, regions and projections are never folded.
    if !op.is_pure() {
        return None;
    }
    let mut consts: Vec<&ConstValue> = Vec::new();
    let mut all = true;
    op.for_each_operand(|o| match konst(p, o) {
        Some(c) => consts.push(c),
        None => all = false,
    });
    if !all {
        return None;
    }
    fold_consts(op, ty, &consts)
}

/// A foldable `op` of type `ty` evaluated on its constant operands `consts` (in operand
/// order), as [`fold`] does.
pub(super) fn fold_consts(op: &Op, ty: Type, consts: &[&ConstValue]) -> Option<ConstValue> {
    // Matrices and strings have no f32 register form: a select picks its operand as is; a
    // matrix construct keeps its elements rounded to f32, as every back end holds them.
    if ty.is_matrix() || ty == Type::String {
        return match (op, consts) {
            (Op::Select { .. }, [ConstValue::Bool(c), a, b]) => {
                Some(if *c { (*a).clone() } else { (*b).clone() })
            }
            (Op::Construct(_), cs) => {
                let xs: Option<Vec<f64>> = cs
                    .iter()
                    .map(|c| match c {
                        ConstValue::Float(x) => Some(*x as f32 as f64),
                        _ => None,
                    })
                    .collect();
                ConstValue::from_floats(ty, &xs?)
            }
            _ => None,
        };
    }
    if let (Op::Extract(_, k), [c]) = (op, consts)
        && c.ty().is_matrix()
    {
        let x = *c.floats().get(*k as usize)?;
        return Some(ConstValue::Float(x as f32 as f64));
    }
    let vals: Vec<Val<f32>> = consts.iter().map(|c| Val::from_const(c)).collect();
    let val = |k: usize| vals.get(k).copied();
    let r = match op {
        Op::Unary(u, _) => ops::unary(*u, val(0)?),
        Op::Binary(b @ (BinOp::MulPoint | BinOp::MulVector), ..) => {
            let ConstValue::Matrix44(m) = consts.first()? else {
                return None;
            };
            let m = m.map(|x| x as f32);
            let v = val(1)?.as_vec3();
            Val::Vec3(if *b == BinOp::MulPoint {
                ops::mul_point(&m, v)
            } else {
                ops::mul_vector(&m, v)
            })
        }
        Op::Binary(b, ..) => {
            if consts
                .iter()
                .any(|c| c.ty().is_matrix() || matches!(c, ConstValue::String(_)))
            {
                return None;
            }
            ops::binary(*b, val(0)?, val(1)?)
        }
        Op::Select { .. } => ops::select(val(0)?, val(1)?, val(2)?),
        Op::Construct(_) => ops::construct(ty, &vals),
        Op::Extract(_, k) => ops::extract(val(0)?, *k),
        Op::Splat(_) => ops::splat(ty, val(0)?),
        Op::Convert(_) => ops::convert(ty, val(0)?),
        Op::Call(f, _) => ops::intrinsic(*f, &vals),
        _ => return None,
    };
    let c = r.to_const(ty);
    // A valid program always gives a value of the recorded type; anything else stays as is.
    (c.ty() == ty).then_some(c)
}

/// The constant `v` is in every fragment of a program *under construction* (the builder's
/// arena: no blocks needed), or `None` where it depends on the fragment, the environment
/// or a region: what folding would make of it, with every parameter at its default (the
/// instance the material is compiled as), a `select` on a constant condition taking its
/// arm without looking at the other, and `and`/`or` decided by one constant side. For lowerings that must decide at compile time (an
/// unbuilt feature whose lobe weight is 0 is dropped, not refused).
pub fn constant(p: &Program, v: Value) -> Option<ConstValue> {
    let mut memo = std::collections::HashMap::new();
    constant_memo(p, v, &mut memo, 0)
}

/// [`constant`] with a memo; `depth` bounds the recursion (deep chains give `None`).
fn constant_memo(
    p: &Program,
    v: Value,
    memo: &mut std::collections::HashMap<usize, Option<ConstValue>>,
    depth: usize,
) -> Option<ConstValue> {
    if let Some(c) = memo.get(&v.index()) {
        return c.clone();
    }
    if depth > 512 {
        return None;
    }
    let e = p.exprs.get(v.index())?;
    let c = match &e.op {
        Op::Const(c) => Some(c.clone()),
        Op::Param(i) => p.params.get(*i as usize).map(|d| d.default.clone()),
        Op::Select { cond, a, b } => match constant_memo(p, *cond, memo, depth + 1) {
            Some(ConstValue::Bool(t)) => constant_memo(p, if t { *a } else { *b }, memo, depth + 1),
            _ => None,
        },
        // `and` with a false side and `or` with a true side need not know the other.
        Op::Binary(op @ (BinOp::And | BinOp::Or), x, y) => {
            let absorbing = ConstValue::Bool(*op == BinOp::Or);
            let cx = constant_memo(p, *x, memo, depth + 1);
            let cy = constant_memo(p, *y, memo, depth + 1);
            match (cx, cy) {
                (Some(a), _) if a == absorbing => Some(absorbing),
                (_, Some(a)) if a == absorbing => Some(absorbing),
                (Some(ConstValue::Bool(a)), Some(ConstValue::Bool(b))) => {
                    Some(ConstValue::Bool(if *op == BinOp::Or {
                        a || b
                    } else {
                        a && b
                    }))
                }
                _ => None,
            }
        }
        op => {
            let ty = e.ty?;
            let mut operands = Vec::new();
            op.for_each_operand(|o| operands.push(o));
            let mut consts = Vec::with_capacity(operands.len());
            for o in operands {
                consts.push(constant_memo(p, o, memo, depth + 1)?);
            }
            let refs: Vec<&ConstValue> = consts.iter().collect();
            match op.is_pure() {
                true => fold_consts(op, ty, &refs),
                false => None,
            }
        }
    };
    memo.insert(v.index(), c.clone());
    c
}

/// Every float component of `c` has exactly the f64 bits `bits` (false for non-float
/// constants).
fn all_bits(c: Option<&ConstValue>, bits: u64) -> bool {
    match c {
        Some(
            c @ (ConstValue::Float(_)
            | ConstValue::Vec2(_)
            | ConstValue::Vec3(_)
            | ConstValue::Color(_)),
        ) => c.floats().iter().all(|x| x.to_bits() == bits),
        _ => false,
    }
}

const ONE: u64 = 0x3ff0_0000_0000_0000;
const POS_ZERO: u64 = 0;
const NEG_ZERO: u64 = 0x8000_0000_0000_0000;

/// The operand `op` (operands already resolved) always equals, if an exact identity
/// applies, resolved and of type `ty`.
fn identity(p: &Program, map: &[Option<Value>], op: &Op, ty: Type) -> Option<Value> {
    let k = |v: Value| konst(p, v);
    let int = |v: Value, n: i32| matches!(k(v), Some(ConstValue::Int(x)) if *x == n);
    let boolean = |v: Value, b: bool| matches!(k(v), Some(ConstValue::Bool(x)) if *x == b);
    let float = |v: Value, bits: u64| all_bits(k(v), bits);
    let is_int = ty == Type::Int;
    let is_float = ty.is_float_based();
    let target = match op {
        Op::Unary(UnOp::Neg, a) if is_int || is_float => match p.op(*a) {
            Op::Unary(UnOp::Neg, x) => Some(*x),
            _ => None,
        },
        Op::Unary(UnOp::Not, a) => match p.op(*a) {
            Op::Unary(UnOp::Not, x) => Some(*x),
            _ => None,
        },
        Op::Binary(BinOp::Add, a, b) if is_int => {
            if int(*b, 0) {
                Some(*a)
            } else if int(*a, 0) {
                Some(*b)
            } else {
                None
            }
        }
        Op::Binary(BinOp::Add, a, b) if is_float => {
            if float(*b, NEG_ZERO) {
                Some(*a)
            } else if float(*a, NEG_ZERO) {
                Some(*b)
            } else {
                None
            }
        }
        Op::Binary(BinOp::Sub, a, b) if is_int && int(*b, 0) => Some(*a),
        Op::Binary(BinOp::Sub, a, b) if is_float && float(*b, POS_ZERO) => Some(*a),
        Op::Binary(BinOp::Mul, a, b) if is_int => {
            if int(*b, 1) || int(*a, 0) {
                Some(*a)
            } else if int(*a, 1) || int(*b, 0) {
                Some(*b)
            } else {
                None
            }
        }
        Op::Binary(BinOp::Mul, a, b) if is_float => {
            if float(*b, ONE) {
                Some(*a)
            } else if float(*a, ONE) {
                Some(*b)
            } else {
                None
            }
        }
        Op::Binary(BinOp::Div, a, b) if (is_int && int(*b, 1)) || (is_float && float(*b, ONE)) => {
            Some(*a)
        }
        Op::Binary(BinOp::Min | BinOp::Max, a, b) if a == b => Some(*a),
        Op::Binary(BinOp::And, a, b) => {
            if a == b || boolean(*b, true) || boolean(*a, false) {
                Some(*a)
            } else if boolean(*a, true) || boolean(*b, false) {
                Some(*b)
            } else {
                None
            }
        }
        Op::Binary(BinOp::Or, a, b) => {
            if a == b || boolean(*b, false) || boolean(*a, true) {
                Some(*a)
            } else if boolean(*a, false) || boolean(*b, true) {
                Some(*b)
            } else {
                None
            }
        }
        Op::Select { a, b, .. } if a == b => Some(*a),
        Op::Convert(a) => Some(*a),
        Op::Extract(a, i) => match p.op(*a) {
            Op::Construct(args) => args.get(*i as usize).copied(),
            Op::Splat(x) => Some(*x),
            _ => None,
        },
        Op::Construct(args) if args.len() == ty.width() => {
            let mut src = None;
            let mut ok = true;
            for (j, a) in args.iter().enumerate() {
                match p.op(*a) {
                    Op::Extract(v, i) if *i as usize == j => {
                        let v = resolve(map, *v);
                        ok &= *src.get_or_insert(v) == v;
                    }
                    _ => ok = false,
                }
            }
            src.filter(|_| ok)
        }
        _ => None,
    }?;
    let target = resolve(map, target);
    // Same type as the value replaced (this also rules out `convert` between types).
    (p.exprs.get(target.index())?.ty == Some(ty)).then_some(target)
}
