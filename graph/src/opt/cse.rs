//! Common subexpression elimination: value numbering over the whole program, with scopes.
//!
//! Two values are the same when they have the same op (kind and immediate fields), the same
//! operands after earlier replacements, and the same type. Constants compare by the exact
//! bits of their floats (`0.0` and `-0.0` differ, and so do NaNs with different payloads).
//! The later of two equal values is replaced by the earlier one everywhere
//! ([`Program::substitute`]) and removed from its block; the pass returns how many values it
//! replaced, 0 when it changed nothing.
//!
//! **Commutative ops.** The operands of `add`, `mul`, `dot`, `eq`, `ne`, `and` and `or` are
//! ordered by handle before comparing, so `a + b` and `b + a` are one value. Each of these
//! is exactly symmetric in [`crate::ops`]: IEEE `x + y` and `x * y` round the same exact
//! result whichever operand comes first (ints wrap the same way), `dot` sums the products
//! `xᵢ·yᵢ = yᵢ·xᵢ` in the same left-to-right order, and `==`, `!=`, `&&`, `||` are
//! symmetric. The only difference a swap can make is which payload a NaN result carries when
//! both operands are NaN, and nothing can observe a payload: no op reads a float's bits, and
//! the output guard turns every NaN into 0. `min` and `max` are *not* canonicalized:
//! `a < b ? a : b` returns `b` when either is NaN and picks differently between `0.0` and
//! `-0.0`, so `min(a, b)` and `min(b, a)` can differ. (`distance` is symmetric too, but is
//! left alone; `sub`, `div`, `cross`, `atan2`, comparisons and the rest are not.)
//!
//! **Scopes.** The prelude is the outermost scope, then the top-level block. Each `If` arm
//! and each `Illuminance` body opens a scope that closes after it: a value defined inside a
//! block may replace values of the same block or of blocks nested in it, never values outside
//! it or in a sibling arm (it is not computed there); a value of an enclosing block may
//! replace one inside. A loop's condition and body are two such scopes; `loop.var k` is one
//! value within one loop's blocks and different across loops (nested ones included). `light.L` and `light.Cl` are the same value within one illuminance
//! body (nested `If` arms included) and different across bodies, including an illuminance
//! nested in another one.
//!
//! **Not done.** Regions themselves (`If`, `Illuminance`) are never merged, even when their
//! operands and blocks are identical (simple, and rare after lowering); two `proj`s of the
//! same region and index are merged. Nothing is reordered or moved between blocks: values
//! only disappear, so results stay bit-identical.

use super::Specialization;
use crate::ir::{
    BinOp, Block, Intrinsic, Op, ProbeField, Program, Sampling, Space, Stream, UnOp, Value,
    XformKind,
};
use crate::types::{ConstValue, Type};
use std::collections::HashMap;

/// Replaces every value equal to an earlier visible one; returns how many were replaced.
pub fn run(p: &mut Program, _spec: &Specialization) -> usize {
    let mut n = Numbering {
        p,
        table: HashMap::new(),
        repl: vec![None; p.exprs.len()],
        light: None,
        loop_: None,
        changes: 0,
    };
    // The prelude is visible to the whole body: one scope for both, never closed.
    n.scope(&p.prelude);
    n.scope(&p.body);
    let (changes, repl) = (n.changes, n.repl);
    if changes == 0 {
        return 0;
    }
    p.substitute(&repl);
    let keep = |v: &Value| repl[v.index()].is_none();
    for e in &mut p.exprs {
        for b in e.op.blocks_mut() {
            b.body.retain(keep);
        }
    }
    p.prelude.body.retain(keep);
    p.body.body.retain(keep);
    changes
}

