//! The checker and the lowering of a shader to the IR, in one pass over the AST: every
//! expression is typed and lowered through `shadenet_graph::ir::Builder`, mutable locals
//! become SSA values (an `if` yields what its branches assign), RSL's `illuminance` becomes
//! the IR's light-loop region, instance parameters become the program's parameters. Errors
//! are collected as [`Diagnostic`]s on the source spans (both types of a mismatch, the
//! closest name of an unknown one, the candidate signatures of a call).
//!
//! What is built: RSL `surface` and `light` shaders ([`light`]) with `float`, `point`/`vector`/`normal`, `color` and
//! `string` values; declarations, assignments (all compound forms), `if`/`else`, blocks,
//! loops, `illuminance`; the operators (`.` dot, `^` cross); constructors in `"rgb"`,
//! `"current"` and `"world"`; user functions (inlined); the builtins of `builtins`. OSL
//! `surface` and `shader` shaders add `int`, closures (`closure`: lobe lists), output
//! parameters and OSL's builtins and noise (`osl`); both have fixed-size arrays (`arrays`)
//! and OSL shader groups lower through `group`; both have `matrix` values (`matrix`).
//! What is not yet — other spaces, volume/displacement shaders, OSL light shaders — is an error that says so,
//! naming the construct. It owns the rules of the language;
//! it must not hold op semantics (the IR's) nor touch the renderer.

mod arrays;
mod attributes;
mod builtins;
mod closure;
mod colorspace;
mod components;
mod derivs;
mod displace;
mod expr;
mod geometry;
mod group;
pub mod light;
pub use displace::compile_displaced;
mod loops;
mod matrix;
mod messages;
mod noise;
mod osl;
mod oslmath;
mod print;
mod probe;
mod returns;
mod spectral;
mod spline;
mod stdosl;
mod stmt;
mod strings;
mod structs;
mod texinfo;
mod texture_opts;
mod unroll;
mod walk;

use crate::ast::{self, Item, ShaderKind};
use crate::diag::{Diagnostic, Diagnostics};
use crate::source::Span;
use crate::{Dialect, Parsed};
use shadenet_graph::closure::Closure;
use shadenet_graph::ir::{BinOp, Builder, Program, Stream, Value};
use shadenet_graph::{ConstValue, Type};
use std::collections::{BTreeMap, HashMap};

pub use group::compile_group;

/// The most errors collected before lowering stops.
const MAX_ERRORS: usize = 20;

/// How deep inlined user-function calls may nest (recursion is refused before this).
const MAX_INLINE_DEPTH: usize = 64;

/// The language's value types (RSL's; `Bool` is the type of conditions).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Ty {
    /// `float`.
    Float,
    /// `point`.
    Point,
    /// `vector`.
    Vector,
    /// `normal`.
    Normal,
    /// `color`.
    Color,
    /// OSL's `int` (32-bit, wrapping; RSL has none).
    Int,
    /// A condition (comparisons, `&&`, `!`).
    Bool,
    /// A 4×4 `matrix` of row vectors, held as its transpose ([`matrix`]).
    Matrix,
}

impl Ty {
    /// The IR type that holds it.
    pub(crate) fn ir(self) -> Type {
        match self {
            Ty::Float => Type::Float,
            Ty::Point | Ty::Vector | Ty::Normal => Type::Vec3,
            Ty::Color => Type::Color,
            Ty::Int => Type::Int,
            Ty::Bool => Type::Bool,
            Ty::Matrix => Type::Matrix44,
        }
    }

    /// Its name in messages.
    pub(crate) fn name(self) -> &'static str {
        match self {
            Ty::Float => "float",
            Ty::Point => "point",
            Ty::Vector => "vector",
            Ty::Normal => "normal",
            Ty::Color => "color",
            Ty::Int => "int",
            Ty::Bool => "bool (a condition)",
            Ty::Matrix => "matrix",
        }
    }

    /// Whether it is one of the three-component geometric types.
    pub(crate) fn is_geometric(self) -> bool {
        matches!(self, Ty::Point | Ty::Vector | Ty::Normal)
    }

    /// Whether it has three components (geometric or color).
    pub(crate) fn is_triple(self) -> bool {
        self.is_geometric() || self == Ty::Color
    }
}

