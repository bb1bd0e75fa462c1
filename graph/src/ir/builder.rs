//! Building programs: the API node lowerings use.
//!
//! The builder appends values to the innermost open block and infers each value's type with
//! the rules of [`crate::ops`]. A lowering that asks for an ill-typed op is a bug in the
//! lowering, not in the user's network; the builder records the first such error (and keeps
//! going with a placeholder of a plausible type), and [`Builder::finish`] reports it.
//!
//! **Stream overrides** (DESIGN §3): while overrides are in force
//! ([`Builder::push_overrides`]), [`Builder::stream`] returns the overriding value instead of
//! reading the fragment. The lowering driver uses them to re-evaluate a node's upstream
//! subgraph with, say, `uv` moved (bump mapping): the overrides exist only while that
//! subgraph is being lowered, so the program itself has no mutable state. The builder also
//! records which streams were read ([`Builder::take_streams_read`]), so the driver knows
//! which nodes an override changes.

use super::{
    BinOp, Block, Expr, Filter, Intrinsic, Op, Output, ProbeField, Program, Sampling, Severity,
    Space, Stream, TextureFile, UnOp, Value, is_traceable_ray_type,
};
use crate::ops;
use crate::transport::LightStrategy;
use crate::types::{ConstValue, Type};

/// Appends typed values to a [`Program`].
#[derive(Debug)]
pub struct Builder {
    program: Program,
    /// Open blocks; the last is the innermost.
    blocks: Vec<Block>,
    error: Option<String>,
    /// Stream overrides in force, innermost last.
    overrides: Vec<(Stream, Value)>,
    /// Streams read through [`Builder::stream`] since the last [`Builder::take_streams_read`]
    /// (bit [`Stream::bit`]).
    streams_read: u32,
    /// How the surface lowering lights closures (a lowering option).
    light_strategy: LightStrategy,
}

impl Builder {
    /// A builder for an empty program called `name`.
    pub fn new(name: &str) -> Builder {
        Builder {
            program: Program {
                name: name.to_string(),
                ..Program::default()
            },
            blocks: vec![Block::default()],
            error: None,
            overrides: Vec::new(),
            streams_read: 0,
            light_strategy: LightStrategy::Mis,
        }
    }

    /// How the surface lowering lights closures ([`LightStrategy::Mis`] unless set).
    pub fn light_strategy(&self) -> LightStrategy {
        self.light_strategy
    }

    /// Sets how the surface lowering lights closures.
    pub fn set_light_strategy(&mut self, s: LightStrategy) {
        self.light_strategy = s;
    }

    /// The program so far (values, outputs, components), for reading types.
    pub fn program(&self) -> &Program {
        &self.program
    }

    /// The type of a value built so far.
    pub fn ty(&self, v: Value) -> Type {
        self.program.exprs[v.index()].ty.unwrap_or(Type::Float)
    }

    /// Records an internal error (the first one wins).
    pub fn fail(&mut self, msg: impl Into<String>) {
        if self.error.is_none() {
            self.error = Some(msg.into());
        }
    }

    /// Appends an expr to the innermost block.
    pub fn push(&mut self, op: Op, ty: Option<Type>) -> Value {
        let v = Value::new(self.program.exprs.len());
        self.program.exprs.push(Expr { op, ty });
        self.blocks
            .last_mut()
            .expect("builder always has a block")
            .body
            .push(v);
        v
    }

    /// A constant.
    pub fn constant(&mut self, c: ConstValue) -> Value {
        let ty = c.ty();
        self.push(Op::Const(c), Some(ty))
    }

    /// A float constant.
    pub fn float(&mut self, x: f64) -> Value {
        self.constant(ConstValue::Float(x))
    }

    /// An int constant.
    pub fn int(&mut self, i: i32) -> Value {
        self.constant(ConstValue::Int(i))
    }

    /// A bool constant.
    pub fn boolean(&mut self, b: bool) -> Value {
        self.constant(ConstValue::Bool(b))
    }

    /// A vec3 constant.
    pub fn vec3(&mut self, v: [f64; 3]) -> Value {
        self.constant(ConstValue::Vec3(v))
    }

    /// A color constant.
    pub fn color(&mut self, v: [f64; 3]) -> Value {
        self.constant(ConstValue::Color(v))
    }

    /// The zero of a type.
    pub fn zero(&mut self, ty: Type) -> Value {
        self.constant(ConstValue::zero(ty))
    }

