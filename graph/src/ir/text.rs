//! The IR text form: `Display for Program` (the printer) and [`parse`] (its inverse).
//!
//! The text is what tests, `shadenet compile --emit ir` and bug reports show. Printing is
//! canonical: print → parse → print gives the same text, and `parse(&p.to_string())` is the
//! same program as `p` up to the numbering of its values (values in the arena but in no
//! block are not printed, so they are dropped). Floats round-trip bit for bit, `-0.0`, NaN
//! payloads and denormals included.
//!
//! # Example
//!
//! ```
//! let src = r#"program "marble" {
//!   components diffuse specular
//!   param "surf.color" color = (0.5, 0.5, 0.5)
//!   %0 = const 2.5 : float
//!   %1 = param 0 : color
//!   %2 = stream P : vec3
//!   %3 = transform point world -> camera %2 : vec3
//!   %4 = mul %1, %1 : color
//!   %5 = component_enabled diffuse : bool
//!   %6 = if %5 {
//!     %7 = call noise3 %3 : float
//!     %8 = splat %7 : color
//!     %9 = mul %4, %8 : color
//!     yield %9
//!   } else {
//!     %10 = const (0.0, -0.0, 0.0) : color
//!     yield %10
//!   }
//!   %11 = proj %6, 0 : color
//!   %12 = stream N : vec3
//!   %13 = illuminance %2 {
//!     %14 = light.L : vec3
//!     %15 = light.Cl : color
//!     %16 = dot %12, %14 : float
//!     %17 = const 0.0 : float
//!     %18 = max %16, %17 : float
//!     %19 = splat %18 : color
//!     %20 = mul %15, %19 : color
//!     yield %20
//!   }
//!   %21 = proj %13, 0 : color
//!   %22 = ambient : color
//!   %23 = add %21, %22 : color
//!   %24 = mul %23, %11 : color
//!   %25 = extract %24, 1 : float
//!   %26 = construct %25, %25, %0 : vec3
//!   %27 = stream raydepth : int
//!   %28 = convert %27 : float
//!   %29 = lt %28, %0 : bool
//!   %30 = select %29, %24, %1 : color
//!   output color[diffuse] %30
//!   output color[specular] %22
//!   output "out alpha" %0
//! }
//! "#;
//! let program = shadenet_graph::ir::parse(src).unwrap();
//! shadenet_graph::ir::validate(&program).unwrap();
//! assert_eq!(program.to_string(), src);
//! ```
//!
//! # Syntax
//!
//! A program is `program "NAME" { … }` around the statements of its top-level block. The
//! printer writes, one per line and in this order:
//!
//! - `components A B …`: the render component names (`Program::components`), all on the
//!   `components` line (omitted when there are none);
//! - `param "NAME" TYPE = LITERAL`: one line per uniform parameter, in index order;
//! - `texture "FILE" [COLORSPACE]`: one line per texture-table entry, in index order (the
//!   color space, a [`ColorSpace`] name, is omitted when it is `auto`);
//! - `attribute "NAME" TYPE`: one line per attribute-table entry (`Program::attributes`),
//!   in index order;
//! - the values of the top-level block (below);
//! - `output NAME %v` or `output NAME[COMPONENT] %v`: the outputs, in order.
//!
//! A value is `%N = OP OPERANDS : TYPE`. The printer numbers values `%0, %1, …` in the order
//! they appear in the text (a region before the values of its blocks), whatever their arena
//! index; the parser accepts any label made of letters, digits and `_` after the `%`, and
//! gives the values arena indices in text order. `: TYPE` is written exactly when the expr
//! has a type (every op but the regions; a missing or extra type is left to
//! [`validate`](fn@super::validate) to report). The ops, with operands `%a`, `%b`, …:
//!
//! | text | op |
//! |---|---|
//! | `const LITERAL` | [`Op::Const`] |
//! | `param 0` | [`Op::Param`] (index into the `param` lines) |
//! | `stream P` | [`Op::Stream`] ([`Stream::name`]) |
//! | `transform point world -> camera %a` | [`Op::Transform`] ([`XformKind::name`], [`Space::name`]) |
//! | `component_enabled COMPONENT` | [`Op::ComponentEnabled`] |
//! | `neg %a`, `sqrt %a`, … | [`Op::Unary`] ([`UnOp::name`]) |
//! | `add %a, %b`, `mulpoint %m, %p`, … | [`Op::Binary`] ([`BinOp::name`]) |
//! | `select %c, %a, %b` | [`Op::Select`] |
//! | `construct %x, %y, %z` | [`Op::Construct`] (the type says which vector) |
//! | `extract %a, 1` | [`Op::Extract`] |
//! | `splat %a`, `convert %a` | [`Op::Splat`], [`Op::Convert`] (the type says to what) |
//! | `call noise3 %a, …` | [`Op::Call`] ([`Intrinsic::name`]) |
//! | `if %c { … } else { … }` | [`Op::If`] |
//! | `illuminance %p { … }` | [`Op::Illuminance`] |
//! | `loop %a, %b while { … } do { … }` | [`Op::Loop`] (the initial values, possibly none; the condition block, then the body) |
//! | `loop.var 0` | [`Op::LoopVar`] |
//! | `light.L`, `light.Cl`, `light.visible`, `light.pdf`, `ambient` | [`Op::LightL`], [`Op::LightCl`], [`Op::LightVisible`], [`Op::LightPdf`], [`Op::Ambient`] |
//! | `proj %r, 0` | [`Op::Proj`] |
//! | `texture #0 %uv`, `texture.alpha #0 trilinear clamp mirror %uv, %dudx, %dvdx` | [`Op::Texture`] (index into the texture table; then the filter if not `anisotropic`, the u and v wrap modes if not both `periodic`, uv and its optional derivatives ∂uv/∂x, ∂uv/∂y) |
//! | `attribute #0 %default` | [`Op::Attribute`] (index into the attribute table; the default where the geometry lacks it) |
//! | `attribute.found #0` | [`Op::AttributeFound`] (whether the geometry has table entry 0) |
//! | `trace reflection %d` or `trace reflection %d, %pdf` | [`Op::Trace`] (the ray type by name, [`super::ray_type_name`], or `#K` for any other code `K`; the optional second operand is the BSDF sample's density) |
//! | `occlusion %n, %samples, %maxdist` | [`Op::Occlusion`] |
//! | `probe hitdist %origin, %dir, %min, %max` | [`Op::Probe`] (the field by name, [`ProbeField::name`]) |
//! | `printf "x = %g\n", %x` (or `warning`, `error`) | [`Op::Print`] (the format as a quoted string, then the values it formats) |
//!
//! A region's blocks hold value lines and end with `yield %a, %b, …` (left out when the
//! block yields nothing). A label is visible after its line, in its block and the blocks
//! nested in it; a label names one value in the whole program. The region itself is
//! defined after its closing brace.
//!
//! **Literals** take their type from the line (`: TYPE` for a constant, `TYPE =` for a
//! parameter): `true`/`false`; an integer (`-3`); a float as Rust's `{:?}` writes it (`1.0`,
//! `-0.0`, `1e-7`, `5e-324`) or `inf`, `-inf`, `nan` (the canonical quiet NaN) and
//! `nan(0x7ff4000000000000)` (any other NaN, by its bits); a vector or matrix as a
//! parenthesized list of floats (2 for `vec2`, 3 for `vec3`/`color`, 16 row-major for
//! `matrix44`); a string as a Rust-escaped quoted string (`"a\"b\n"`). A literal whose own
//! type differs from the line's (or a constant without a type) is preceded by its type:
//! `const vec3 (1.0, 2.0, 3.0) : color`.
//!
//! **Names.** The program and parameter names are always quoted. A component or output name
//! is written bare when it is an identifier (a letter or `_`, then letters, digits, `_`
//! and `.`) and quoted otherwise (`output "out alpha" %0`); the parser accepts either form.
//! A component is referred to by name, or as `#K` (its index) where the name does not lead
//! back to index K (out of range, or a repeated name: both invalid programs).
//!
//! `;` starts a comment that runs to the end of the line. Whitespace and line breaks are
//! free, except that the names of a `components` line must be on that line. The parser
//! takes the top-level statements in any order (a name or label must be declared before it
//! is used) and regions nested at most 64 deep.
//!
//! **Invalid programs** print without panicking: a value listed a second time prints as a
//! `; error:` comment, an operand that is in no block as `%vN` (its arena index), which
//! the parser rejects.

use super::{
    AttributeDecl, BinOp, Block, ColorSpace, Expr, Filter, Intrinsic, Op, Output, ParamDecl,
    ProbeField, Program, Sampling, Severity, Space, Stream, TextureFile, UnOp, Value, Wrap,
    XformKind, ray_type_from_name, ray_type_name,
};
use crate::types::{ConstValue, Type, fmt_float};
use std::collections::HashMap;
use std::fmt;

/// The bits of the NaN written `nan` (Rust's `f64::NAN`); other NaNs print with their bits.
const CANONICAL_NAN_BITS: u64 = 0x7ff8_0000_0000_0000;

/// How deeply regions may nest in parsed text (a guard against stack exhaustion).
const MAX_DEPTH: usize = 64;

// ---------------------------------------------------------------------------------------
// Printing
// ---------------------------------------------------------------------------------------

/// The textual number of every value (indexed like `Program::exprs`): values are numbered
/// in print order, a region before its blocks; values in no block get `None`. A value
/// listed more than once is numbered (and its blocks walked) at its first listing only.
fn number_values(p: &Program) -> Vec<Option<u32>> {
    fn go(p: &Program, b: &Block, names: &mut [Option<u32>], next: &mut u32) {
        for &v in &b.body {
            // Dangling handles and repeated listings get no number.
            if let Some(slot @ None) = names.get_mut(v.index()) {
                *slot = Some(*next);
                *next += 1;
                for inner in p.exprs[v.index()].op.blocks() {
                    go(p, inner, names, next);
                }
            }
        }
    }
    let mut names = vec![None; p.exprs.len()];
    let mut next = 0;
    go(p, &p.prelude, &mut names, &mut next);
    go(p, &p.body, &mut names, &mut next);
    names
}

/// Whether `s` can be written without quotes (it lexes as one identifier).
fn is_bare(s: &str) -> bool {
    let mut cs = s.chars();
    matches!(cs.next(), Some(c) if is_ident_start(c)) && cs.all(is_ident_char)
}

fn is_ident_start(c: char) -> bool {
    c.is_ascii_alphabetic() || c == '_'
}

fn is_ident_char(c: char) -> bool {
    c.is_ascii_alphanumeric() || c == '_' || c == '.'
}

/// A component or output name: bare if it is an identifier, quoted otherwise.
fn name_text(s: &str) -> String {
    if is_bare(s) {
        s.to_string()
    } else {
        format!("{s:?}")
    }
}

/// A float that parses back to the same bits.
fn float_text(x: f64) -> String {
    if x.is_nan() && x.to_bits() != CANONICAL_NAN_BITS {
        format!("nan(0x{:016x})", x.to_bits())
    } else {
        fmt_float(x)
    }
}

/// A literal; preceded by its type unless that is `context`.
fn const_text(c: &ConstValue, context: Option<Type>) -> String {
    let mut s = String::new();
    if context != Some(c.ty()) {
        s.push_str(c.ty().name());
        s.push(' ');
    }
    match c {
        ConstValue::Bool(b) => s.push_str(if *b { "true" } else { "false" }),
        ConstValue::Int(i) => s.push_str(&i.to_string()),
        ConstValue::String(x) => s.push_str(&format!("{x:?}")),
        ConstValue::Float(x) => s.push_str(&float_text(*x)),
        other => {
            let parts: Vec<String> = other.floats().iter().map(|x| float_text(*x)).collect();
            s.push('(');
            s.push_str(&parts.join(", "));
            s.push(')');
        }
    }
    s
}

struct Printer<'a, W> {
    p: &'a Program,
    names: Vec<Option<u32>>,
    printed: Vec<bool>,
    out: W,
}