/// A typed value: an IR value, or a string known at compile time (strings are never
/// varying: space names, texture names).
#[derive(Clone, Debug)]
pub(crate) enum Val {
    /// An IR value of a language type; `varying` when it may differ between fragments.
    V {
        /// The IR value.
        v: Value,
        /// Its type.
        ty: Ty,
        /// Whether it may vary per fragment.
        varying: bool,
    },
    /// A string constant.
    Str(String),
    /// An OSL `closure color`: a lobe list built while lowering (never an IR value).
    Closure(Box<Closure>),
    /// An array's elements (of the element type), as an expression's value.
    Array(Vec<Val>),
    /// In a scope: an array variable of `len` elements, held in hidden element variables
    /// ([`element`]).
    ArrayVar {
        /// Its length.
        len: usize,
        /// The element type; `None` for an array of structs (each element a struct
        /// variable).
        ty: Option<Ty>,
    },
    /// An OSL struct's fields by name, of the struct type named, as an expression's value.
    Struct(String, Vec<(String, Val)>),
    /// In a scope: a struct variable of the type named, held in hidden field variables
    /// ([`structs::field`]).
    StructVar(String),
}

impl Val {
    /// Its type's name in messages.
    pub(crate) fn type_name(&self) -> &'static str {
        match self {
            Val::V { ty, .. } => ty.name(),
            Val::Str(_) => "string",
            Val::Closure(_) => "closure color",
            Val::Array(..) | Val::ArrayVar { .. } => "array",
            Val::Struct(..) | Val::StructVar(_) => "struct",
        }
    }
}

/// The IR values of call arguments that are all values (`None` if one is a string or a
/// closure), ints as floats: the math builtins take floats, and OSL promotes ints.
pub(crate) fn numbers(b: &mut Builder, args: &[(Val, Span)]) -> Option<Vec<(Value, Ty, bool)>> {
    args.iter()
        .map(|(v, _)| match v {
            Val::V {
                v,
                ty: Ty::Int,
                varying,
            } => Some((b.convert(Type::Float, *v), Ty::Float, *varying)),
            Val::V { v, ty, varying } => Some((*v, *ty, *varying)),
            _ => None,
        })
        .collect()
}

/// Two operands brought to one type: equal, a float widened, geometric types mixed.
pub(crate) fn same(
    b: &mut Builder,
    (x, tx): (Value, Ty),
    (y, ty): (Value, Ty),
) -> Option<(Value, Value, Ty)> {
    match (tx, ty) {
        _ if tx == Ty::Bool || ty == Ty::Bool => None,
        _ if (tx == Ty::Matrix || ty == Ty::Matrix) && tx != ty => None,
        _ if tx == ty => Some((x, y, tx)),
        (Ty::Float, t) => Some((b.splat(t.ir(), x), y, t)),
        (t, Ty::Float) => Some((x, b.splat(t.ir(), y), t)),
        (a, c) if a.is_geometric() && c.is_geometric() => Some((x, y, a)),
        _ => None,
    }
}

/// Whether the scalar `v` of type `t` (int or float; a bool is itself) is not 0: OSL's
/// truth of a number.
pub(crate) fn nonzero(b: &mut Builder, v: Value, t: Ty) -> Value {
    let zero = match t {
        Ty::Bool => return v,
        Ty::Int => b.int(0),
        _ => b.float(0.0),
    };
    b.binary(BinOp::Ne, v, zero)
}

/// `name` with its indefinite article ("a float", "an int").
pub(crate) fn an(name: &str) -> String {
    match name.chars().next() {
        Some('a' | 'e' | 'i' | 'o' | 'u') => format!("an {name}"),
        _ => format!("a {name}"),
    }
}

/// The binary operator of a compound assignment (`a op= b` is `a = a op b`); `None` for `=`.
pub(crate) fn compound_of(op: ast::AssignOp) -> Option<ast::BinaryOp> {
    use ast::{AssignOp as A, BinaryOp as B};
    Some(match op {
        A::Set => return None,
        A::Add => B::Add,
        A::Sub => B::Sub,
        A::Mul => B::Mul,
        A::Div => B::Div,
        A::Rem => B::Rem,
        A::BitAnd => B::BitAnd,
        A::BitOr => B::BitOr,
        A::BitXor => B::BitXor,
        A::Shl => B::Shl,
        A::Shr => B::Shr,
    })
}

/// What a group gives a layer's parameter.
#[derive(Clone, Debug)]
pub(crate) enum LayerInput {
    /// A `param` statement's values.
    Values(Vec<crate::group::ParamValue>, Span),
    /// The output of an earlier layer.
    Connected(Val, Span),
}