    /// An implicit stream in world space: the fragment's, or the innermost override of `s`
    /// in force.
    pub fn stream(&mut self, s: Stream) -> Value {
        self.streams_read |= s.bit();
        if let Some(&(_, v)) = self.overrides.iter().rev().find(|(t, _)| *t == s) {
            return v;
        }
        self.push(Op::Stream(s), Some(s.ty()))
    }

    /// Puts stream overrides in force (on top of those already in force): until the matching
    /// [`Builder::pop_overrides`], [`Builder::stream`] of an overridden stream returns its
    /// value (world space, of the stream's type; a value of another type is recorded as an
    /// internal error).
    pub fn push_overrides(&mut self, overrides: &[(Stream, Value)]) {
        for &(s, v) in overrides {
            if self.ty(v) != s.ty() {
                let t = self.ty(v);
                self.fail(format!("override of stream {} with a {t}", s.name()));
            }
            self.overrides.push((s, v));
        }
    }

    /// Ends the last `n` overrides put in force.
    pub fn pop_overrides(&mut self, n: usize) {
        let keep = self.overrides.len().saturating_sub(n);
        self.overrides.truncate(keep);
    }

    /// The streams overridden now (bits [`Stream::bit`]).
    pub fn overridden_streams(&self) -> u32 {
        self.overrides.iter().fold(0, |m, (s, _)| m | s.bit())
    }

    /// The streams read through [`Builder::stream`] since the last call (bits
    /// [`Stream::bit`]; overridden reads count), and starts a new record.
    pub fn take_streams_read(&mut self) -> u32 {
        std::mem::take(&mut self.streams_read)
    }

    /// An implicit stream read in `space` (a transform is inserted unless `space` is world or
    /// the stream does not transform).
    pub fn stream_in(&mut self, s: Stream, space: Space) -> Value {
        let v = self.stream(s);
        match s.xform_kind() {
            Some(kind) if space != Space::World => self.push(
                Op::Transform {
                    kind,
                    from: Space::World,
                    to: space,
                    arg: v,
                },
                Some(Type::Vec3),
            ),
            _ => v,
        }
    }

    /// Whether render component `name` is active (registers the component name).
    pub fn component_enabled(&mut self, name: &str) -> Value {
        let k = self.component(name);
        self.push(Op::ComponentEnabled(k), Some(Type::Bool))
    }

    /// The index of a component name, registering it if new.
    pub fn component(&mut self, name: &str) -> u8 {
        if let Some(k) = self.program.component_index(name) {
            return k;
        }
        if self.program.components.len() >= 32 {
            self.fail("more than 32 render components");
            return 31;
        }
        self.program.components.push(name.to_string());
        (self.program.components.len() - 1) as u8
    }

    /// A unary op.
    pub fn unary(&mut self, op: UnOp, a: Value) -> Value {
        let at = self.ty(a);
        let ty = ops::unary_type(op, at).unwrap_or_else(|| {
            self.fail(format!("{} is not defined on {at}", op.name()));
            at
        });
        self.push(Op::Unary(op, a), Some(ty))
    }

    /// A binary op.
    pub fn binary(&mut self, op: BinOp, a: Value, b: Value) -> Value {
        let (at, bt) = (self.ty(a), self.ty(b));
        let ty = ops::binary_type(op, at, bt).unwrap_or_else(|| {
            self.fail(format!("{} is not defined on ({at}, {bt})", op.name()));
            at
        });
        self.push(Op::Binary(op, a, b), Some(ty))
    }

    /// `a + b`.
    pub fn add(&mut self, a: Value, b: Value) -> Value {
        self.binary(BinOp::Add, a, b)
    }

    /// `a - b`.
    pub fn sub(&mut self, a: Value, b: Value) -> Value {
        self.binary(BinOp::Sub, a, b)
    }

    /// `a * b`.
    pub fn mul(&mut self, a: Value, b: Value) -> Value {
        self.binary(BinOp::Mul, a, b)
    }

    /// `a / b` (total).
    pub fn div(&mut self, a: Value, b: Value) -> Value {
        self.binary(BinOp::Div, a, b)
    }

    /// `min(a, b)`.
    pub fn min(&mut self, a: Value, b: Value) -> Value {
        self.binary(BinOp::Min, a, b)
    }