impl<W: fmt::Write> Printer<'_, W> {
    fn val(&self, v: Value) -> String {
        match self.names.get(v.index()).copied().flatten() {
            Some(n) => format!("%{n}"),
            None => format!("%v{}", v.index()),
        }
    }

    fn vals(&self, vs: &[Value]) -> String {
        let parts: Vec<String> = vs.iter().map(|v| self.val(*v)).collect();
        parts.join(", ")
    }

    fn component(&self, k: u8) -> String {
        match self.p.components.get(k as usize) {
            Some(name) if self.p.component_index(name) == Some(k) => name_text(name),
            _ => format!("#{k}"),
        }
    }

    fn program(&mut self) -> fmt::Result {
        let p = self.p;
        writeln!(self.out, "program {:?} {{", p.name)?;
        if !p.components.is_empty() {
            let names: Vec<String> = p.components.iter().map(|c| name_text(c)).collect();
            writeln!(self.out, "  components {}", names.join(" "))?;
        }
        for ParamDecl { name, ty, default } in &p.params {
            let lit = const_text(default, Some(*ty));
            writeln!(self.out, "  param {name:?} {ty} = {lit}")?;
        }
        for t in &p.textures {
            match t.colorspace {
                ColorSpace::Auto => writeln!(self.out, "  texture {:?}", t.path)?,
                cs => writeln!(self.out, "  texture {:?} {}", t.path, cs.name())?,
            }
        }
        for a in &p.attributes {
            writeln!(self.out, "  attribute {:?} {}", a.name, a.ty)?;
        }
        if !p.prelude.body.is_empty() || !p.prelude.yields.is_empty() {
            writeln!(self.out, "  prelude {{")?;
            self.block(&p.prelude, 2)?;
            writeln!(self.out, "  }}")?;
        }
        self.block(&p.body, 1)?;
        for Output {
            name,
            component,
            value,
        } in &p.outputs
        {
            let comp = component.map_or(String::new(), |k| format!("[{}]", self.component(k)));
            let v = self.val(*value);
            writeln!(self.out, "  output {}{comp} {v}", name_text(name))?;
        }
        writeln!(self.out, "}}")
    }

    fn block(&mut self, b: &Block, depth: usize) -> fmt::Result {
        let ind = "  ".repeat(depth);
        for &v in &b.body {
            let Some(e) = self.p.exprs.get(v.index()) else {
                writeln!(self.out, "{ind}; error: {v:?} is not in the arena")?;
                continue;
            };
            if self.printed[v.index()] {
                let name = self.val(v);
                writeln!(
                    self.out,
                    "{ind}; error: {name} ({v:?}) is listed again here"
                )?;
                continue;
            }
            self.printed[v.index()] = true;
            write!(self.out, "{ind}{} = ", self.val(v))?;
            self.op(e, depth)?;
            if let Some(t) = e.ty {
                write!(self.out, " : {t}")?;
            }
            writeln!(self.out)?;
        }
        if !b.yields.is_empty() {
            writeln!(self.out, "{ind}yield {}", self.vals(&b.yields))?;
        }
        Ok(())
    }

    fn op(&mut self, e: &Expr, depth: usize) -> fmt::Result {
        let ind = "  ".repeat(depth);
        let text = match &e.op {
            Op::Const(c) => format!("const {}", const_text(c, e.ty)),
            Op::Param(i) => format!("param {i}"),
            Op::Stream(s) => format!("stream {}", s.name()),
            Op::Transform {
                kind,
                from,
                to,
                arg,
            } => format!(
                "transform {} {} -> {} {}",
                kind.name(),
                from.name(),
                to.name(),
                self.val(*arg)
            ),
            Op::ComponentEnabled(k) => format!("component_enabled {}", self.component(*k)),
            Op::Unary(op, a) => format!("{} {}", op.name(), self.val(*a)),
            Op::Binary(op, a, b) => format!("{} {}", op.name(), self.vals(&[*a, *b])),
            Op::Select { cond, a, b } => format!("select {}", self.vals(&[*cond, *a, *b])),
            Op::Construct(args) if args.is_empty() => "construct".to_string(),
            Op::Construct(args) => format!("construct {}", self.vals(args)),
            Op::Extract(a, i) => format!("extract {}, {i}", self.val(*a)),
            Op::Splat(a) => format!("splat {}", self.val(*a)),
            Op::Convert(a) => format!("convert {}", self.val(*a)),
            Op::Call(i, args) if args.is_empty() => format!("call {}", i.name()),
            Op::Call(i, args) => format!("call {} {}", i.name(), self.vals(args)),
            Op::If { cond, then_, else_ } => {
                writeln!(self.out, "if {} {{", self.val(*cond))?;
                self.block(then_, depth + 1)?;
                writeln!(self.out, "{ind}}} else {{")?;
                self.block(else_, depth + 1)?;
                return write!(self.out, "{ind}}}");
            }
            Op::Illuminance { p, body } => {
                writeln!(self.out, "illuminance {} {{", self.val(*p))?;
                self.block(body, depth + 1)?;
                return write!(self.out, "{ind}}}");
            }
            Op::Loop { init, cond, body } => {
                match init.is_empty() {
                    true => writeln!(self.out, "loop while {{")?,
                    false => writeln!(self.out, "loop {} while {{", self.vals(init))?,
                }
                self.block(cond, depth + 1)?;
                writeln!(self.out, "{ind}}} do {{")?;
                self.block(body, depth + 1)?;
                return write!(self.out, "{ind}}}");
            }
            Op::LoopVar(k) => format!("loop.var {k}"),
            Op::LightL => "light.L".to_string(),
            Op::LightCl => "light.Cl".to_string(),
            Op::LightVisible => "light.visible".to_string(),
            Op::LightPdf => "light.pdf".to_string(),
            Op::Ambient => "ambient".to_string(),
            Op::Proj(r, i) => format!("proj {}, {i}", self.val(*r)),
            Op::Texture {
                texture,
                uv,
                derivs,
                sampling,
                alpha,
            } => {
                let mut s = format!(
                    "{} #{texture} ",
                    if *alpha { "texture.alpha" } else { "texture" }
                );
                let def = Sampling::default();
                if sampling.filter != def.filter {
                    s += &format!("{} ", sampling.filter.name());
                }
                if sampling.wrap != def.wrap {
                    s += &format!("{} {} ", sampling.wrap[0].name(), sampling.wrap[1].name());
                }
                s += &self.val(*uv);
                if let Some([dx, dy]) = derivs {
                    s += &format!(", {}, {}", self.val(*dx), self.val(*dy));
                }
                s
            }
            Op::Attribute { slot, default } => {
                format!("attribute #{slot} {}", self.val(*default))
            }
            Op::AttributeFound { slot } => format!("attribute.found #{slot}"),
            Op::Trace { dir, ray_type, pdf } => {
                let ty = match ray_type_name(*ray_type) {
                    Some(name) => name.to_string(),
                    None => format!("#{ray_type}"),
                };
                match pdf {
                    Some(p) => format!("trace {ty} {}", self.vals(&[*dir, *p])),
                    None => format!("trace {ty} {}", self.val(*dir)),
                }
            }
            Op::Occlusion {
                n,
                samples,
                max_distance,
            } => format!("occlusion {}", self.vals(&[*n, *samples, *max_distance])),
            Op::Probe {
                field,
                origin,
                dir,
                min_distance,
                max_distance,
            } => format!(
                "probe {} {}",
                field.name(),
                self.vals(&[*origin, *dir, *min_distance, *max_distance])
            ),
            Op::Print {
                severity,
                format,
                args,
            } => {
                let mut s = format!("{} {format:?}", severity.name());
                for a in args {
                    s += ", ";
                    s += &self.val(*a);
                }
                s
            }
        };
        self.out.write_str(&text)
    }
}

/// Prints the program in the IR text form (syntax: the module documentation at the top of
/// `graph/src/ir/text.rs`); [`parse`] reads it back.
impl fmt::Display for Program {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        Printer {
            p: self,
            names: number_values(self),
            printed: vec![false; self.exprs.len()],
            out: f,
        }
        .program()
    }
}

// ---------------------------------------------------------------------------------------
// Errors
// ---------------------------------------------------------------------------------------

/// A syntax or naming error in IR text, with the place it was found.
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
#[error("line {line}, column {column}: {kind}")]
pub struct ParseError {
    /// 1-based line.
    pub line: usize,
    /// 1-based column, in characters.
    pub column: usize,
    /// What is wrong.
    pub kind: ParseErrorKind,
}

/// What is wrong in IR text (see [`ParseError`] for where).
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
pub enum ParseErrorKind {
    /// A character that starts no token.
    #[error("unexpected character {0:?}")]
    UnexpectedChar(char),
    /// A string literal without its closing quote.
    #[error("unterminated string")]
    UnterminatedString,
    /// An escape sequence Rust's `{:?}` would not write.
    #[error("invalid escape `{0}` in string")]
    BadEscape(String),
    /// Some other token was expected here.
    #[error("expected {expected}, found {found}")]
    Expected {
        /// What the parser was looking for.
        expected: String,
        /// What it found.
        found: String,
    },
    /// An op name that is not an op.
    #[error("unknown op `{0}`")]
    UnknownOp(String),
    /// A type name that is not a [`Type`].
    #[error("unknown type `{0}`")]
    UnknownType(String),
    /// A stream name that is not a [`Stream`].
    #[error("unknown stream `{0}`")]
    UnknownStream(String),
    /// A space name that is not a [`Space`].
    #[error("unknown space `{0}` (world, camera or object)")]
    UnknownSpace(String),
    /// A transform kind that is not an [`XformKind`].
    #[error("unknown transform kind `{0}` (point, vector or normal)")]
    UnknownXformKind(String),
    /// An intrinsic name that is not an [`Intrinsic`].
    #[error("unknown intrinsic `{0}`")]
    UnknownIntrinsic(String),
    /// A ray type name that is not one of [`super::RAY_TYPES`].
    #[error("unknown ray type `{0}` (camera, shadow, reflection, refraction, diffuse or #CODE)")]
    UnknownRayType(String),
    /// A component name not declared on the `components` line.
    #[error("unknown component `{0}` (declare it on the `components` line)")]
    UnknownComponent(String),
    /// More components than a `u8` index can name.
    #[error("more than 256 components")]
    TooManyComponents,
    /// A label that no line defines (or defines only later).
    #[error("undefined value %{0}")]
    UndefinedValue(String),
    /// A label defined in a region that does not enclose this use.
    #[error("%{name} is not visible here: it is defined inside a region, at line {line}")]
    NotVisible {
        /// The label, without `%`.
        name: String,
        /// Where it is defined.
        line: usize,
    },
    /// A label defined a second time.
    #[error("%{name} is defined twice (first at line {line})")]
    Redefined {
        /// The label, without `%`.
        name: String,
        /// Where it was first defined.
        line: usize,
    },
    /// A number that is malformed or out of range for its place.
    #[error("bad number `{0}`")]
    BadNumber(String),
    /// A literal that does not fit its type.
    #[error("bad {ty} literal: {reason}")]
    BadLiteral {
        /// The type the literal should have.
        ty: Type,
        /// What does not fit.
        reason: String,
    },
    /// A constant with neither `: TYPE` nor a type before its literal.
    #[error("the constant has no type: write `: TYPE` or a type before the literal")]
    UntypedConst,
    /// Regions nested too deeply.
    #[error("regions nested deeper than {0}")]
    TooDeep(usize),
}

// ---------------------------------------------------------------------------------------
// Lexing
// ---------------------------------------------------------------------------------------

#[derive(Clone, Debug, PartialEq)]
enum Tok {
    /// `[A-Za-z_][A-Za-z0-9_.]*`.
    Ident(String),
    /// `%label`, without the `%`.
    Val(String),
    /// A number, or `-` followed by word characters (`-inf`); checked where it is used.
    Num(String),
    /// A string literal, unescaped.
    Str(String),
    /// One of `{ } ( ) [ ] , : = #`.
    Punct(char),
    /// `->`.
    Arrow,
    /// The end of the input.
    Eof,
}