/// The hidden variable holding element `k` of array `name` ([`arrays`]).
pub(crate) fn element(name: &str, k: usize) -> String {
    format!("{name}[{k}]")
}

/// Whether `v` depends on a program parameter (through the operands of its ops).
pub(crate) fn reads_param(p: &Program, v: Value) -> bool {
    let mut seen = std::collections::HashSet::new();
    let mut todo = vec![v];
    while let Some(v) = todo.pop() {
        if !seen.insert(v.index()) {
            continue;
        }
        let Some(e) = p.exprs.get(v.index()) else {
            continue;
        };
        if matches!(e.op, shadenet_graph::ir::Op::Param(_)) {
            return true;
        }
        e.op.for_each_operand(|a| todo.push(a));
    }
    false
}

/// A variable: its current value and whether it was declared `uniform`.
#[derive(Clone, Debug)]
pub(crate) struct Var {
    pub(crate) val: Val,
    pub(crate) uniform: bool,
    /// Where it was declared (`None`: a global).
    pub(crate) decl: Option<Span>,
}

/// The lowering state: scopes of variables, the user functions, the diagnostics.
pub(crate) struct Lower<'a> {
    pub(crate) scopes: Vec<HashMap<String, Var>>,
    pub(crate) functions: HashMap<&'a str, Vec<&'a ast::FunctionDef>>,
    /// The user functions being inlined, innermost last (recursion check): name, call,
    /// definition (overloads share a name).
    pub(crate) inlining: Vec<(&'a str, Span, Span)>,
    pub(crate) diags: Diagnostics,
    /// Inside an `illuminance` body: `L` and `Cl` are bound.
    pub(crate) in_illuminance: bool,
    /// The hidden flags of the loops enclosing the current point, innermost last (emptied
    /// inside light-loop bodies and inlined functions, which no jump may leave).
    pub(crate) loops: Vec<loops::LoopFlags>,
    /// The dialect being lowered (OSL's types, globals and builtins differ from RSL's).
    pub(crate) dialect: Dialect,
    /// The type the expression being lowered is assigned to, where a call's result type
    /// depends on it (OSL's noise: a float or a vector); taken by the call.
    pub(crate) want: Option<Ty>,
    /// Prefixed to the program parameters' names (`layer.` in a shader group).
    pub(crate) prefix: String,
    /// A shader group layer's instance values and connections, by parameter name.
    pub(crate) inputs: HashMap<String, LayerInput>,
    /// The file's OSL struct types by name.
    pub(crate) structs: HashMap<&'a str, &'a ast::StructDef>,
    /// The struct type the expression being lowered is assigned to, where a call's
    /// overload depends on it (OSL's overloading by return type); taken by the call.
    pub(crate) want_struct: Option<String>,
    /// Inside an inlined function that returns before its end ([`returns`]).
    pub(crate) returns: Option<returns::Returns<'a>>,
    /// The shader's parameters by name, with OSL's `isconnected` bits: 1 connected to an
    /// earlier layer of a group, 2 (an output) connected to a later one.
    pub(crate) shader_params: HashMap<String, i32>,
    /// The group's connection bits of this layer's parameters, by name (set by the group
    /// before the layer is lowered).
    pub(crate) connections: HashMap<String, i32>,
    /// The conditions of the flattened `if` arms around the current point (the condition
    /// and whether the arm is where it holds), outermost first: a print there runs under
    /// them ([`print`]).
    pub(crate) print_guard: Vec<(Value, bool)>,
    /// What the file's user functions do beyond their own variables, found once per file
    /// ([`FileFacts`]).
    pub(crate) facts: &'a FileFacts,
    /// What answers `gettextureinfo` ([`crate::Options::texture_info`]), if anything.
    pub(crate) texture_info: Option<&'a crate::TextureInfoSource>,
    /// The messages' types, known before lowering (from a first lowering that found them:
    /// [`messages`]); each has its hidden variables from the start.
    pub(crate) message_types: BTreeMap<String, Ty>,
    /// The messages `setmessage` sets, with the type and place of the first.
    pub(crate) messages_found: BTreeMap<String, (Ty, Span)>,
}

/// Facts about a parsed file's user functions, a fixpoint over the call graph found once
/// per file (kept in [`Parsed`]: a module of many shaders, as MaterialX's, lowers each
/// with the same functions) so that asking them of a statement never walks the call graph.
#[derive(Debug, Default)]
pub(crate) struct FileFacts {
    /// The names each function may assign beyond its own variables (the globals it writes,
    /// the hidden variables of the `trace` and `setmessage` it calls, directly or through
    /// its calls): a call of it assigns them too ([`Lower::function_writes`]).
    pub(crate) globals_written: HashMap<String, Vec<String>>,
}