/// What makes two values equal: the op with its operands resolved (and canonically ordered
/// for commutative ops). Paired with the value's type in the table.
#[derive(Clone, Debug, PartialEq, Eq, Hash)]
enum Key {
    Const(ConstKey),
    Param(u32),
    Stream(Stream),
    Transform(XformKind, Space, Space, Value),
    ComponentEnabled(u8),
    Unary(UnOp, Value),
    Binary(BinOp, Value, Value),
    Select(Value, Value, Value),
    Construct(Vec<Value>),
    Extract(Value, u8),
    Splat(Value),
    Convert(Value),
    Call(Intrinsic, Vec<Value>),
    /// `light.L` of the innermost enclosing illuminance region.
    LightL(Option<Value>),
    /// `light.Cl` of the innermost enclosing illuminance region.
    LightCl(Option<Value>),
    LightVisible(Option<Value>),
    LightPdf(Option<Value>),
    LoopVar(Option<Value>, u8),
    Trace(Value, i32, Option<Value>),
    Occlusion(Value, Value, Value),
    Probe(ProbeField, [Value; 4]),
    Ambient,
    Proj(Value, u8),
    Texture(u32, Value, Option<[Value; 2]>, Sampling, bool),
    Attribute(u32, Value),
    AttributeFound(u32),
}

/// A constant by exact bits (the type, kept beside the key, tells vectors from colors).
#[derive(Clone, Debug, PartialEq, Eq, Hash)]
enum ConstKey {
    Bool(bool),
    Int(i32),
    Floats(Vec<u64>),
    String(String),
}

impl ConstKey {
    fn of(c: &ConstValue) -> ConstKey {
        match c {
            ConstValue::Bool(b) => ConstKey::Bool(*b),
            ConstValue::Int(i) => ConstKey::Int(*i),
            ConstValue::String(s) => ConstKey::String(s.clone()),
            ConstValue::Float(_)
            | ConstValue::Vec2(_)
            | ConstValue::Vec3(_)
            | ConstValue::Color(_)
            | ConstValue::Vec4(_)
            | ConstValue::Color4(_)
            | ConstValue::Matrix33(_)
            | ConstValue::Matrix44(_) => {
                ConstKey::Floats(c.floats().iter().map(|x| x.to_bits()).collect())
            }
        }
    }
}

/// Whether swapping the operands of `op` never changes its result (see the module doc).
fn commutative(op: BinOp) -> bool {
    use BinOp::*;
    match op {
        Add | Mul | Dot | Eq | Ne | And | Or | BitAnd | BitOr | BitXor => true,
        Sub | Div | Mod | Pow | Min | Max | Atan2 | Cross | Distance | Lt | Le | Gt | Ge
        | MulPoint | MulVector | Shl | Shr => false,
    }
}

/// The scoped value table and the replacements found so far.
struct Numbering<'a> {
    p: &'a Program,
    /// Visible representatives by key. Keys are only inserted when absent, so closing a
    /// scope is removing the keys it inserted.
    table: HashMap<(Key, Option<Type>), Value>,
    /// `repl[v]`: the representative replacing `v` (itself never replaced).
    repl: Vec<Option<Value>>,
    /// The innermost illuminance region around the current point.
    light: Option<Value>,
    /// The innermost loop around the current point.
    loop_: Option<Value>,
    changes: usize,
}