#[derive(Clone, Debug)]
struct Token {
    tok: Tok,
    line: usize,
    column: usize,
}

impl Token {
    fn describe(&self) -> String {
        match &self.tok {
            Tok::Ident(s) | Tok::Num(s) => format!("`{s}`"),
            Tok::Val(s) => format!("`%{s}`"),
            Tok::Str(s) => format!("string {s:?}"),
            Tok::Punct(c) => format!("`{c}`"),
            Tok::Arrow => "`->`".to_string(),
            Tok::Eof => "end of input".to_string(),
        }
    }
}

struct Lexer {
    chars: Vec<char>,
    i: usize,
    line: usize,
    column: usize,
}

impl Lexer {
    fn peek(&self, k: usize) -> Option<char> {
        self.chars.get(self.i + k).copied()
    }

    fn bump(&mut self) -> Option<char> {
        let c = self.peek(0)?;
        self.i += 1;
        if c == '\n' {
            self.line += 1;
            self.column = 1;
        } else {
            self.column += 1;
        }
        Some(c)
    }

    fn err(&self, line: usize, column: usize, kind: ParseErrorKind) -> ParseError {
        ParseError { line, column, kind }
    }

    fn word(&mut self, first: char, number: bool) -> String {
        let mut s = String::from(first);
        while let Some(c) = self.peek(0) {
            let exponent_sign = number
                && (c == '+' || c == '-')
                && s.ends_with(['e', 'E'])
                && !s.trim_start_matches('-').starts_with("0x");
            if is_ident_char(c) || exponent_sign {
                s.push(c);
                self.bump();
            } else {
                break;
            }
        }
        s
    }

    fn string(&mut self, line: usize, column: usize) -> Result<String, ParseError> {
        let mut s = String::new();
        loop {
            let (l, c) = (self.line, self.column);
            match self.bump() {
                None => return Err(self.err(line, column, ParseErrorKind::UnterminatedString)),
                Some('"') => return Ok(s),
                Some('\\') => {
                    let bad =
                        |lx: &Lexer, text: String| lx.err(l, c, ParseErrorKind::BadEscape(text));
                    match self.bump() {
                        Some('n') => s.push('\n'),
                        Some('t') => s.push('\t'),
                        Some('r') => s.push('\r'),
                        Some('0') => s.push('\0'),
                        Some('\\') => s.push('\\'),
                        Some('"') => s.push('"'),
                        Some('\'') => s.push('\''),
                        Some('u') => {
                            let mut text = String::from("\\u");
                            if self.peek(0) != Some('{') {
                                return Err(bad(self, text));
                            }
                            self.bump();
                            text.push('{');
                            let mut hex = String::new();
                            while let Some(h) = self.peek(0).filter(|h| h.is_ascii_hexdigit()) {
                                hex.push(h);
                                self.bump();
                            }
                            text.push_str(&hex);
                            if self.peek(0) != Some('}') {
                                return Err(bad(self, text));
                            }
                            self.bump();
                            text.push('}');
                            let ch = (hex.len() <= 6)
                                .then(|| u32::from_str_radix(&hex, 16).ok())
                                .flatten()
                                .and_then(char::from_u32);
                            match ch {
                                Some(ch) => s.push(ch),
                                None => return Err(bad(self, text)),
                            }
                        }
                        Some(other) => return Err(bad(self, format!("\\{other}"))),
                        None => {
                            return Err(self.err(line, column, ParseErrorKind::UnterminatedString));
                        }
                    }
                }
                Some(ch) => s.push(ch),
            }
        }
    }

    fn tokens(mut self) -> Result<Vec<Token>, ParseError> {
        let mut out = Vec::new();
        loop {
            let (line, column) = (self.line, self.column);
            let Some(c) = self.bump() else {
                out.push(Token {
                    tok: Tok::Eof,
                    line,
                    column,
                });
                return Ok(out);
            };
            let tok = match c {
                c if c.is_whitespace() => continue,
                ';' => {
                    while self.peek(0).is_some_and(|c| c != '\n') {
                        self.bump();
                    }
                    continue;
                }
                '"' => Tok::Str(self.string(line, column)?),
                '%' => {
                    let mut label = String::new();
                    while let Some(c) = self
                        .peek(0)
                        .filter(|c| c.is_ascii_alphanumeric() || *c == '_')
                    {
                        label.push(c);
                        self.bump();
                    }
                    if label.is_empty() {
                        let found = self
                            .peek(0)
                            .map_or("end of input".to_string(), |c| format!("{c:?}"));
                        return Err(self.err(
                            line,
                            column,
                            ParseErrorKind::Expected {
                                expected: "a value name after `%`".to_string(),
                                found,
                            },
                        ));
                    }
                    Tok::Val(label)
                }
                '-' if self.peek(0) == Some('>') => {
                    self.bump();
                    Tok::Arrow
                }
                '-' if self.peek(0).is_some_and(|c| c.is_ascii_alphanumeric()) => {
                    Tok::Num(self.word('-', true))
                }
                c if c.is_ascii_digit() => Tok::Num(self.word(c, true)),
                c if is_ident_start(c) => Tok::Ident(self.word(c, false)),
                '{' | '}' | '(' | ')' | '[' | ']' | ',' | ':' | '=' | '#' => Tok::Punct(c),
                other => return Err(self.err(line, column, ParseErrorKind::UnexpectedChar(other))),
            };
            out.push(Token { tok, line, column });
        }
    }
}

// ---------------------------------------------------------------------------------------
// Parsing
// ---------------------------------------------------------------------------------------

/// Parses the IR text form written by `Display for Program` (syntax: the module
/// documentation at the top of `graph/src/ir/text.rs`).
///
/// The parser checks the syntax and the names: every op, type, stream, space, intrinsic and
/// component name, every literal against its type, and that each `%label` is defined once
/// and used only where it is visible. It does not check types against the op rules: run
/// [`validate`](fn@super::validate) on the result for that. It never panics on malformed input.
///
/// ```
/// use shadenet_graph::ir::parse;
/// let p = parse("program \"m\" {\n  %0 = const 1.0 : float\n  output out %0\n}\n").unwrap();
/// assert_eq!(p.outputs[0].name, "out");
/// let e = parse("program \"m\" {\n  %0 = frob : float\n}\n").unwrap_err();
/// assert_eq!((e.line, e.column), (2, 8));
/// ```
pub fn parse(src: &str) -> Result<Program, ParseError> {
    let toks = Lexer {
        chars: src.chars().collect(),
        i: 0,
        line: 1,
        column: 1,
    }
    .tokens()?;
    let mut p = Parser {
        toks,
        pos: 0,
        prog: Program::default(),
        defs: HashMap::new(),
        scopes: Vec::new(),
        keep_scope: false,
        depth: 0,
    };
    p.program()?;
    Ok(p.prog)
}

/// A label's definition.
struct Def {
    value: Value,
    line: usize,
    visible: bool,
}

/// A literal before its type is known (the `: TYPE` of a line comes after it).
enum Lit {
    /// A number, string, `true`/`false`, `inf` or `nan`.
    Atom(Token),
    /// `nan(0x…)`: the token of the bits.
    NanBits(Token),
    /// `( … )`: the token of the opening parenthesis and the items.
    Tuple(Token, Vec<Lit>),
}

impl Lit {
    fn token(&self) -> &Token {
        match self {
            Lit::Atom(t) | Lit::NanBits(t) | Lit::Tuple(t, _) => t,
        }
    }
}

/// What an op parses to: an op, or a constant still waiting for its type.
enum Parsed {
    Op(Op),
    Const { prefix: Option<Type>, lit: Lit },
}

struct Parser {
    toks: Vec<Token>,
    pos: usize,
    prog: Program,
    defs: HashMap<String, Def>,
    /// The labels defined in each open block, innermost last.
    scopes: Vec<Vec<String>>,
    /// The next block's values stay visible after it (the prelude's).
    keep_scope: bool,
    depth: usize,
}

type PResult<T> = Result<T, ParseError>;

impl Parser {
    fn peek(&self) -> &Token {
        // The token list always ends with `Eof` and `pos` never passes it.
        &self.toks[self.pos.min(self.toks.len() - 1)]
    }

    fn next(&mut self) -> Token {
        let t = self.peek().clone();
        if self.pos + 1 < self.toks.len() {
            self.pos += 1;
        }
        t
    }

    fn err(t: &Token, kind: ParseErrorKind) -> ParseError {
        ParseError {
            line: t.line,
            column: t.column,
            kind,
        }
    }

    fn expected(t: &Token, what: &str) -> ParseError {
        Self::err(
            t,
            ParseErrorKind::Expected {
                expected: what.to_string(),
                found: t.describe(),
            },
        )
    }

    fn is_punct(&self, c: char) -> bool {
        self.peek().tok == Tok::Punct(c)
    }

    fn eat_punct(&mut self, c: char) -> bool {
        let yes = self.is_punct(c);
        if yes {
            self.next();
        }
        yes
    }

    fn expect_punct(&mut self, c: char) -> PResult<Token> {
        let t = self.next();
        if t.tok == Tok::Punct(c) {
            Ok(t)
        } else {
            Err(Self::expected(&t, &format!("`{c}`")))
        }
    }

    fn keyword(&mut self, word: &str) -> PResult<()> {
        let t = self.next();
        match &t.tok {
            Tok::Ident(w) if w == word => Ok(()),
            _ => Err(Self::expected(&t, &format!("`{word}`"))),
        }
    }

    /// An identifier, with its token.
    fn ident(&mut self, what: &str) -> PResult<(String, Token)> {
        let t = self.next();
        match &t.tok {
            Tok::Ident(w) => Ok((w.clone(), t.clone())),
            _ => Err(Self::expected(&t, what)),
        }
    }

    /// A component or output name: an identifier or a quoted string.
    fn name(&mut self, what: &str) -> PResult<(String, Token)> {
        let t = self.next();
        match &t.tok {
            Tok::Ident(w) | Tok::Str(w) => Ok((w.clone(), t.clone())),
            _ => Err(Self::expected(&t, what)),
        }
    }

    /// A non-negative integer that fits `T`.
    fn index<T: TryFrom<u64>>(&mut self, what: &str) -> PResult<T> {
        let t = self.next();
        let Tok::Num(text) = &t.tok else {
            return Err(Self::expected(&t, what));
        };
        text.parse::<u64>()
            .ok()
            .and_then(|n| T::try_from(n).ok())
            .ok_or_else(|| Self::err(&t, ParseErrorKind::BadNumber(text.clone())))
    }

    fn ty(&mut self) -> PResult<Type> {
        let (w, t) = self.ident("a type")?;
        Type::from_name(&w).ok_or_else(|| Self::err(&t, ParseErrorKind::UnknownType(w)))
    }

    /// A type name written before a literal, if there is one.
    fn type_prefix(&mut self) -> Option<Type> {
        let ty = match &self.peek().tok {
            Tok::Ident(w) => Type::from_name(w),
            _ => None,
        };
        if ty.is_some() {
            self.next();
        }
        ty
    }

    fn program(&mut self) -> PResult<()> {
        self.keyword("program")?;
        let t = self.next();
        let Tok::Str(name) = t.tok.clone() else {
            return Err(Self::expected(&t, "the program's name (a quoted string)"));
        };
        self.prog.name = name;
        self.expect_punct('{')?;
        self.prog.body = self.block(true)?;
        self.expect_punct('}')?;
        let t = self.next();
        if t.tok != Tok::Eof {
            return Err(Self::expected(&t, "end of input after the program"));
        }
        Ok(())
    }