impl FileFacts {
    /// The facts of `parsed` (see [`FileFacts`]).
    fn of(parsed: &Parsed) -> FileFacts {
        let mut facts = FileFacts::default();
        // What each function's own statements assign, once; then each pass adds what the
        // functions it calls assign (at most one pass per level of calls).
        let (mut writes, calls) = Lower::with_facts(parsed, &facts).function_writes();
        for _ in 0..=calls.len() {
            let mut grew = false;
            for (f, callees) in &calls {
                let mut add: Vec<String> = callees
                    .iter()
                    .filter_map(|g| writes.get(g))
                    .flatten()
                    .filter(|n| !writes[f].contains(*n))
                    .cloned()
                    .collect();
                if add.is_empty() {
                    continue;
                }
                add.sort();
                add.dedup();
                grew = true;
                writes
                    .get_mut(f)
                    .expect("every function has writes")
                    .extend(add);
            }
            if !grew {
                break;
            }
        }
        facts.globals_written = writes;
        facts
    }
}

/// The user functions of a file by name (overloads in order).
fn function_map(parsed: &Parsed) -> HashMap<&str, Vec<&ast::FunctionDef>> {
    let mut functions: HashMap<&str, Vec<&ast::FunctionDef>> = HashMap::new();
    for item in &parsed.file.items {
        if let Item::Function(f) = item {
            functions.entry(f.name.name.as_str()).or_default().push(f);
        }
    }
    functions
}

/// Compiles shader `name` (the file's only or first shader when `None`) of a parsed file to
/// an IR program named after it: its parameters the program's, `Ci` and `Oi` its outputs
/// (a light shader's: [`light`]).
/// Runs on the front end's own thread ([`crate::STACK_BYTES`]): the lowering recurses over
/// the tree as the parser does.
pub fn compile(parsed: &Parsed, name: Option<&str>) -> Result<Program, Diagnostics> {
    crate::on_big_stack(|| compile_here(parsed, name))
}

fn compile_here(parsed: &Parsed, name: Option<&str>) -> Result<Program, Diagnostics> {
    let shaders: Vec<&ast::ShaderDef> = parsed
        .file
        .items
        .iter()
        .filter_map(|i| match i {
            Item::Shader(s) => Some(s),
            _ => None,
        })
        .collect();
    let shader = match name {
        Some(n) => shaders.iter().find(|s| s.name.name == n).copied(),
        None => shaders.first().copied(),
    };
    let Some(shader) = shader else {
        let known: Vec<&str> = shaders.iter().map(|s| s.name.name.as_str()).collect();
        return Err(Diagnostic::error_nowhere(match name {
            Some(n) => format!(
                "no shader `{n}` in the file (its shaders: {})",
                known.join(", ")
            ),
            None => "the file defines no shader".to_string(),
        })
        .into());
    };
    let built = match parsed.dialect {
        Dialect::Rsl => matches!(
            shader.kind,
            ShaderKind::Surface | ShaderKind::Light | ShaderKind::Displacement
        ),
        Dialect::Osl => matches!(
            shader.kind,
            ShaderKind::Surface | ShaderKind::Shader | ShaderKind::Displacement
        ),
    };
    if !built {
        return Err(Diagnostic::error(
            format!(
                "{} shaders are not compiled yet: built are RSL `surface`, `light` and `displacement` shaders and OSL `surface`, `shader` and `displacement` shaders (issues 21, 22)",
                kind_name(shader.kind)
            ),
            shader.kind_span,
            "not built yet",
        )
        .into());
    }
    // A shader that sets messages is lowered twice: the first finds their types.
    let types = if messages::calls_setmessage(parsed) {
        lower_shader(parsed, shader, BTreeMap::new())
            .0
            .found_message_types()
    } else {
        BTreeMap::new()
    };
    let (lower, b) = lower_shader(parsed, shader, types);
    if lower.diags.has_errors() {
        return Err(lower.diags);
    }
    finish(b, shader)
}

/// The program `b` built for `shader`; an invalid one is an internal error at the shader.
fn finish(b: Builder, shader: &ast::ShaderDef) -> Result<Program, Diagnostics> {
    b.finish().map_err(|e| {
        Diagnostic::error(
            format!("internal error: the lowered program is invalid: {e}"),
            shader.span,
            "while lowering this shader",
        )
        .into()
    })
}