    /// `max(a, b)`.
    pub fn max(&mut self, a: Value, b: Value) -> Value {
        self.binary(BinOp::Max, a, b)
    }

    /// `dot(a, b)`.
    pub fn dot(&mut self, a: Value, b: Value) -> Value {
        self.binary(BinOp::Dot, a, b)
    }

    /// `normalize(a)`.
    pub fn normalize(&mut self, a: Value) -> Value {
        self.unary(UnOp::Normalize, a)
    }

    /// `clamp(x, lo, hi) = min(max(x, lo), hi)`.
    pub fn clamp(&mut self, x: Value, lo: Value, hi: Value) -> Value {
        let m = self.max(x, lo);
        self.min(m, hi)
    }

    /// `mix(a, b, t)`: exactly `a` where `t == 0`, exactly `b` where `t == 1`, else
    /// `a * (1 - t) + b * t` (a float `t` is splatted for the arithmetic). The exact ends
    /// make a constant weight of 0 or 1 an exact dead-branch case, whatever `a` and `b` hold
    /// (even ±inf or NaN).
    pub fn mix(&mut self, a: Value, b: Value, t: Value) -> Value {
        let ty = self.ty(a);
        let scalar_t = t;
        let t = self.splat_to(ty, t);
        let one = self.constant(
            ConstValue::from_floats(ty, &vec![1.0; ty.width()]).unwrap_or(ConstValue::Float(1.0)),
        );
        let omt = self.sub(one, t);
        let x = self.mul(a, omt);
        let y = self.mul(b, t);
        let lerp = self.add(x, y);
        if self.ty(scalar_t) != Type::Float {
            return lerp;
        }
        let zero = self.float(0.0);
        let one = self.float(1.0);
        let at0 = self.binary(BinOp::Eq, scalar_t, zero);
        let at1 = self.binary(BinOp::Eq, scalar_t, one);
        let end1 = self.select(at1, b, lerp);
        self.select(at0, a, end1)
    }

    /// A uniform parameter `name` (class compilation) with value `value`: declared in the
    /// program's parameter table and read with `param`.
    pub fn param(&mut self, name: &str, value: ConstValue) -> Value {
        let ty = value.ty();
        self.program.params.push(super::ParamDecl {
            name: name.to_string(),
            ty,
            default: value,
        });
        let i = (self.program.params.len() - 1) as u32;
        self.push(Op::Param(i), Some(ty))
    }

    /// `cond ? a : b`, both evaluated.
    pub fn select(&mut self, cond: Value, a: Value, b: Value) -> Value {
        let (ct, at, bt) = (self.ty(cond), self.ty(a), self.ty(b));
        if ct != Type::Bool || at != bt {
            self.fail(format!("select({ct}, {at}, {bt}) is ill-typed"));
        }
        self.push(Op::Select { cond, a, b }, Some(at))
    }

    /// Builds a vector of type `ty` from floats, or a matrix from its elements (row-major).
    pub fn construct(&mut self, ty: Type, args: &[Value]) -> Value {
        let ok = (ty.is_vector() || ty.is_matrix())
            && args.len() == ty.width()
            && args.iter().all(|a| self.ty(*a) == Type::Float);
        if !ok {
            self.fail(format!("cannot construct {ty} from {} values", args.len()));
        }
        self.push(Op::Construct(args.to_vec()), Some(ty))
    }

    /// Component `i` of a vector; element `i` (row-major) of a matrix.
    pub fn extract(&mut self, v: Value, i: usize) -> Value {
        let t = self.ty(v);
        if !(t.is_vector() || t.is_matrix()) || i >= t.width() {
            self.fail(format!("no component {i} in {t}"));
        }
        self.push(Op::Extract(v, i as u8), Some(Type::Float))
    }

    /// A float broadcast to the vector type `ty`.
    pub fn splat(&mut self, ty: Type, f: Value) -> Value {
        if self.ty(f) != Type::Float || !ty.is_vector() {
            self.fail(format!("cannot splat {} to {ty}", self.ty(f)));
        }
        self.push(Op::Splat(f), Some(ty))
    }

    /// `v` unchanged if it has type `ty`, splatted if it is a float and `ty` a vector.
    pub fn splat_to(&mut self, ty: Type, v: Value) -> Value {
        if self.ty(v) == Type::Float && ty.is_vector() {
            self.splat(ty, v)
        } else {
            v
        }
    }