    /// The statements of a block, up to (not including) its `}`.
    fn block(&mut self, top: bool) -> PResult<Block> {
        if self.depth >= MAX_DEPTH {
            return Err(Self::err(self.peek(), ParseErrorKind::TooDeep(MAX_DEPTH)));
        }
        self.depth += 1;
        let keep = std::mem::take(&mut self.keep_scope);
        self.scopes.push(Vec::new());
        let mut block = Block::default();
        let mut yielded = false;
        loop {
            let t = self.peek().clone();
            match &t.tok {
                Tok::Punct('}') | Tok::Eof => break,
                Tok::Val(_) if top || !yielded => {
                    let v = self.definition()?;
                    block.body.push(v);
                }
                Tok::Ident(w) if w == "yield" && !yielded => {
                    self.next();
                    block.yields = self.operand_list()?;
                    yielded = true;
                }
                Tok::Ident(w) if top && w == "components" => self.components()?,
                Tok::Ident(w) if top && w == "texture" => {
                    self.next();
                    let t = self.next();
                    let Tok::Str(name) = t.tok.clone() else {
                        return Err(Self::expected(&t, "a texture file name (a quoted string)"));
                    };
                    let mut file = TextureFile::auto(name);
                    if let Tok::Ident(w) = &self.peek().tok
                        && let Some(cs) = ColorSpace::from_name(w)
                    {
                        file.colorspace = cs;
                        self.next();
                    }
                    self.prog.textures.push(file);
                }
                Tok::Ident(w) if top && w == "attribute" => {
                    self.next();
                    let t = self.next();
                    let Tok::Str(name) = t.tok.clone() else {
                        return Err(Self::expected(&t, "an attribute name (a quoted string)"));
                    };
                    let ty = self.ty()?;
                    self.prog.attributes.push(AttributeDecl { name, ty });
                }
                Tok::Ident(w) if top && w == "prelude" => {
                    self.next();
                    self.expect_punct('{')?;
                    self.keep_scope = true;
                    let pre = self.block(false)?;
                    self.expect_punct('}')?;
                    self.prog.prelude.body.extend(pre.body);
                    self.prog.prelude.yields.extend(pre.yields);
                }
                Tok::Ident(w) if top && w == "param" => self.param()?,
                Tok::Ident(w) if top && w == "output" => self.output()?,
                _ => {
                    let what = if yielded && !top {
                        "`}` after `yield`"
                    } else if top {
                        "a statement (`%name = …`, `components`, `param`, `output`) or `}`"
                    } else {
                        "a statement (`%name = …`, `yield`) or `}`"
                    };
                    return Err(Self::expected(&t, what));
                }
            }
        }
        let labels = self.scopes.pop().unwrap_or_default();
        if keep {
            // The prelude's values stay visible to the rest of the program.
            if let Some(outer) = self.scopes.last_mut() {
                outer.extend(labels);
            }
        } else {
            for label in labels {
                if let Some(d) = self.defs.get_mut(&label) {
                    d.visible = false;
                }
            }
        }
        self.depth -= 1;
        Ok(block)
    }

    fn components(&mut self) -> PResult<()> {
        let kw = self.next();
        while matches!(self.peek().tok, Tok::Ident(_) | Tok::Str(_)) && self.peek().line == kw.line
        {
            let (name, t) = self.name("a component name")?;
            if self.prog.components.len() > u8::MAX as usize {
                return Err(Self::err(&t, ParseErrorKind::TooManyComponents));
            }
            self.prog.components.push(name);
        }
        Ok(())
    }

    fn param(&mut self) -> PResult<()> {
        self.next();
        let t = self.next();
        let Tok::Str(name) = t.tok.clone() else {
            return Err(Self::expected(&t, "the parameter's name (a quoted string)"));
        };
        let ty = self.ty()?;
        self.expect_punct('=')?;
        let prefix = self.type_prefix();
        let lit = self.lit()?;
        let default = self.lit_value(&lit, prefix.unwrap_or(ty))?;
        self.prog.params.push(ParamDecl { name, ty, default });
        Ok(())
    }

    fn output(&mut self) -> PResult<()> {
        self.next();
        let (name, _) = self.name("an output name")?;
        let component = if self.eat_punct('[') {
            let k = self.component_ref()?;
            self.expect_punct(']')?;
            Some(k)
        } else {
            None
        };
        let value = self.operand()?;
        self.prog.outputs.push(Output {
            name,
            component,
            value,
        });
        Ok(())
    }

    fn component_ref(&mut self) -> PResult<u8> {
        if self.eat_punct('#') {
            return self.index("a component index");
        }
        let (name, t) = self.name("a component name")?;
        self.prog
            .component_index(&name)
            .ok_or_else(|| Self::err(&t, ParseErrorKind::UnknownComponent(name)))
    }

    /// `%label = op … [: type]`.
    fn definition(&mut self) -> PResult<Value> {
        let t = self.next();
        let Tok::Val(label) = t.tok.clone() else {
            return Err(Self::expected(&t, "a value (`%name`)"));
        };
        let redefined = |defs: &HashMap<String, Def>| {
            defs.get(&label).map(|d| {
                Self::err(
                    &t,
                    ParseErrorKind::Redefined {
                        name: label.clone(),
                        line: d.line,
                    },
                )
            })
        };
        if let Some(e) = redefined(&self.defs) {
            return Err(e);
        }
        self.expect_punct('=')?;
        // Reserve the arena slot now, so a region comes before its blocks' values.
        let v = Value::new(self.prog.exprs.len());
        self.prog.exprs.push(Expr {
            op: Op::Ambient,
            ty: None,
        });
        let parsed = self.op()?;
        let ty = if self.eat_punct(':') {
            Some(self.ty()?)
        } else {
            None
        };
        let op = match parsed {
            Parsed::Op(op) => op,
            Parsed::Const { prefix, lit } => {
                let Some(lty) = prefix.or(ty) else {
                    return Err(Self::err(lit.token(), ParseErrorKind::UntypedConst));
                };
                Op::Const(self.lit_value(&lit, lty)?)
            }
        };
        // A label reused inside the region's own blocks.
        if let Some(e) = redefined(&self.defs) {
            return Err(e);
        }
        self.prog.exprs[v.index()] = Expr { op, ty };
        self.defs.insert(
            label.clone(),
            Def {
                value: v,
                line: t.line,
                visible: true,
            },
        );
        if let Some(scope) = self.scopes.last_mut() {
            scope.push(label);
        }
        Ok(v)
    }

    fn operand(&mut self) -> PResult<Value> {
        let t = self.next();
        let Tok::Val(label) = &t.tok else {
            return Err(Self::expected(&t, "a value (`%name`)"));
        };
        match self.defs.get(label) {
            None => Err(Self::err(&t, ParseErrorKind::UndefinedValue(label.clone()))),
            Some(d) if !d.visible => Err(Self::err(
                &t,
                ParseErrorKind::NotVisible {
                    name: label.clone(),
                    line: d.line,
                },
            )),
            Some(d) => Ok(d.value),
        }
    }

    /// `%a, %b, …`, possibly empty.
    fn operand_list(&mut self) -> PResult<Vec<Value>> {
        let mut vs = Vec::new();
        if matches!(self.peek().tok, Tok::Val(_)) {
            vs.push(self.operand()?);
            while self.eat_punct(',') {
                vs.push(self.operand()?);
            }
        }
        Ok(vs)
    }

    fn operands<const N: usize>(&mut self) -> PResult<[Value; N]> {
        let mut vs = [Value::new(0); N];
        for (i, v) in vs.iter_mut().enumerate() {
            if i > 0 {
                self.expect_punct(',')?;
            }
            *v = self.operand()?;
        }
        Ok(vs)
    }

    /// `{ block }`.
    fn braced_block(&mut self) -> PResult<Block> {
        self.expect_punct('{')?;
        let b = self.block(false)?;
        self.expect_punct('}')?;
        Ok(b)
    }

    fn op(&mut self) -> PResult<Parsed> {
        let (word, t) = self.ident("an op")?;
        // Regions recurse: keep their path through small frames, the rest out of line.
        match word.as_str() {
            "if" => {
                let cond = self.operand()?;
                let then_ = self.braced_block()?;
                self.keyword("else")?;
                let else_ = self.braced_block()?;
                Ok(Parsed::Op(Op::If { cond, then_, else_ }))
            }
            "illuminance" => {
                let p = self.operand()?;
                let body = self.braced_block()?;
                Ok(Parsed::Op(Op::Illuminance { p, body }))
            }
            "loop" => {
                let init = self.operand_list()?;
                self.keyword("while")?;
                let cond = self.braced_block()?;
                self.keyword("do")?;
                let body = self.braced_block()?;
                Ok(Parsed::Op(Op::Loop { init, cond, body }))
            }
            _ => self.plain_op(word, t),
        }
    }

    /// Every op but the regions.
    #[inline(never)]
    fn plain_op(&mut self, word: String, t: Token) -> PResult<Parsed> {
        let op = match word.as_str() {
            "const" => {
                let prefix = self.type_prefix();
                let lit = self.lit()?;
                return Ok(Parsed::Const { prefix, lit });
            }
            "param" => Op::Param(self.index("a parameter index")?),
            "stream" => {
                let (w, t) = self.ident("a stream name")?;
                let s = Stream::from_name(&w);
                Op::Stream(s.ok_or_else(|| Self::err(&t, ParseErrorKind::UnknownStream(w)))?)
            }
            "transform" => {
                let (w, t) = self.ident("a transform kind")?;
                let kind = XformKind::from_name(&w)
                    .ok_or_else(|| Self::err(&t, ParseErrorKind::UnknownXformKind(w)))?;
                let from = self.space()?;
                let t = self.next();
                if t.tok != Tok::Arrow {
                    return Err(Self::expected(&t, "`->`"));
                }
                let to = self.space()?;
                let arg = self.operand()?;
                Op::Transform {
                    kind,
                    from,
                    to,
                    arg,
                }
            }
            "component_enabled" => Op::ComponentEnabled(self.component_ref()?),
            "select" => {
                let [cond, a, b] = self.operands()?;
                Op::Select { cond, a, b }
            }
            "construct" => Op::Construct(self.operand_list()?),
            "extract" => {
                let a = self.operand()?;
                self.expect_punct(',')?;
                Op::Extract(a, self.index("a component index")?)
            }
            "splat" => Op::Splat(self.operand()?),
            "convert" => Op::Convert(self.operand()?),
            "call" => {
                let (w, t) = self.ident("an intrinsic name")?;
                let i = Intrinsic::from_name(&w)
                    .ok_or_else(|| Self::err(&t, ParseErrorKind::UnknownIntrinsic(w)))?;
                Op::Call(i, self.operand_list()?)
            }
            "texture" | "texture.alpha" => {
                self.expect_punct('#')?;
                let texture = self.index("a texture index")?;
                let sampling = self.sampling()?;
                let uv = self.operand()?;
                let derivs = if self.eat_punct(',') {
                    let [dx, dy] = self.operands()?;
                    Some([dx, dy])
                } else {
                    None
                };
                Op::Texture {
                    texture,
                    uv,
                    derivs,
                    sampling,
                    alpha: word == "texture.alpha",
                }
            }
            "attribute" => {
                self.expect_punct('#')?;
                let slot = self.index("an attribute index")?;
                Op::Attribute {
                    slot,
                    default: self.operand()?,
                }
            }
            "attribute.found" => {
                self.expect_punct('#')?;
                Op::AttributeFound {
                    slot: self.index("an attribute index")?,
                }
            }
            "light.L" => Op::LightL,
            "light.Cl" => Op::LightCl,
            "light.visible" => Op::LightVisible,
            "light.pdf" => Op::LightPdf,
            "ambient" => Op::Ambient,
            "loop.var" => Op::LoopVar(self.index("a carried value's index")?),
            "trace" => {
                let ray_type = self.ray_type()?;
                let dir = self.operand()?;
                let pdf = if self.eat_punct(',') {
                    Some(self.operand()?)
                } else {
                    None
                };
                Op::Trace { dir, ray_type, pdf }
            }
            "occlusion" => {
                let [n, samples, max_distance] = self.operands()?;
                Op::Occlusion {
                    n,
                    samples,
                    max_distance,
                }
            }
            "probe" => {
                let (w, t) = self.ident("a probe field")?;
                let field = ProbeField::from_name(&w).ok_or_else(|| {
                    Self::err(
                        &t,
                        ParseErrorKind::Expected {
                            expected: "a probe field (hit, hitdist, P, N, Ng, u, v)".into(),
                            found: format!("`{w}`"),
                        },
                    )
                })?;
                let [origin, dir, min_distance, max_distance] = self.operands()?;
                Op::Probe {
                    field,
                    origin,
                    dir,
                    min_distance,
                    max_distance,
                }
            }
            "printf" | "warning" | "error" => {
                let t = self.next();
                let Tok::Str(format) = t.tok.clone() else {
                    return Err(Self::expected(&t, "a format (a quoted string)"));
                };
                let mut args = Vec::new();
                while self.eat_punct(',') {
                    args.push(self.operand()?);
                }
                Op::Print {
                    severity: Severity::from_name(&word).unwrap_or(Severity::Printf),
                    format,
                    args,
                }
            }
            "proj" => {
                let r = self.operand()?;
                self.expect_punct(',')?;
                Op::Proj(r, self.index("a result index")?)
            }
            w => {
                if let Some(op) = UnOp::from_name(w) {
                    Op::Unary(op, self.operand()?)
                } else if let Some(op) = BinOp::from_name(w) {
                    let [a, b] = self.operands()?;
                    Op::Binary(op, a, b)
                } else {
                    return Err(Self::err(&t, ParseErrorKind::UnknownOp(word)));
                }
            }
        };
        Ok(Parsed::Op(op))
    }