/// One lowering of `shader` with the messages of `message_types` declared.
fn lower_shader<'a>(
    parsed: &'a Parsed,
    shader: &'a ast::ShaderDef,
    message_types: BTreeMap<String, Ty>,
) -> (Lower<'a>, Builder) {
    let mut lower = Lower::new(parsed);
    lower.message_types = message_types;
    let mut b = Builder::new(&shader.name.name);
    match (parsed.dialect, shader.kind) {
        (_, ShaderKind::Displacement) => {
            let (p, n) = lower.displacement(&mut b, shader);
            b.output("P", None, p);
            b.output("N", None, n);
        }
        (Dialect::Osl, _) => lower.osl_shader(&mut b, shader),
        (Dialect::Rsl, ShaderKind::Light) => lower.light(&mut b, shader),
        (Dialect::Rsl, _) => lower.surface(&mut b, shader),
    }
    (lower, b)
}

/// The name of a shader kind in messages.
pub fn kind_name(k: ShaderKind) -> &'static str {
    match k {
        ShaderKind::Surface => "surface",
        ShaderKind::Light => "light",
        ShaderKind::Volume => "volume",
        ShaderKind::Displacement => "displacement",
        ShaderKind::Imager => "imager",
        ShaderKind::Shader => "generic (OSL `shader`)",
    }
}

impl<'a> Lower<'a> {
    /// A lowering of a shader of `parsed`: its user functions known, nothing else bound.
    pub(crate) fn new(parsed: &'a Parsed) -> Lower<'a> {
        let facts = parsed.facts.get_or_init(|| FileFacts::of(parsed));
        Lower::with_facts(parsed, facts)
    }

    /// [`Lower::new`] with the file's facts given.
    fn with_facts(parsed: &'a Parsed, facts: &'a FileFacts) -> Lower<'a> {
        let mut structs = HashMap::new();
        for item in &parsed.file.items {
            if let Item::Struct(d) = item {
                structs.insert(d.name.name.as_str(), d);
            }
        }
        Lower {
            scopes: vec![HashMap::new()],
            functions: function_map(parsed),
            inlining: Vec::new(),
            diags: Diagnostics::new(),
            in_illuminance: false,
            loops: Vec::new(),
            dialect: parsed.dialect,
            want: None,
            prefix: String::new(),
            inputs: HashMap::new(),
            structs,
            want_struct: None,
            returns: None,
            shader_params: HashMap::new(),
            connections: HashMap::new(),
            print_guard: Vec::new(),
            facts,
            texture_info: parsed.texture_info.as_ref(),
            message_types: BTreeMap::new(),
            messages_found: BTreeMap::new(),
        }
    }

    /// A surface shader: the globals, the parameters, the body, the outputs (`Ci`, `Oi`, then
    /// the `output` parameters).
    fn surface(&mut self, b: &mut Builder, shader: &'a ast::ShaderDef) {
        self.surface_body(b, shader);
        for out in ["Ci", "Oi"] {
            let v = match self.lookup(out).map(|v| v.val.clone()) {
                Some(Val::V { v, .. }) => v,
                _ => b.zero(Type::Color),
            };
            b.output(out, None, v);
        }
        for p in shader.params.iter().filter(|p| p.ty.output.is_some()) {
            if let Some(Var {
                val: Val::V { v, .. },
                ..
            }) = self.lookup(&p.name.name)
            {
                b.output(&p.name.name, None, *v);
            }
        }
    }

    /// An RSL surface or displacement shader's globals, parameters and body.
    fn surface_body(&mut self, b: &mut Builder, shader: &'a ast::ShaderDef) {
        self.globals(b);
        for p in &shader.params {
            match &p.ty.output {
                Some(_) => self.rsl_output_param(b, p),
                None => self.param(b, p),
            }
        }
        self.scopes.push(HashMap::new());
        self.block(b, &shader.body);
        self.scopes.pop();
    }

    /// An RSL `output` parameter of a surface (an arbitrary output variable, RenderMan's
    /// AOV): a varying variable holding its default, read back as a program output after
    /// `Ci` and `Oi` ([`Lower::surface`]).
    fn rsl_output_param(&mut self, b: &mut Builder, p: &'a ast::Param) {
        if p.array.is_some() || p.ty.base == ast::BaseType::String {
            self.error(
                "output parameters that are arrays or strings are not built (floats, triples and matrices are)",
                p.span,
                "`output`",
            );
            return;
        }
        let Some(ty) = self.declared_type(&p.ty) else {
            return;
        };
        let v = match &p.default {
            Some(d) => self.expr_as(b, d, ty),
            None => Val::V {
                v: b.zero(ty.ir()),
                ty,
                varying: false,
            },
        };
        self.declare(&p.name, v, false);
    }