    /// A scalar conversion (bool/int/float); the identity if `v` already has type `ty`.
    pub fn convert(&mut self, ty: Type, v: Value) -> Value {
        let from = self.ty(v);
        if from == ty {
            return v;
        }
        if !ops::convert_ok(from, ty) {
            self.fail(format!("cannot convert {from} to {ty}"));
        }
        self.push(Op::Convert(v), Some(ty))
    }

    /// Reinterprets a vec3 as a color or back, or a vec4 as a color4 or back (same
    /// components, rebuilt with extracts and a construct). Returns a value of type `ty`.
    pub fn retype(&mut self, ty: Type, v: Value) -> Value {
        let from = self.ty(v);
        if from == ty {
            return v;
        }
        if !from.is_renaming_of(ty) {
            self.fail(format!("cannot retype {from} as {ty}"));
            return v;
        }
        let parts: Vec<Value> = (0..ty.width()).map(|i| self.extract(v, i)).collect();
        self.construct(ty, &parts)
    }

    /// A call of an intrinsic.
    pub fn call(&mut self, i: Intrinsic, args: &[Value]) -> Value {
        let tys: Vec<Type> = args.iter().map(|a| self.ty(*a)).collect();
        let ty = ops::intrinsic_type(i, &tys).unwrap_or_else(|| {
            self.fail(format!("{} does not take {tys:?}", i.name()));
            Type::Float
        });
        self.push(Op::Call(i, args.to_vec()), Some(ty))
    }

    /// Registers a texture file (once per distinct file and color space) and returns its
    /// index.
    pub fn texture_index(&mut self, file: &TextureFile) -> u32 {
        if let Some(i) = self.program.textures.iter().position(|t| t == file) {
            return i as u32;
        }
        self.program.textures.push(file.clone());
        (self.program.textures.len() - 1) as u32
    }

    /// A filtered lookup of texture `texture` at `uv` over the footprint of uv's
    /// screen-space derivatives ([`Builder::derivs`]): color, or alpha (float) if `alpha`.
    pub fn texture(&mut self, texture: u32, uv: Value, sampling: Sampling, alpha: bool) -> Value {
        let derivs = match sampling.filter {
            Filter::Closest | Filter::Bilinear => None,
            Filter::Trilinear | Filter::Anisotropic => self.derivs(uv),
        };
        self.texture_over(texture, uv, derivs, sampling, alpha)
    }

    /// [`Builder::texture`] over the footprint `derivs` (∂uv/∂x, ∂uv/∂y; `None`: a point
    /// lookup) given by the caller: uv's own derivatives widened or narrowed, as OSL's
    /// `"width"` and `"blur"` options ask.
    pub fn texture_over(
        &mut self,
        texture: u32,
        uv: Value,
        derivs: Option<[Value; 2]>,
        sampling: Sampling,
        alpha: bool,
    ) -> Value {
        if self.ty(uv) != Type::Vec2
            || derivs.is_some_and(|d| d.iter().any(|v| self.ty(*v) != Type::Vec2))
        {
            self.fail("texture coordinates and their derivatives must be vec2s");
            return self.zero(if alpha { Type::Float } else { Type::Color });
        }
        let ty = if alpha { Type::Float } else { Type::Color };
        self.push(
            Op::Texture {
                texture,
                uv,
                derivs,
                sampling,
                alpha,
            },
            Some(ty),
        )
    }

    /// Sum of the ambient lights (color).
    pub fn ambient(&mut self) -> Value {
        self.push(Op::Ambient, Some(Type::Color))
    }

    /// Inside an illuminance body: 1.0 where the current light sample is unblocked, else 0.0
    /// ([`Op::LightVisible`]).
    pub fn light_visible(&mut self) -> Value {
        self.push(Op::LightVisible, Some(Type::Float))
    }

    /// The radiance arriving at the shaded point along the vec3 `dir`, traced by the
    /// scene as a ray of type `ray_type` ([`Op::Trace`]); color.
    pub fn trace(&mut self, dir: Value, ray_type: i32) -> Value {
        if self.ty(dir) != Type::Vec3 {
            let t = self.ty(dir);
            self.fail(format!("trace direction must be a vec3, not a {t}"));
        }
        if !is_traceable_ray_type(ray_type) {
            self.fail(format!("trace cannot trace rays of type {ray_type}"));
        }
        self.push(
            Op::Trace {
                dir,
                ray_type,
                pdf: None,
            },
            Some(Type::Color),
        )
    }