    /// A ray type: its name, or `#CODE` (any i32).
    /// A lookup's filter and wrap modes, each optional (defaults: [`Sampling::default`]):
    /// `[FILTER] [WRAP_U WRAP_V]`.
    fn sampling(&mut self) -> PResult<Sampling> {
        let mut s = Sampling::default();
        if let Tok::Ident(w) = &self.peek().tok
            && let Some(f) = Filter::from_name(w)
        {
            s.filter = f;
            self.next();
        }
        if let Tok::Ident(w) = &self.peek().tok
            && let Some(u) = Wrap::from_name(w)
        {
            self.next();
            let (w, t) = self.ident("the v axis's wrap mode")?;
            let v = Wrap::from_name(&w).ok_or_else(|| Self::expected(&t, "a wrap mode"))?;
            s.wrap = [u, v];
        }
        Ok(s)
    }

    fn ray_type(&mut self) -> PResult<i32> {
        if self.eat_punct('#') {
            let t = self.next();
            let Tok::Num(text) = &t.tok else {
                return Err(Self::expected(&t, "a ray type code"));
            };
            return text
                .parse::<i32>()
                .map_err(|_| Self::err(&t, ParseErrorKind::BadNumber(text.clone())));
        }
        let (w, t) = self.ident("a ray type")?;
        ray_type_from_name(&w).ok_or_else(|| Self::err(&t, ParseErrorKind::UnknownRayType(w)))
    }

    fn space(&mut self) -> PResult<Space> {
        let (w, t) = self.ident("a space")?;
        Space::from_name(&w).ok_or_else(|| Self::err(&t, ParseErrorKind::UnknownSpace(w)))
    }

    /// A literal atom or a tuple of atoms (tuples do not nest).
    fn lit(&mut self) -> PResult<Lit> {
        let t = self.next();
        if t.tok == Tok::Punct('(') {
            let mut items = Vec::new();
            if !self.eat_punct(')') {
                loop {
                    let item = self.next();
                    items.push(self.atom(item)?);
                    if !self.eat_punct(',') {
                        self.expect_punct(')')?;
                        break;
                    }
                }
            }
            return Ok(Lit::Tuple(t, items));
        }
        self.atom(t)
    }

    fn atom(&mut self, t: Token) -> PResult<Lit> {
        match &t.tok {
            Tok::Num(_) | Tok::Str(_) => Ok(Lit::Atom(t)),
            Tok::Ident(w) if w == "nan" && self.is_punct('(') => {
                self.next();
                let bits = self.next();
                if !matches!(bits.tok, Tok::Num(_)) {
                    return Err(Self::expected(&bits, "the bits of a NaN (`0x…`)"));
                }
                self.expect_punct(')')?;
                Ok(Lit::NanBits(bits))
            }
            Tok::Ident(w) if matches!(w.as_str(), "true" | "false" | "inf" | "nan") => {
                Ok(Lit::Atom(t))
            }
            _ => Err(Self::expected(&t, "a constant")),
        }
    }

    /// Gives a literal its type.
    fn lit_value(&self, lit: &Lit, ty: Type) -> PResult<ConstValue> {
        let bad =
            |reason: String| Self::err(lit.token(), ParseErrorKind::BadLiteral { ty, reason });
        let atom_text = |lit: &Lit| match lit {
            Lit::Atom(t) => Some(t.tok.clone()),
            _ => None,
        };
        match ty {
            Type::Bool => match atom_text(lit) {
                Some(Tok::Ident(w)) if w == "true" => Ok(ConstValue::Bool(true)),
                Some(Tok::Ident(w)) if w == "false" => Ok(ConstValue::Bool(false)),
                _ => Err(bad("expected `true` or `false`".into())),
            },
            Type::Int => match atom_text(lit) {
                Some(Tok::Num(text)) => text
                    .parse::<i32>()
                    .map(ConstValue::Int)
                    .map_err(|_| bad(format!("`{text}` is not a 32-bit integer"))),
                _ => Err(bad("expected an integer".into())),
            },
            Type::String => match atom_text(lit) {
                Some(Tok::Str(s)) => Ok(ConstValue::String(s)),
                _ => Err(bad("expected a quoted string".into())),
            },
            Type::Closure(_) => Err(bad("closures have no constants in the IR".into())),
            Type::Float => Ok(ConstValue::Float(self.float(lit, ty)?)),
            Type::Vec2
            | Type::Vec3
            | Type::Color
            | Type::Vec4
            | Type::Color4
            | Type::Matrix33
            | Type::Matrix44 => {
                let Lit::Tuple(_, items) = lit else {
                    return Err(bad(format!("expected ({} floats)", ty.width())));
                };
                if items.len() != ty.width() {
                    return Err(bad(format!(
                        "expected {} components, found {}",
                        ty.width(),
                        items.len()
                    )));
                }
                let v = items
                    .iter()
                    .map(|x| self.float(x, ty))
                    .collect::<PResult<Vec<f64>>>()?;
                ConstValue::from_floats(ty, &v).ok_or_else(|| bad("wrong width".into()))
            }
        }
    }