    /// RSL's surface globals: the streams, `E`, `s`/`t`, `Cs`/`Os` (white: the scene gives
    /// no per-object color yet) and `Ci`/`Oi` (black and opaque until assigned).
    fn globals(&mut self, b: &mut Builder) {
        let set = |me: &mut Self, name: &str, v: Value, ty: Ty, varying: bool| {
            me.scopes[0].insert(
                name.to_string(),
                Var {
                    val: Val::V { v, ty, varying },
                    uniform: false,
                    decl: None,
                },
            );
        };
        let p = b.stream(Stream::P);
        set(self, "P", p, Ty::Point, true);
        let n = b.stream(Stream::N);
        set(self, "N", n, Ty::Normal, true);
        let ng = b.stream(Stream::Ng);
        set(self, "Ng", ng, Ty::Normal, true);
        let i = b.stream(Stream::I);
        set(self, "I", i, Ty::Vector, true);
        let e = b.sub(p, i);
        set(self, "E", e, Ty::Point, true);
        let uv = b.stream(Stream::Uv);
        for (k, names) in [["u", "s"], ["v", "t"]].into_iter().enumerate() {
            let c = b.extract(uv, k);
            for name in names {
                set(self, name, c, Ty::Float, true);
            }
        }
        let dpdu = b.stream(Stream::DPdu);
        set(self, "dPdu", dpdu, Ty::Vector, true);
        let dpdv = b.stream(Stream::DPdv);
        set(self, "dPdv", dpdv, Ty::Vector, true);
        let white = b.color([1.0; 3]);
        set(self, "Cs", white, Ty::Color, false);
        set(self, "Os", white, Ty::Color, false);
        let pi = b.float(std::f64::consts::PI);
        set(self, "PI", pi, Ty::Float, false);
        let black = b.color([0.0; 3]);
        set(self, "Ci", black, Ty::Color, false);
        set(self, "Oi", white, Ty::Color, false);
    }

    /// An instance parameter: a program parameter when its default is a constant, else
    /// (a default computed from earlier parameters) that expression, evaluated once per
    /// instance as uniform code.
    fn param(&mut self, b: &mut Builder, p: &'a ast::Param) {
        if let Some(a) = &p.array {
            self.array_param(b, p, a);
            return;
        }
        if p.ty.base == ast::BaseType::String && p.ty.output.is_none() {
            if let Some(input) = self.inputs.remove(&p.name.name) {
                self.layer_input(b, p, input);
                return;
            }
            // A string parameter is a compile-time constant (a texture name).
            match p.default.as_ref().map(|d| &d.kind) {
                Some(ast::ExprKind::Str(text)) => {
                    self.declare(&p.name, Val::Str(text.clone()), true)
                }
                _ => self.error(
                    format!(
                        "string parameter `{}` needs a string literal default",
                        p.name.name
                    ),
                    p.span,
                    "here",
                ),
            }
            return;
        }
        if self.dialect == Dialect::Osl && (p.ty.output.is_some() || p.ty.closure.is_some()) {
            self.osl_output_param(b, p);
            return;
        }
        if let Some(input) = self.inputs.remove(&p.name.name) {
            self.layer_input(b, p, input);
            return;
        }
        if let ast::BaseType::Struct(n) = &p.ty.base
            && let Some(def) = self.struct_def(&n.name)
        {
            // A struct parameter holds its default (its fields are not program parameters).
            let v = match &p.default {
                Some(d) => self.expr_for_struct(b, d, def),
                None => self.struct_zero(b, def, 0),
            };
            if !matches!(&v, Val::Struct(s, _) if *s == def.name.name) {
                self.error(
                    format!(
                        "parameter `{}` is a `{}`: its default is not one",
                        p.name.name, n.name
                    ),
                    p.span,
                    "wrong default",
                );
                return;
            }
            self.bind_struct(&p.name, def, v, false);
            return;
        }
        let Some(ty) = self.declared_type(&p.ty) else {
            return;
        };
        if p.ty.output.is_some() {
            self.error(
                "output parameters of light shaders are not built yet (a light shader's result is `Cl`)",
                p.span,
                "`output`",
            );
            return;
        }
        let uniform = !matches!(p.ty.rate, Some((ast::Rate::Varying, _)));
        let Some(default) = &p.default else {
            self.error(
                format!("parameter `{}` needs a default value", p.name.name),
                p.name.span,
                "no default",
            );
            return;
        };
        let val = match const_eval(default, ty) {
            Some(c) => Val::V {
                v: b.param(&format!("{}{}", self.prefix, p.name.name), c),
                ty,
                varying: false,
            },
            None => self.expr_as(b, default, ty),
        };
        // OSL's parameters may be bound to anything varying (a default reading `P` is
        // common); RSL's are uniform unless declared `varying`.
        if let Val::V { varying: true, .. } = val
            && uniform
            && self.dialect == Dialect::Rsl
        {
            self.error(
                format!(
                    "uniform parameter `{}` gets a varying default (it reads a varying global)",
                    p.name.name
                ),
                p.span,
                "varying value",
            );
        }
        self.declare(&p.name, val, uniform);
    }