    /// Like [`Builder::trace`], for a direction drawn by BSDF sampling with density `pdf`
    /// (float): the renderer weights light sources the ray hits against its light samples.
    pub fn trace_sampled(&mut self, dir: Value, ray_type: i32, pdf: Value) -> Value {
        let v = self.trace(dir, ray_type);
        if let Op::Trace { pdf: p, .. } = &mut self.program.exprs[v.index()].op {
            *p = Some(pdf);
        }
        v
    }

    /// Inside an illuminance body: the light loop's density of the current sample
    /// ([`Op::LightPdf`]).
    pub fn light_pdf(&mut self) -> Value {
        self.push(Op::LightPdf, Some(Type::Float))
    }

    /// Field `field` of the closest surface along a probe ray ([`Op::Probe`]): from
    /// `origin` towards `dir` (vec3s) between `min_distance` and `max_distance` (floats).
    pub fn probe(
        &mut self,
        field: ProbeField,
        origin: Value,
        dir: Value,
        min_distance: Value,
        max_distance: Value,
    ) -> Value {
        let tys = [origin, dir, min_distance, max_distance].map(|v| self.ty(v));
        if tys != [Type::Vec3, Type::Vec3, Type::Float, Type::Float] {
            self.fail(format!(
                "probe takes (vec3, vec3, float, float), not {tys:?}"
            ));
        }
        let op = Op::Probe {
            field,
            origin,
            dir,
            min_distance,
            max_distance,
        };
        self.push(op, Some(field.ty()))
    }

    /// A message the fragment writes ([`Op::Print`]): `format` with `args`. The format must
    /// fit the arguments (one numeric conversion per argument; the validator checks it).
    pub fn print(&mut self, severity: Severity, format: String, args: Vec<Value>) -> Value {
        let op = Op::Print {
            severity,
            format,
            args,
        };
        self.push(op, Some(Type::Int))
    }

    /// Ambient occlusion at the shaded point around `n` (vec3) with `samples` (int) rays
    /// reaching `max_distance` (float) ([`Op::Occlusion`]); float in [0, 1].
    pub fn occlusion(&mut self, n: Value, samples: Value, max_distance: Value) -> Value {
        let tys = (self.ty(n), self.ty(samples), self.ty(max_distance));
        if tys != (Type::Vec3, Type::Int, Type::Float) {
            self.fail(format!(
                "occlusion takes (vec3, int, float), not ({}, {}, {})",
                tys.0, tys.1, tys.2
            ));
        }
        let op = Op::Occlusion {
            n,
            samples,
            max_distance,
        };
        self.push(op, Some(Type::Float))
    }

    /// The geometry's attribute `name` at the shaded point, read as `default`'s type (float,
    /// vec2, vec3, color, vec4 or color4), or `default` where the geometry lacks it
    /// ([`Op::Attribute`]).
    pub fn attribute(&mut self, name: &str, default: Value) -> Value {
        let ty = self.ty(default);
        if !super::is_attribute_type(ty) {
            self.fail(format!(
                "attribute {name:?} cannot be read as a {ty}: attributes are floats, vectors and colors"
            ));
            return default;
        }
        let slot = self.program.attribute_slot(name, ty);
        self.push(Op::Attribute { slot, default }, Some(ty))
    }

    /// Whether the geometry has attribute `name` read as a `ty` (bool): true exactly where
    /// [`Builder::attribute`] of that name and type gives the geometry's value
    /// ([`Op::AttributeFound`]).
    pub fn attribute_found(&mut self, name: &str, ty: Type) -> Value {
        if !super::is_attribute_type(ty) {
            self.fail(format!(
                "attribute {name:?} cannot be read as a {ty}: attributes are floats, vectors and colors"
            ));
            return self.boolean(false);
        }
        let slot = self.program.attribute_slot(name, ty);
        self.push(Op::AttributeFound { slot }, Some(Type::Bool))
    }

    fn build_block(&mut self, f: impl FnOnce(&mut Builder) -> Vec<Value>) -> Block {
        self.blocks.push(Block::default());
        let yields = f(self);
        let mut block = self.blocks.pop().expect("pushed above");
        block.yields = yields;
        block
    }