    /// One float of a literal of type `ty`.
    fn float(&self, lit: &Lit, ty: Type) -> PResult<f64> {
        let bad =
            |t: &Token, reason: String| Self::err(t, ParseErrorKind::BadLiteral { ty, reason });
        match lit {
            Lit::Atom(t) => match &t.tok {
                Tok::Ident(w) if w == "inf" => Ok(f64::INFINITY),
                Tok::Ident(w) if w == "nan" => Ok(f64::from_bits(CANONICAL_NAN_BITS)),
                Tok::Num(text) if text == "-inf" => Ok(f64::NEG_INFINITY),
                Tok::Num(text) => {
                    let digits = text.strip_prefix('-').unwrap_or(text);
                    let ok = digits.starts_with(|c: char| c.is_ascii_digit());
                    ok.then(|| text.parse::<f64>().ok())
                        .flatten()
                        .ok_or_else(|| Self::err(t, ParseErrorKind::BadNumber(text.clone())))
                }
                _ => Err(bad(t, format!("expected a float, found {}", t.describe()))),
            },
            Lit::NanBits(t) => {
                let Tok::Num(text) = &t.tok else {
                    return Err(bad(t, "expected NaN bits".into()));
                };
                let bits = text
                    .strip_prefix("0x")
                    .and_then(|h| u64::from_str_radix(h, 16).ok())
                    .ok_or_else(|| Self::err(t, ParseErrorKind::BadNumber(text.clone())))?;
                let x = f64::from_bits(bits);
                if x.is_nan() {
                    Ok(x)
                } else {
                    Err(bad(t, format!("{text} is not the bits of a NaN")))
                }
            }
            Lit::Tuple(t, _) => Err(bad(t, "expected a float, found a list".into())),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::ir::{Builder, RAY_DIFFUSE, RAY_REFLECTION, RAY_REFRACTION, validate};

    // ---- helpers ----

    fn remap_block(b: &Block, m: &impl Fn(Value) -> Value) -> Block {
        Block {
            body: b.body.iter().map(|v| m(*v)).collect(),
            yields: b.yields.iter().map(|v| m(*v)).collect(),
        }
    }

    fn remap_op(op: &Op, m: &impl Fn(Value) -> Value) -> Op {
        let all = |vs: &[Value]| vs.iter().map(|v| m(*v)).collect::<Vec<_>>();
        match op {
            Op::Const(_)
            | Op::Param(_)
            | Op::Stream(_)
            | Op::ComponentEnabled(_)
            | Op::LightL
            | Op::LightCl
            | Op::LightVisible
            | Op::LightPdf
            | Op::LoopVar(_)
            | Op::AttributeFound { .. }
            | Op::Ambient => op.clone(),
            Op::Transform {
                kind,
                from,
                to,
                arg,
            } => Op::Transform {
                kind: *kind,
                from: *from,
                to: *to,
                arg: m(*arg),
            },
            Op::Unary(o, a) => Op::Unary(*o, m(*a)),
            Op::Binary(o, a, b) => Op::Binary(*o, m(*a), m(*b)),
            Op::Select { cond, a, b } => Op::Select {
                cond: m(*cond),
                a: m(*a),
                b: m(*b),
            },
            Op::Construct(args) => Op::Construct(all(args)),
            Op::Extract(a, i) => Op::Extract(m(*a), *i),
            Op::Splat(a) => Op::Splat(m(*a)),
            Op::Convert(a) => Op::Convert(m(*a)),
            Op::Call(i, args) => Op::Call(*i, all(args)),
            Op::If { cond, then_, else_ } => Op::If {
                cond: m(*cond),
                then_: remap_block(then_, m),
                else_: remap_block(else_, m),
            },
            Op::Illuminance { p, body } => Op::Illuminance {
                p: m(*p),
                body: remap_block(body, m),
            },
            Op::Probe {
                field,
                origin,
                dir,
                min_distance,
                max_distance,
            } => Op::Probe {
                field: *field,
                origin: m(*origin),
                dir: m(*dir),
                min_distance: m(*min_distance),
                max_distance: m(*max_distance),
            },
            Op::Print {
                severity,
                format,
                args,
            } => Op::Print {
                severity: *severity,
                format: format.clone(),
                args: all(args),
            },
            Op::Loop { init, cond, body } => Op::Loop {
                init: all(init),
                cond: remap_block(cond, m),
                body: remap_block(body, m),
            },
            Op::Proj(r, i) => Op::Proj(m(*r), *i),
            Op::Texture {
                texture,
                uv,
                derivs,
                sampling,
                alpha,
            } => Op::Texture {
                texture: *texture,
                uv: m(*uv),
                derivs: derivs.map(|d| d.map(m)),
                sampling: *sampling,
                alpha: *alpha,
            },
            Op::Attribute { slot, default } => Op::Attribute {
                slot: *slot,
                default: m(*default),
            },
            Op::Trace { dir, ray_type, pdf } => Op::Trace {
                dir: m(*dir),
                ray_type: *ray_type,
                pdf: pdf.map(m),
            },
            Op::Occlusion {
                n,
                samples,
                max_distance,
            } => Op::Occlusion {
                n: m(*n),
                samples: m(*samples),
                max_distance: m(*max_distance),
            },
        }
    }

    /// `p` with its values renumbered in text order; values in no block are dropped.
    fn canon(p: &Program) -> Program {
        let names = number_values(p);
        let m = |v: Value| match names.get(v.index()).copied().flatten() {
            Some(k) => Value::new(k as usize),
            None => v,
        };
        let mut exprs: Vec<Option<Expr>> = vec![None; names.iter().flatten().count()];
        for (e, k) in p.exprs.iter().zip(&names) {
            if let Some(k) = k {
                exprs[*k as usize] = Some(Expr {
                    op: remap_op(&e.op, &m),
                    ty: e.ty,
                });
            }
        }
        Program {
            name: p.name.clone(),
            exprs: exprs.into_iter().map(|e| e.expect("numbered")).collect(),
            prelude: remap_block(&p.prelude, &m),
            body: remap_block(&p.body, &m),
            textures: p.textures.clone(),
            attributes: p.attributes.clone(),
            outputs: p
                .outputs
                .iter()
                .map(|o| Output {
                    value: m(o.value),
                    ..o.clone()
                })
                .collect(),
            components: p.components.clone(),
            params: p.params.clone(),
        }
    }

    /// The bits of every float constant and parameter default, in arena order.
    fn float_bits(p: &Program) -> Vec<u64> {
        let consts = p.exprs.iter().filter_map(|e| match &e.op {
            Op::Const(c) => Some(c),
            _ => None,
        });
        consts
            .chain(p.params.iter().map(|d| &d.default))
            .flat_map(|c| c.floats().iter().map(|x| x.to_bits()))
            .collect()
    }

    fn zero_floats(c: &ConstValue) -> ConstValue {
        ConstValue::from_floats(c.ty(), &vec![0.0; c.floats().len()]).unwrap_or(c.clone())
    }

    /// `p` with every float constant replaced by 0 (so `==` works with NaNs).
    fn without_floats(p: &Program) -> Program {
        let mut q = p.clone();
        for e in &mut q.exprs {
            if let Op::Const(c) = &e.op {
                e.op = Op::Const(zero_floats(c));
            }
        }
        for d in &mut q.params {
            d.default = zero_floats(&d.default);
        }
        q
    }

    /// Equal up to renumbering, floats compared by their bits.
    fn assert_same(a: &Program, b: &Program) {
        let (a, b) = (canon(a), canon(b));
        assert_eq!(without_floats(&a), without_floats(&b));
        assert_eq!(float_bits(&a), float_bits(&b));
    }

    /// Prints, parses and prints again; checks both properties and returns the parse.
    fn round_trip(p: &Program) -> Program {
        let text = p.to_string();
        let q = parse(&text).unwrap_or_else(|e| panic!("{e}\n{text}"));
        assert_eq!(q.to_string(), text);
        assert_same(p, &q);
        // The parser numbers the arena in text order.
        assert_eq!(without_floats(&q), without_floats(&canon(&q)));
        q
    }

    fn err(src: &str) -> ParseError {
        match parse(src) {
            Ok(p) => panic!("parsed:\n{p}"),
            Err(e) => e,
        }
    }

    fn special_floats() -> Vec<f64> {
        vec![
            0.0,
            -0.0,
            1.0,
            -2.5,
            0.1,
            1e-7,
            1e300,
            123_456_789.123_456_79,
            f64::MAX,
            f64::MIN,
            f64::EPSILON,
            f64::MIN_POSITIVE,
            f64::MIN_POSITIVE / 3.0, // denormal
            f64::from_bits(1),       // smallest denormal
            -f64::from_bits(1),
            f32::MIN_POSITIVE as f64 / 2.0,
            f64::INFINITY,
            f64::NEG_INFINITY,
            f64::NAN,
            -f64::NAN,
            f64::from_bits(0x7ff0_0000_0000_0001), // signalling NaN
            f64::from_bits(0xfff8_0000_0000_1234),
        ]
    }

    /// A program with every op kind, nested regions, every stream, type, transform,
    /// unary, binary op and intrinsic, and names that need quoting.
    fn everything() -> Program {
        let mut b = Builder::new("every \"op\"\n\t\\ é 😀");
        let f = b.float(2.5);
        let i = b.int(-7);
        let t = b.boolean(true);
        let v2 = b.constant(ConstValue::Vec2([0.25, -1.5]));
        let v3 = b.vec3([1.0, 2.0, 3.0]);
        let c = b.color([0.5, 0.25, 0.125]);
        let m: Vec<f64> = (0..16).map(|k| k as f64 * 0.5 - 3.0).collect();
        let mat = b.constant(ConstValue::from_floats(Type::Matrix44, &m).unwrap());
        b.constant(ConstValue::identity());
        b.constant(ConstValue::String(
            "tex/\"marble\".png\n\t\\ é \u{1F600} \0 '".into(),
        ));
        b.constant(ConstValue::String(String::new()));
        b.boolean(false);
        b.int(i32::MIN);
        b.int(i32::MAX);
        let prm = b.push(Op::Param(0), Some(Type::Color));
        let pm = b.push(Op::Param(1), Some(Type::Matrix44));
        b.push(Op::Param(2), Some(Type::String));
        let streams: Vec<Value> = Stream::ALL.iter().map(|s| b.stream(*s)).collect();
        let pos = streams[0];
        for kind in XformKind::ALL {
            for from in Space::ALL {
                for to in Space::ALL {
                    let arg = pos;
                    b.push(
                        Op::Transform {
                            kind,
                            from,
                            to,
                            arg,
                        },
                        Some(Type::Vec3),
                    );
                }
            }
        }
        for op in UnOp::ALL {
            let a = match op {
                UnOp::Not => t,
                UnOp::Length | UnOp::Normalize => v3,
                UnOp::Neg | UnOp::Abs | UnOp::BitNot => i,
                _ => c,
            };
            b.unary(*op, a);
        }
        for op in BinOp::ALL {
            let (x, y) = match op {
                BinOp::MulPoint => (mat, pos),
                BinOp::MulVector => (pm, v3),
                BinOp::And | BinOp::Or => (t, t),
                BinOp::Dot | BinOp::Distance => (v2, v2),
                BinOp::Cross => (c, c),
                BinOp::Lt | BinOp::Le | BinOp::Gt | BinOp::Ge => (f, f),
                BinOp::Eq | BinOp::Ne => (i, i),
                BinOp::BitAnd | BinOp::BitOr | BinOp::BitXor | BinOp::Shl | BinOp::Shr => (i, i),
                BinOp::Pow | BinOp::Atan2 => (v3, v3),
                _ => (prm, c),
            };
            b.binary(*op, x, y);
        }
        let lt = b.binary(BinOp::Lt, f, f);
        b.select(lt, c, prm);
        let x = b.extract(v3, 0);
        let y = b.extract(c, 2);
        b.construct(Type::Vec2, &[x, y]);
        b.construct(Type::Vec3, &[x, y, f]);
        b.construct(Type::Color, &[f, f, f]);
        b.splat(Type::Vec2, f);
        b.splat(Type::Color, x);
        let fi = b.convert(Type::Int, f);
        b.convert(Type::Float, i);
        b.convert(Type::Bool, fi);
        b.convert(Type::Float, t);
        b.call(Intrinsic::Noise2, &[v2]);
        b.call(Intrinsic::Noise3, &[pos]);
        b.call(Intrinsic::Fbm3, &[pos, i, f, f]);
        b.call(Intrinsic::CellNoise3, &[pos]);
        let hsv = b.call(Intrinsic::RgbToHsv, &[c]);
        b.call(Intrinsic::HsvToRgb, &[hsv]);
        let uv = streams[4];
        let t0 = b.texture_index(&TextureFile::auto("tex/\"a\" é.png"));
        let t1 = b.texture_index(&TextureFile {
            path: "b.exr".into(),
            colorspace: ColorSpace::AcesCg,
        });
        b.push(
            Op::Texture {
                texture: t0,
                uv,
                derivs: None,
                sampling: Sampling::default(),
                alpha: false,
            },
            Some(Type::Color),
        );
        for (filter, wrap) in [
            (Filter::Closest, [Wrap::Clamp, Wrap::Mirror]),
            (Filter::Trilinear, [Wrap::Periodic; 2]),
            (Filter::Anisotropic, [Wrap::Black, Wrap::Periodic]),
        ] {
            b.push(
                Op::Texture {
                    texture: t1,
                    uv,
                    derivs: Some([v2, uv]),
                    sampling: Sampling { filter, wrap },
                    alpha: true,
                },
                Some(Type::Float),
            );
        }
        let diffuse = b.component_enabled("diffuse");
        let mine = b.component_enabled("my pass");
        // Nested ifs, with an empty region in the middle.
        let outer = b.if_(
            diffuse,
            |b| {
                let inner = b.if_(
                    mine,
                    |b| {
                        let k = b.float(-0.0);
                        let s = b.splat(Type::Color, k);
                        vec![s, k]
                    },
                    |b| {
                        let z = b.zero(Type::Color);
                        vec![z, x]
                    },
                );
                b.if_(t, |_| Vec::new(), |_| Vec::new());
                let sum = b.add(inner[0], c);
                vec![sum, inner[1]]
            },
            |b| {
                let n = b.float(f64::NAN);
                vec![prm, n]
            },
        );
        let n = streams[1];
        let samples = b.int(16);
        b.occlusion(n, samples, f);
        for ray_type in [RAY_REFLECTION, RAY_REFRACTION, RAY_DIFFUSE] {
            b.trace(n, ray_type);
        }
        let lit = b.illuminance(pos, |b, l, cl| {
            let vis = b.light_visible();
            let d = b.dot(n, l);
            let d = b.mul(d, vis);
            let zero = b.float(0.0);
            let front = b.binary(BinOp::Gt, d, zero);
            let shaded = b.if_(
                front,
                |b| {
                    let l2 = b.push(Op::LightL, Some(Type::Vec3));
                    let cl2 = b.push(Op::LightCl, Some(Type::Color));
                    let dd = b.dot(l2, n);
                    let s = b.splat(Type::Color, dd);
                    vec![b.mul(cl2, s)]
                },
                |_| vec![cl],
            );
            vec![shaded[0], d]
        });
        let amb = b.ambient();
        let total = b.add(lit[0], amb);
        let total = b.add(total, outer[0]);
        b.output("color", Some(0), total);
        b.output("color", Some(1), outer[0]);
        b.output("out alpha", None, lit[1]);
        b.output("_x.y2", None, outer[1]);
        let mut p = b.finish().expect("builds");
        p.params = vec![
            ParamDecl {
                name: "surf.color".into(),
                ty: Type::Color,
                default: ConstValue::Color([0.5, -0.0, f64::NAN]),
            },
            ParamDecl {
                name: "place \"xf\"".into(),
                ty: Type::Matrix44,
                default: ConstValue::identity(),
            },
            ParamDecl {
                name: "file".into(),
                ty: Type::String,
                default: ConstValue::String("a\\b.png".into()),
            },
        ];
        p
    }

    // ---- round trips ----

    #[test]
    fn everything_round_trips_and_validates() {
        let p = everything();
        validate(&p).unwrap();
        let q = round_trip(&p);
        validate(&q).unwrap();
        let text = p.to_string();
        for needle in [
            "program \"every \\\"op\\\"\\n\\t\\\\ é 😀\" {",
            "  components diffuse \"my pass\"\n",
            "param \"surf.color\" color = (0.5, -0.0, nan)",
            "component_enabled \"my pass\" : bool",
            "transform normal object -> camera %",
            "light.L : vec3",
            "light.Cl : color",
            "light.visible : float",
            "= trace reflection %",
            "= trace refraction %",
            "= trace diffuse %",
            "= occlusion %",
            "mulpoint %6, %",
            "call fbm3 %",
            "output color[diffuse] %",
            "output color[\"my pass\"] %",
            "output \"out alpha\" %",
            "output _x.y2 %",
            "} else {\n",
            "const -2147483648 : int",
            "const \"\" : string",
        ] {
            assert!(text.contains(needle), "no {needle:?} in\n{text}");
        }
        // Every op kind is in the text.
        for op in UnOp::ALL
            .iter()
            .map(|o| o.name())
            .chain(BinOp::ALL.iter().map(|o| o.name()))
        {
            assert!(text.contains(&format!(" = {op} %")), "no {op}");
        }
        for word in [
            "const",
            "param",
            "stream",
            "transform",
            "select",
            "construct",
            "extract",
            "splat",
            "convert",
            "call",
            "if",
            "illuminance",
            "ambient",
            "proj",
            "trace",
            "occlusion",
        ] {
            assert!(text.contains(&format!(" = {word} ")), "no {word}");
        }
    }

    #[test]
    fn values_are_numbered_in_text_order() {
        // The builder puts a region after its arms in the arena; the text numbers it first.
        let mut b = Builder::new("m");
        let t = b.boolean(true);
        let r = b.if_(t, |b| vec![b.float(1.0)], |b| vec![b.float(2.0)]);
        b.output("o", None, r[0]);
        let p = b.finish().unwrap();
        assert!(
            p.body.body[1].index() > 2,
            "the builder's region comes after its arms"
        );
        let expected = "program \"m\" {
  %0 = const true : bool
  %1 = if %0 {
    %2 = const 1.0 : float
    yield %2
  } else {
    %3 = const 2.0 : float
    yield %3
  }
  %4 = proj %1, 0 : float
  output o %4
}
";
        assert_eq!(p.to_string(), expected);
        let q = round_trip(&p);
        assert_eq!(q.body.body[1], Value::new(1));
    }

    #[test]
    fn floats_round_trip_bit_exactly() {
        let floats = special_floats();
        let mut b = Builder::new("floats");
        for x in &floats {
            b.float(*x);
            b.vec3([*x, -*x, 1.0]);
            b.constant(ConstValue::Vec2([1.0, *x]));
            b.color([*x, *x, *x]);
        }
        for chunk in floats.chunks(16) {
            let mut m = [0.5; 16];
            m[..chunk.len()].copy_from_slice(chunk);
            b.constant(ConstValue::Matrix44(m));
        }
        let mut p = b.finish().unwrap();
        for (k, x) in floats.iter().enumerate() {
            p.params.push(ParamDecl {
                name: format!("p{k}"),
                ty: Type::Float,
                default: ConstValue::Float(*x),
            });
        }
        let q = round_trip(&p);
        let bits: Vec<u64> = float_bits(&q);
        for x in &floats {
            assert!(bits.contains(&x.to_bits()), "{x:?} lost");
        }
        let text = p.to_string();
        assert!(text.contains("const -0.0 : float"));
        assert!(text.contains("const 5e-324 : float"));
        assert!(text.contains("const -inf : float"));
        assert!(text.contains("const nan : float"));
        assert!(text.contains("const nan(0xfff8000000000000) : float"));
        assert!(text.contains("const nan(0x7ff0000000000001) : float"));
    }

    #[test]
    fn float_literal_forms_parse() {
        let src = "program \"f\" {
  %0 = const (1, -0.0, 1E3) : vec3
  %1 = const nan(0x7ff0000000000002) : float
  %2 = const inf : float
  %3 = const -inf : float
  %4 = const 2.5e-3 : float
}";
        let p = parse(src).unwrap();
        let c = |k: usize| match &p.exprs[k].op {
            Op::Const(c) => c.floats().iter().map(|x| x.to_bits()).collect::<Vec<_>>(),
            _ => panic!(),
        };
        assert_eq!(
            c(0),
            [1.0f64.to_bits(), (-0.0f64).to_bits(), 1000.0f64.to_bits()]
        );
        assert_eq!(c(1), [0x7ff0_0000_0000_0002]);
        assert_eq!(c(2), [f64::INFINITY.to_bits()]);
        assert_eq!(c(3), [f64::NEG_INFINITY.to_bits()]);
        assert_eq!(c(4), [2.5e-3f64.to_bits()]);
    }