    /// The language type of a declared type, or an error for what is not built.
    pub(crate) fn declared_type(&mut self, t: &ast::Type) -> Option<Ty> {
        if let Some(s) = t.closure {
            let what = match self.dialect {
                Dialect::Rsl => "closures are OSL's",
                Dialect::Osl => {
                    "a closure is not a value of this kind here (closures are built for `Ci`, closure locals, output parameters and function results)"
                }
            };
            self.error(what, s, "a closure");
            return None;
        }
        match &t.base {
            ast::BaseType::Float => Some(Ty::Float),
            ast::BaseType::Int if self.dialect == Dialect::Osl => Some(Ty::Int),
            ast::BaseType::Point => Some(Ty::Point),
            ast::BaseType::Vector => Some(Ty::Vector),
            ast::BaseType::Normal => Some(Ty::Normal),
            ast::BaseType::Color => Some(Ty::Color),
            ast::BaseType::Matrix => Some(Ty::Matrix),
            other => {
                let what = match other {
                    ast::BaseType::String => "string variables are not built yet",
                    ast::BaseType::Int => "RSL has no `int`: use float",
                    ast::BaseType::Void => "a variable cannot be void",
                    _ => "structs are OSL's (issue 22)",
                };
                self.error(what, t.base_span, "this type");
                None
            }
        }
    }

    /// Binds a new variable in the innermost scope.
    pub(crate) fn declare(&mut self, name: &ast::Ident, val: Val, uniform: bool) {
        let scope = self.scopes.last_mut().expect("a scope");
        scope.insert(
            name.name.clone(),
            Var {
                val,
                uniform,
                decl: Some(name.span),
            },
        );
    }

    /// The variable `name`, innermost scope first.
    pub(crate) fn lookup(&self, name: &str) -> Option<&Var> {
        self.scopes.iter().rev().find_map(|s| s.get(name))
    }

    /// Every visible name, for "did you mean".
    pub(crate) fn visible_names(&self) -> Vec<String> {
        let mut v: Vec<String> = self.scopes.iter().flat_map(|s| s.keys().cloned()).collect();
        v.extend(self.functions.keys().map(|k| k.to_string()));
        v.extend(builtins::NAMES.iter().map(|s| s.to_string()));
        v.extend(matrix::NAMES.iter().map(|s| s.to_string()));
        if self.dialect == Dialect::Osl {
            v.extend(osl::NAMES.iter().map(|s| s.to_string()));
            v.extend(strings::NAMES.iter().map(|s| s.to_string()));
            v.extend(closure::names().map(str::to_string));
        }
        v.sort();
        v.dedup();
        v
    }

    /// Records an error (up to [`MAX_ERRORS`]).
    pub(crate) fn error(
        &mut self,
        message: impl Into<String>,
        span: Span,
        label: impl Into<String>,
    ) {
        if self.diags.len() < MAX_ERRORS {
            self.diags.push(Diagnostic::error(message, span, label));
        }
    }

    /// Whether lowering should stop (too many errors).
    pub(crate) fn stopped(&self) -> bool {
        self.diags.len() >= MAX_ERRORS
    }

    /// A placeholder value of `ty` after an error.
    pub(crate) fn poison(b: &mut Builder, ty: Ty) -> Val {
        Val::V {
            v: b.zero(ty.ir()),
            ty,
            varying: false,
        }
    }