impl Numbering<'_> {
    /// Numbers the values of `block` in the current scope; returns the keys it inserted.
    fn scope(&mut self, block: &Block) -> Vec<(Key, Option<Type>)> {
        let mut inserted = Vec::new();
        for &v in &block.body {
            let key = match self.p.op(v) {
                Op::If { then_, else_, .. } => {
                    self.nested(then_);
                    self.nested(else_);
                    continue;
                }
                Op::Illuminance { body, .. } => {
                    let outer = self.light.replace(v);
                    self.nested(body);
                    self.light = outer;
                    continue;
                }
                Op::Loop { cond, body, .. } => {
                    let outer = self.loop_.replace(v);
                    self.nested(cond);
                    self.nested(body);
                    self.loop_ = outer;
                    continue;
                }
                op => match self.key(op) {
                    Some(k) => (k, self.p.expr(v).ty),
                    None => continue,
                },
            };
            match self.table.get(&key) {
                Some(&rep) => {
                    self.repl[v.index()] = Some(rep);
                    self.changes += 1;
                }
                None => {
                    self.table.insert(key.clone(), v);
                    inserted.push(key);
                }
            }
        }
        inserted
    }

    /// Numbers a region's block in a scope of its own.
    fn nested(&mut self, block: &Block) {
        for key in self.scope(block) {
            self.table.remove(&key);
        }
    }

    /// The representative of an operand.
    fn rep(&self, v: Value) -> Value {
        self.repl.get(v.index()).copied().flatten().unwrap_or(v)
    }

    /// The key of an op; `None` for regions and prints, which are never merged.
    fn key(&self, op: &Op) -> Option<Key> {
        let r = |v: &Value| self.rep(*v);
        Some(match op {
            Op::Const(c) => Key::Const(ConstKey::of(c)),
            Op::Param(k) => Key::Param(*k),
            Op::Stream(s) => Key::Stream(*s),
            Op::Transform {
                kind,
                from,
                to,
                arg,
            } => Key::Transform(*kind, *from, *to, r(arg)),
            Op::ComponentEnabled(k) => Key::ComponentEnabled(*k),
            Op::Unary(u, a) => Key::Unary(*u, r(a)),
            Op::Binary(b, x, y) => {
                let (mut x, mut y) = (r(x), r(y));
                if commutative(*b) && y < x {
                    std::mem::swap(&mut x, &mut y);
                }
                Key::Binary(*b, x, y)
            }
            Op::Select { cond, a, b } => Key::Select(r(cond), r(a), r(b)),
            Op::Construct(args) => Key::Construct(args.iter().map(r).collect()),
            Op::Extract(a, i) => Key::Extract(r(a), *i),
            Op::Splat(a) => Key::Splat(r(a)),
            Op::Convert(a) => Key::Convert(r(a)),
            Op::Call(i, args) => Key::Call(*i, args.iter().map(r).collect()),
            Op::LightL => Key::LightL(self.light),
            Op::LightCl => Key::LightCl(self.light),
            Op::LightVisible => Key::LightVisible(self.light),
            Op::LightPdf => Key::LightPdf(self.light),
            // Scene services are pure functions of their arguments (SceneServices' contract),
            // and the shaded point and seed are the fragment's: equal calls give equal results.
            Op::Trace { dir, ray_type, pdf } => Key::Trace(r(dir), *ray_type, pdf.as_ref().map(r)),
            Op::Occlusion {
                n,
                samples,
                max_distance,
            } => Key::Occlusion(r(n), r(samples), r(max_distance)),
            Op::Probe {
                field,
                origin,
                dir,
                min_distance,
                max_distance,
            } => Key::Probe(
                *field,
                [r(origin), r(dir), r(min_distance), r(max_distance)],
            ),
            Op::Ambient => Key::Ambient,
            Op::Proj(region, i) => Key::Proj(r(region), *i),
            Op::Texture {
                texture,
                uv,
                derivs,
                sampling,
                alpha,
            } => Key::Texture(
                *texture,
                r(uv),
                derivs.map(|[dx, dy]| [r(&dx), r(&dy)]),
                *sampling,
                *alpha,
            ),
            // The fragment's attribute: the same slot and default give the same value.
            Op::Attribute { slot, default } => Key::Attribute(*slot, r(default)),
            Op::AttributeFound { slot } => Key::AttributeFound(*slot),
            Op::LoopVar(k) => Key::LoopVar(self.loop_, *k),
            // A message is written once per op that writes it: two are never one.
            Op::If { .. } | Op::Illuminance { .. } | Op::Loop { .. } | Op::Print { .. } => {
                return None;
            }
        })
    }
}