    #[test]
    fn labels_comments_and_layout_are_free() {
        let src = "; a filetest header
program \"m\" { components diffuse ; the components
  param \"k\" float = 1.0
  %x = param 0 : float   ; a comment
  %big_1 = if %c {
  } else { }
  %c = const true : bool
  output o %x
}";
        // `%c` is used before its definition.
        assert_eq!(err(src).kind, ParseErrorKind::UndefinedValue("c".into()));
        let src = src.replace("if %c", "if %x");
        let p = parse(&src).unwrap();
        assert_eq!(p.components, ["diffuse"]);
        assert_eq!(p.exprs.len(), 3);
        assert!(matches!(p.exprs[1].op, Op::If { .. }));
        assert_eq!(p.outputs[0].value, Value::new(0));
        assert_eq!(
            p.to_string(),
            "program \"m\" {
  components diffuse
  param \"k\" float = 1.0
  %0 = param 0 : float
  %1 = if %0 {
  } else {
  }
  %2 = const true : bool
  output o %0
}
"
        );
    }

    #[test]
    fn scene_queries_round_trip() {
        let src = "program \"glass\" {
  %0 = stream P : vec3
  %1 = stream N : vec3
  %2 = trace reflection %1 : color
  %3 = trace refraction %1 : color
  %4 = trace diffuse %1 : color
  %5 = const 16 : int
  %6 = const 1e30 : float
  %7 = occlusion %1, %5, %6 : float
  %8 = illuminance %0 {
    %9 = light.Cl : color
    %10 = light.visible : float
    %11 = splat %10 : color
    %12 = mul %9, %11 : color
    yield %12
  }
  %13 = proj %8, 0 : color
  output c %2
  output o %7
  output s %13
}
";
        let p = parse(src).unwrap();
        validate(&p).unwrap();
        assert_eq!(p.to_string(), src);
        assert_eq!(
            p.exprs[3].op,
            Op::Trace {
                dir: Value::new(1),
                ray_type: RAY_REFRACTION,
                pdf: None,
            }
        );
        assert_eq!(
            p.exprs[7].op,
            Op::Occlusion {
                n: Value::new(1),
                samples: Value::new(5),
                max_distance: Value::new(6)
            }
        );
        assert_eq!(p.exprs[10].op, Op::LightVisible);
        round_trip(&p);
        // Ray types by code: a named one prints by name, any other code as `#K`.
        let q = parse("program \"m\" {\n  %0 = stream N : vec3\n  %1 = trace #8 %0 : color\n  %2 = trace #-3 %0 : color\n  %3 = trace #6 %0 : color\n}\n").unwrap();
        let text = q.to_string();
        assert!(text.contains("= trace refraction %0"), "{text}");
        assert!(text.contains("= trace #-3 %0"), "{text}");
        assert!(text.contains("= trace #6 %0"), "{text}");
        round_trip(&q);
        assert!(validate(&q).is_err(), "ray type -3 cannot be traced");
        // Mistakes.
        let m = |body: &str| format!("program \"m\" {{\n  %0 = stream N : vec3\n  {body}\n}}\n");
        assert_eq!(
            at(&m("%1 = trace mirror %0 : color")),
            (3, 14, ParseErrorKind::UnknownRayType("mirror".into()))
        );
        assert_eq!(
            at(&m("%1 = trace #x %0 : color")),
            (
                3,
                15,
                ParseErrorKind::Expected {
                    expected: "a ray type code".into(),
                    found: "`x`".into()
                }
            )
        );
        assert_eq!(
            at(&m("%1 = trace #99999999999 %0 : color")),
            (3, 15, ParseErrorKind::BadNumber("99999999999".into()))
        );
        assert!(matches!(
            at(&m("%1 = occlusion %0, %0 : float")),
            (3, 25, ParseErrorKind::Expected { .. })
        ));
    }

    // ---- invalid programs print, and what prints parses back ----

    #[test]
    fn invalid_programs_round_trip_where_they_can() {
        let mut b = Builder::new("bad");
        let f = b.float(1.0);
        let en = b.component_enabled("diffuse");
        b.output("o", Some(0), f);
        let mut p = b.finish().unwrap();
        // A component index out of range, a repeated component name, an output component
        // past the end, a constant whose type disagrees, an untyped value, a typed region.
        p.exprs[en.index()].op = Op::ComponentEnabled(7);
        p.components.push("diffuse".into());
        let dup = p.body.body.len();
        let mut b2 = Builder::new("x");
        b2.push(Op::ComponentEnabled(1), Some(Type::Bool));
        p.exprs.push(b2.program().exprs[0].clone());
        p.body.body.push(Value::new(p.exprs.len() - 1));
        p.outputs[0].component = Some(9);
        p.exprs.push(Expr {
            op: Op::Const(ConstValue::Vec3([1.0, 2.0, 3.0])),
            ty: Some(Type::Color),
        });
        p.body.body.push(Value::new(p.exprs.len() - 1));
        p.exprs.push(Expr {
            op: Op::Unary(UnOp::Neg, f),
            ty: None,
        });
        p.body.body.push(Value::new(p.exprs.len() - 1));
        p.exprs.push(Expr {
            op: Op::Const(ConstValue::Int(3)),
            ty: None,
        });
        p.body.body.push(Value::new(p.exprs.len() - 1));
        p.exprs.push(Expr {
            op: Op::If {
                cond: en,
                then_: Block::default(),
                else_: Block::default(),
            },
            ty: Some(Type::Float),
        });
        p.body.body.push(Value::new(p.exprs.len() - 1));
        let text = p.to_string();
        for needle in [
            "component_enabled #7 : bool",
            &format!("%{dup} = component_enabled #1 : bool"),
            "output o[#9] %0",
            "const vec3 (1.0, 2.0, 3.0) : color",
            "= neg %0\n",
            "= const int 3\n",
            "} : float\n",
        ] {
            assert!(text.contains(needle), "no {needle:?} in\n{text}");
        }
        let q = parse(&text).unwrap();
        assert_eq!(q.to_string(), text);
        assert_same(&p, &q);
        assert!(validate(&q).is_err());
    }

    #[test]
    fn broken_structure_prints_without_looping() {
        let mut b = Builder::new("broken");
        let t = b.boolean(true);
        let r = b.if_(t, |b| vec![b.float(1.0)], |b| vec![b.float(2.0)]);
        let mut p = b.finish().unwrap();
        let region = match p.op(r[0]) {
            Op::Proj(region, _) => *region,
            _ => unreachable!(),
        };
        // The region lists itself, a handle past the arena, and an operand in no block.
        if let Op::If { then_, .. } = &mut p.exprs[region.index()].op {
            then_.body.push(region);
            then_.body.push(Value::new(99));
        }
        p.exprs.push(Expr {
            op: Op::Unary(UnOp::Neg, t),
            ty: Some(Type::Bool),
        });
        p.exprs.push(Expr {
            op: Op::Unary(UnOp::Neg, Value::new(p.exprs.len() - 1)),
            ty: Some(Type::Bool),
        });
        p.body.body.push(Value::new(p.exprs.len() - 1));
        let text = p.to_string();
        assert!(
            text.contains("; error: %1 (v3) is listed again here"),
            "{text}"
        );
        assert!(text.contains("; error: v99 is not in the arena"), "{text}");
        assert!(text.contains("= neg %v5 : bool"), "{text}");
        assert_eq!(err(&text).kind, ParseErrorKind::UndefinedValue("v5".into()));
    }

    // ---- parse errors ----

    fn at(src: &str) -> (usize, usize, ParseErrorKind) {
        let e = err(src);
        (e.line, e.column, e.kind)
    }

    #[test]
    fn prints_and_probes_round_trip() {
        let probe = "program \"m\" {\n  %0 = stream P : vec3\n  %1 = stream N : vec3\n  %2 = const 0.0 : float\n  %3 = probe hitdist %0, %1, %2, %2 : float\n  %4 = probe Ng %0, %1, %2, %2 : vec3\n}\n";
        let q = parse(probe).unwrap();
        assert!(matches!(
            q.exprs[4].op,
            Op::Probe {
                field: ProbeField::Ng,
                ..
            }
        ));
        round_trip(&q);
        let src = "program \"m\" {\n  %0 = stream P : vec3\n  %1 = printf \"P = %g \\\"%%\\\"\\n\", %0 : int\n  %2 = warning \"plain\" : int\n  %3 = error \"%d %g\", %1, %0 : int\n}\n";
        let p = parse(src).unwrap();
        assert_eq!(
            p.exprs[1].op,
            Op::Print {
                severity: Severity::Printf,
                format: "P = %g \"%%\"\n".into(),
                args: vec![Value::new(0)],
            }
        );
        assert!(
            matches!(p.exprs[2].op, Op::Print { severity: Severity::Warning, ref args, .. } if args.is_empty())
        );
        round_trip(&p);
        let (line, _, kind) = at("program \"m\" {\n  %0 = printf %1 : int\n}\n");
        assert_eq!(line, 2);
        assert!(
            matches!(&kind, ParseErrorKind::Expected { expected, .. } if expected == "a format (a quoted string)"),
            "{kind:?}"
        );
    }

    #[test]
    fn unknown_op() {
        let src = "program \"m\" {\n  %0 = const 1.0 : float\n  %1 = frobnicate %0 : float\n}\n";
        assert_eq!(
            at(src),
            (3, 8, ParseErrorKind::UnknownOp("frobnicate".into()))
        );
        let e = err(src);
        assert_eq!(e.to_string(), "line 3, column 8: unknown op `frobnicate`");
    }

    #[test]
    fn bad_type() {
        let src = "program \"m\" {\n  %0 = const 1.0 : flaot\n}\n";
        assert_eq!(
            at(src),
            (2, 20, ParseErrorKind::UnknownType("flaot".into()))
        );
        let src = "program \"m\" {\n  param \"p\" colour = 1.0\n}\n";
        assert_eq!(
            at(src),
            (2, 13, ParseErrorKind::UnknownType("colour".into()))
        );
        let src = "program \"m\" {\n  %0 = const 1.0 : 3\n}\n";
        assert!(matches!(at(src), (2, 20, ParseErrorKind::Expected { .. })));
    }

    #[test]
    fn undefined_value() {
        let src = "program \"m\" {\n  %0 = const 1.0 : float\n  %1 = neg %7 : float\n}\n";
        assert_eq!(at(src), (3, 12, ParseErrorKind::UndefinedValue("7".into())));
        // An output reads an undefined value.
        let src = "program \"m\" {\n  output o %0\n}\n";
        assert_eq!(at(src), (2, 12, ParseErrorKind::UndefinedValue("0".into())));
        // A region's arm reads the region itself.
        let src = "program \"m\" {\n  %0 = const true : bool\n  %1 = if %0 {\n    %2 = proj %1, 0 : float\n  } else {\n  }\n}\n";
        assert_eq!(at(src), (4, 15, ParseErrorKind::UndefinedValue("1".into())));
    }

    #[test]
    fn value_out_of_scope() {
        let src = "program \"m\" {
  %0 = const true : bool
  %1 = if %0 {
    %2 = const 1.0 : float
    yield %2
  } else {
    %3 = neg %2 : float
    yield %3
  }
}
";
        let want = ParseErrorKind::NotVisible {
            name: "2".into(),
            line: 4,
        };
        assert_eq!(at(src), (7, 14, want));
    }

    #[test]
    fn redefined_value() {
        let src = "program \"m\" {\n  %0 = const 1.0 : float\n  %0 = const 2.0 : float\n}\n";
        let want = ParseErrorKind::Redefined {
            name: "0".into(),
            line: 2,
        };
        assert_eq!(at(src), (3, 3, want));
        // Reused inside the region it names.
        let src = "program \"m\" {\n  %0 = const true : bool\n  %1 = if %0 {\n    %1 = const 1.0 : float\n  } else {\n  }\n}\n";
        let want = ParseErrorKind::Redefined {
            name: "1".into(),
            line: 4,
        };
        assert_eq!(at(src), (3, 3, want));
    }

    #[test]
    fn missing_brace() {
        let src = "program \"m\" {\n  %0 = const true : bool\n  %1 = if %0 {\n    %2 = const 1.0 : float\n";
        let want = ParseErrorKind::Expected {
            expected: "`}`".into(),
            found: "end of input".into(),
        };
        assert_eq!(at(src), (5, 1, want));
        let src = "program \"m\" {\n  %0 = stream P : vec3\n  %1 = illuminance %0\n    %2 = light.L : vec3\n  }\n}\n";
        let want = ParseErrorKind::Expected {
            expected: "`{`".into(),
            found: "`%2`".into(),
        };
        assert_eq!(at(src), (4, 5, want));
        let src = "program \"m\" \n  %0 = stream P : vec3\n}\n";
        assert!(matches!(at(src), (2, 3, ParseErrorKind::Expected { .. })));
        let src = "program \"m\" {\n}\n}\n";
        assert!(matches!(at(src), (3, 1, ParseErrorKind::Expected { .. })));
    }

    #[test]
    fn bad_names() {
        let m = |body: &str| format!("program \"m\" {{\n  components diffuse\n  {body}\n}}\n");
        let cases = [
            (
                "%0 = stream Q : vec3",
                15,
                ParseErrorKind::UnknownStream("Q".into()),
            ),
            (
                "%0 = transform point wrld -> camera %0 : vec3",
                24,
                ParseErrorKind::UnknownSpace("wrld".into()),
            ),
            (
                "%0 = transform pointy world -> camera %0 : vec3",
                18,
                ParseErrorKind::UnknownXformKind("pointy".into()),
            ),
            (
                "%0 = call noise4 : float",
                13,
                ParseErrorKind::UnknownIntrinsic("noise4".into()),
            ),
            (
                "%0 = component_enabled specular : bool",
                26,
                ParseErrorKind::UnknownComponent("specular".into()),
            ),
            (
                "%0 = extract %0, 300 : float",
                16,
                ParseErrorKind::UndefinedValue("0".into()),
            ),
            (
                "%0 = param -1 : float",
                14,
                ParseErrorKind::BadNumber("-1".into()),
            ),
            (
                "%0 = proj %0, 999 : float",
                13,
                ParseErrorKind::UndefinedValue("0".into()),
            ),
            (
                "%0 = const 1.0 @ float",
                18,
                ParseErrorKind::UnexpectedChar('@'),
            ),
            ("%0 = const \"abc", 14, ParseErrorKind::UnterminatedString),
            (
                "%0 = const \"a\\qb\" : string",
                16,
                ParseErrorKind::BadEscape("\\q".into()),
            ),
            (
                "%0 = const \"\\u{110000}\" : string",
                15,
                ParseErrorKind::BadEscape("\\u{110000}".into()),
            ),
        ];
        for (body, col, kind) in cases {
            assert_eq!(at(&m(body)), (3, col, kind), "{body}");
        }
        // A repeated component name parses (the validator rejects it); references by name
        // go to the first.
        let dup = "program \"m\" {\n  components diffuse \"diffuse\"\n  %0 = component_enabled diffuse : bool\n  %1 = component_enabled #1 : bool\n}\n";
        let p = parse(dup).unwrap();
        assert_eq!(p.components, ["diffuse", "diffuse"]);
        assert_eq!(p.exprs[0].op, Op::ComponentEnabled(0));
        assert_eq!(p.exprs[1].op, Op::ComponentEnabled(1));
        // Quoting an identifier is allowed; the printer writes it bare.
        assert_eq!(p.to_string(), dup.replace("\"diffuse\"", "diffuse"));
    }

    #[test]
    fn bad_literals() {
        let m = |body: &str| format!("program \"m\" {{\n  {body}\n}}\n");
        let lit = |body: &str| match at(&m(body)) {
            (2, col, ParseErrorKind::BadLiteral { ty, .. }) => (col, ty),
            other => panic!("{body}: {other:?}"),
        };
        assert_eq!(lit("%0 = const (1.0, 2.0) : vec3"), (14, Type::Vec3));
        assert_eq!(lit("%0 = const 1.0 : vec3"), (14, Type::Vec3));
        assert_eq!(lit("%0 = const (1.0, true) : vec2"), (20, Type::Vec2));
        assert_eq!(lit("%0 = const 1.5 : int"), (14, Type::Int));
        assert_eq!(lit("%0 = const 3000000000 : int"), (14, Type::Int));
        assert_eq!(lit("%0 = const 1 : bool"), (14, Type::Bool));
        assert_eq!(lit("%0 = const 1.0 : string"), (14, Type::String));
        assert_eq!(
            lit("%0 = const nan(0x3ff0000000000000) : float"),
            (18, Type::Float)
        );
        assert_eq!(lit("param \"p\" color = vec3 (1.0, 2.0)"), (26, Type::Vec3));
        assert_eq!(
            at(&m("%0 = const 1.0")),
            (2, 14, ParseErrorKind::UntypedConst)
        );
        assert_eq!(
            at(&m("%0 = const 1.0x : float")),
            (2, 14, ParseErrorKind::BadNumber("1.0x".into()))
        );
        assert!(matches!(
            at(&m("%0 = const ((1.0)) : float")),
            (2, 15, ParseErrorKind::Expected { .. })
        ));
    }

    #[test]
    fn statements_out_of_place() {
        let src = "program \"m\" {\n  %0 = const true : bool\n  %1 = if %0 {\n    yield %0\n    %2 = const 1.0 : float\n  } else {\n  }\n}\n";
        let want = ParseErrorKind::Expected {
            expected: "`}` after `yield`".into(),
            found: "`%2`".into(),
        };
        assert_eq!(at(src), (5, 5, want));
        // `output` is a top-level statement only.
        let src = "program \"m\" {\n  %0 = const true : bool\n  %1 = if %0 {\n    output o %0\n  } else {\n  }\n}\n";
        assert!(matches!(at(src), (4, 5, ParseErrorKind::Expected { .. })));
        let src = "";
        assert!(matches!(at(src), (1, 1, ParseErrorKind::Expected { .. })));
    }

    #[test]
    fn deep_nesting_is_an_error_not_a_crash() {
        let mut src = String::from("program \"m\" {\n%c = const true : bool\n");
        for k in 0..10_000 {
            src.push_str(&format!("%r{k} = if %c {{\n"));
        }
        // Half the default test-thread stack: the limit must bite well before the stack
        // runs out, even in a debug build.
        let e = std::thread::Builder::new()
            .stack_size(1024 * 1024)
            .spawn(move || err(&src))
            .unwrap()
            .join()
            .unwrap();
        assert_eq!(e.kind, ParseErrorKind::TooDeep(MAX_DEPTH));
        // Reported at the first token of the block one level too deep.
        assert_eq!(e.line, MAX_DEPTH + 3);
    }

    #[test]
    fn mangled_text_never_panics() {
        // Every prefix, and the text with each character removed or replaced, parses or
        // fails with a position inside the text.
        let mut b = Builder::new("m");
        let t = b.boolean(true);
        let pos = b.stream(Stream::P);
        let r = b.if_(t, |b| vec![b.float(-0.0)], |b| vec![b.float(f64::NAN)]);
        let s = b.illuminance(pos, |_, _, cl| vec![cl]);
        let c = b.construct(Type::Vec3, &[r[0], r[0], r[0]]);
        let m = b.constant(ConstValue::identity());
        let x = b.binary(BinOp::MulPoint, m, c);
        b.output("o", Some(b.program().components.len() as u8), x);
        b.output("o s", None, s[0]);
        let mut p = b.finish().unwrap();
        p.components.push("diffuse".into());
        p.params.push(ParamDecl {
            name: "n".into(),
            ty: Type::String,
            default: ConstValue::String("é\"\\".into()),
        });
        let text = p.to_string();
        let lines = text.lines().count() + 1;
        let check = |src: &str| {
            if let Err(e) = parse(src) {
                assert!(e.line >= 1 && e.line <= lines && e.column >= 1, "{e}");
            }
        };
        let cuts: Vec<usize> = text.char_indices().map(|(i, _)| i).collect();
        for (k, &i) in cuts.iter().enumerate() {
            check(&text[..i]);
            let next = cuts.get(k + 1).copied().unwrap_or(text.len());
            for with in ["", "%", "\"", "(", "}", "-", "9", "\\"] {
                check(&format!("{}{with}{}", &text[..i], &text[next..]));
            }
        }
    }
}