    fn projections(&mut self, region: Value, tys: &[Type]) -> Vec<Value> {
        tys.iter()
            .enumerate()
            .map(|(i, t)| self.push(Op::Proj(region, i as u8), Some(*t)))
            .collect()
    }

    /// A structured conditional; `then_` and `else_` return their yields (same count and
    /// types). Returns the region's results.
    pub fn if_(
        &mut self,
        cond: Value,
        then_: impl FnOnce(&mut Builder) -> Vec<Value>,
        else_: impl FnOnce(&mut Builder) -> Vec<Value>,
    ) -> Vec<Value> {
        if self.ty(cond) != Type::Bool {
            self.fail("if condition is not a bool");
        }
        let t = self.build_block(then_);
        let e = self.build_block(else_);
        let tt: Vec<Type> = t.yields.iter().map(|v| self.ty(*v)).collect();
        let et: Vec<Type> = e.yields.iter().map(|v| self.ty(*v)).collect();
        if tt != et {
            self.fail(format!("if arms yield {tt:?} and {et:?}"));
        }
        let region = self.push(
            Op::If {
                cond,
                then_: t,
                else_: e,
            },
            None,
        );
        self.projections(region, &tt)
    }

    /// A light loop around point `p` (world space). `body` receives the builder, the light
    /// direction `L` and the arriving color `Cl`, and returns per-sample values (floats or
    /// vectors) to be summed. Returns the sums.
    pub fn illuminance(
        &mut self,
        p: Value,
        body: impl FnOnce(&mut Builder, Value, Value) -> Vec<Value>,
    ) -> Vec<Value> {
        let block = self.build_block(|b| {
            let l = b.push(Op::LightL, Some(Type::Vec3));
            let cl = b.push(Op::LightCl, Some(Type::Color));
            body(b, l, cl)
        });
        let tys: Vec<Type> = block.yields.iter().map(|v| self.ty(*v)).collect();
        if tys.iter().any(|t| !t.is_float_based()) {
            self.fail(format!(
                "illuminance can only sum floats and vectors, not {tys:?}"
            ));
        }
        let region = self.push(Op::Illuminance { p, body: block }, None);
        self.projections(region, &tys)
    }

    /// A loop carrying `init` (see [`Op::Loop`]): `cond` and `body` receive the builder and
    /// the carried values' current values (`loop.var`s); `cond` returns the bool that runs
    /// the body again, `body` the next values (as many, of the same types). Returns the
    /// values the loop ends with.
    pub fn loop_(
        &mut self,
        init: &[Value],
        cond: impl FnOnce(&mut Builder, &[Value]) -> Value,
        body: impl FnOnce(&mut Builder, &[Value]) -> Vec<Value>,
    ) -> Vec<Value> {
        let tys: Vec<Type> = init.iter().map(|v| self.ty(*v)).collect();
        if tys.len() > u8::MAX as usize + 1 {
            self.fail(format!("a loop carries {} values; at most 256", tys.len()));
            return Vec::new();
        }
        let vars = |b: &mut Builder| -> Vec<Value> {
            let ks = tys.iter().enumerate();
            ks.map(|(k, t)| b.push(Op::LoopVar(k as u8), Some(*t)))
                .collect()
        };
        let c = self.build_block(|b| {
            let vs = vars(b);
            vec![cond(b, &vs)]
        });
        let body = self.build_block(|b| {
            let vs = vars(b);
            body(b, &vs)
        });
        let ct: Vec<Type> = c.yields.iter().map(|v| self.ty(*v)).collect();
        let bt: Vec<Type> = body.yields.iter().map(|v| self.ty(*v)).collect();
        if ct != [Type::Bool] || bt != tys {
            self.fail(format!(
                "a loop carrying {tys:?} has a condition of {ct:?} and a body yielding {bt:?}"
            ));
        }
        let init = init.to_vec();
        let region = self.push(
            Op::Loop {
                init,
                cond: c,
                body,
            },
            None,
        );
        self.projections(region, &tys)
    }

    /// Declares a material output (or one component part of it).
    pub fn output(&mut self, name: &str, component: Option<u8>, value: Value) {
        self.program.outputs.push(Output {
            name: name.to_string(),
            component,
            value,
        });
    }

    /// Ends building; fails with the first internal typing error.
    pub fn finish(mut self) -> Result<Program, String> {
        if let Some(e) = self.error {
            return Err(e);
        }
        self.program.body = self.blocks.pop().expect("top block");
        Ok(self.program)
    }
}