    /// The value of a builtin that returns nothing (`printf`, `sincos`, `setmessage`,
    /// `fresnel`): a float 0.
    pub(crate) fn void(b: &mut Builder) -> Val {
        Self::poison(b, Ty::Float)
    }
}

/// A parameter default that is a constant of type `ty` (literals, signs, triples,
/// constructors of constants, arithmetic on them), as the program's parameter value.
pub(crate) fn const_eval(e: &ast::Expr, ty: Ty) -> Option<ConstValue> {
    constant_of(ty, &eval(e)?)
}

/// The constant of type `ty` that numbers `v` give: one for a float or int (an integer for
/// an int), one (repeated) or three for a triple.
pub(crate) fn constant_of(ty: Ty, v: &[f64]) -> Option<ConstValue> {
    match (ty, v) {
        (Ty::Float, [x]) => Some(ConstValue::Float(*x)),
        (Ty::Int, [x]) if x.fract() == 0.0 && x.abs() <= i32::MAX as f64 => {
            Some(ConstValue::Int(*x as i32))
        }
        (Ty::Color, [x]) => Some(ConstValue::Color([*x; 3])),
        (Ty::Color, [r, g, b]) => Some(ConstValue::Color([*r, *g, *b])),
        (t, [x]) if t.is_geometric() => Some(ConstValue::Vec3([*x; 3])),
        (t, [x, y, z]) if t.is_geometric() => Some(ConstValue::Vec3([*x, *y, *z])),
        _ => None,
    }
}

/// The components of a constant expression (one for a float, three for a triple).
pub(crate) fn eval(e: &ast::Expr) -> Option<Vec<f64>> {
    use ast::ExprKind as K;
    let finite = |v: Vec<f64>| v.iter().all(|x| x.is_finite()).then_some(v);
    match &e.kind {
        K::Float(x) => finite(vec![*x]),
        K::Int(i) => Some(vec![*i as f64]),
        K::Unary { op, operand } => {
            let v = eval(operand)?;
            match op {
                ast::UnaryOp::Neg => Some(v.iter().map(|x| -x).collect()),
                ast::UnaryOp::Plus => Some(v),
                _ => None,
            }
        }
        K::Tuple(items) if items.len() == 3 => {
            let mut out = Vec::new();
            for i in items {
                match eval(i)?.as_slice() {
                    [x] => out.push(*x),
                    _ => return None,
                }
            }
            Some(out)
        }
        K::Construct {
            space, args, ty, ..
        } if matches!(
            ty,
            ast::BaseType::Color
                | ast::BaseType::Point
                | ast::BaseType::Vector
                | ast::BaseType::Normal
                | ast::BaseType::Float
        ) && space
            .as_ref()
            .is_none_or(|(s, _)| matches!(s.as_str(), "rgb" | "current" | "world")) =>
        {
            let parts: Option<Vec<Vec<f64>>> = args.iter().map(eval).collect();
            let parts = parts?;
            match parts.as_slice() {
                [one] => Some(one.clone()),
                [a, b, c] if a.len() == 1 && b.len() == 1 && c.len() == 1 => {
                    Some(vec![a[0], b[0], c[0]])
                }
                _ => None,
            }
        }
        K::Binary { op, lhs, rhs } => {
            let (a, b) = (eval(lhs)?, eval(rhs)?);
            let n = a.len().max(b.len());
            if a.len() != b.len() && a.len() != 1 && b.len() != 1 {
                return None;
            }
            let at = |v: &Vec<f64>, i: usize| if v.len() == 1 { v[0] } else { v[i] };
            let f = |x: f64, y: f64| match op {
                ast::BinaryOp::Add => Some(x + y),
                ast::BinaryOp::Sub => Some(x - y),
                ast::BinaryOp::Mul => Some(x * y),
                ast::BinaryOp::Div => Some(x / y),
                _ => None,
            };
            finite(
                (0..n)
                    .map(|i| f(at(&a, i), at(&b, i)))
                    .collect::<Option<Vec<f64>>>()?,
            )
        }
        _ => None,
    }
}

/// The name among `names` closest to `name` (edit distance at most a third of its length).
pub(crate) fn closest<'n>(name: &str, names: &'n [String]) -> Option<&'n str> {
    names
        .iter()
        .map(|n| (shadenet_graph::edit_distance(name, n), n))
        .filter(|(k, _)| *k <= (name.len() / 3).max(1))
        .min()
        .map(|(_, n)| n.as_str())
}
