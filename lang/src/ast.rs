//! The abstract syntax tree of both dialects, as written: every node carries the [`Span`]
//! of its source text, types keep their qualifiers (`uniform`, `varying`, `output`,
//! `closure`) and space names stay strings. Nothing here is resolved or typed: the checker
//! does that, and it is also where dialect rules that the grammar does not need are enforced
//! (RSL has no `int` but it parses; `imager` shaders parse and are refused there; a tuple
//! `(a, b, c)` is a point or color only where the checker expects one).
//!
//! Shape: a [`File`] is a list of [`Item`]s (shaders, functions, OSL structs). Shaders and
//! functions have [`Param`]s and a body [`Block`] of [`Stmt`]s; [`Expr`]s are trees of
//! boxed nodes.

use crate::source::Span;

/// A name as written.
#[derive(Clone, Debug, PartialEq)]
pub struct Ident {
    /// The name.
    pub name: String,
    /// Where.
    pub span: Span,
}

/// A parsed source file (after preprocessing: items from included files are here too).
#[derive(Clone, Debug, PartialEq)]
pub struct File {
    /// The definitions, in order.
    pub items: Vec<Item>,
}

/// A top-level definition.
#[derive(Clone, Debug, PartialEq)]
pub enum Item {
    /// A shader.
    Shader(ShaderDef),
    /// A user function.
    Function(FunctionDef),
    /// An OSL `struct`.
    Struct(StructDef),
}

/// The kind of a shader.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ShaderKind {
    /// `surface` (both).
    Surface,
    /// `light` (RSL).
    Light,
    /// `volume` (both).
    Volume,
    /// `displacement` (both).
    Displacement,
    /// `imager` (RSL; parsed, refused by the checker).
    Imager,
    /// `shader` (OSL's generic kind).
    Shader,
}

/// `surface plastic(float Ks = .5; …) { … }`.
#[derive(Clone, Debug, PartialEq)]
pub struct ShaderDef {
    /// Its kind.
    pub kind: ShaderKind,
    /// Where the kind keyword is.
    pub kind_span: Span,
    /// Its name.
    pub name: Ident,
    /// OSL metadata after the name.
    pub metadata: Vec<Metadata>,
    /// Instance parameters.
    pub params: Vec<Param>,
    /// The body.
    pub body: Block,
    /// The whole definition.
    pub span: Span,
}

/// `float f(float x; output float y) { … }`.
#[derive(Clone, Debug, PartialEq)]
pub struct FunctionDef {
    /// The return type.
    pub ret: Type,
    /// Its name.
    pub name: Ident,
    /// Its parameters.
    pub params: Vec<Param>,
    /// The body.
    pub body: Block,
    /// The whole definition.
    pub span: Span,
}

/// OSL `struct Name { float a; color b[2]; };`.
#[derive(Clone, Debug, PartialEq)]
pub struct StructDef {
    /// Its name.
    pub name: Ident,
    /// Field declarations (initialisers are refused by the parser).
    pub fields: Vec<Decl>,
    /// The whole definition.
    pub span: Span,
}

/// A shader or function parameter. In RSL `float a = 1, b = 2;` gives two parameters of
/// the same [`Type`] (equal spans).
#[derive(Clone, Debug, PartialEq)]
pub struct Param {
    /// The declared type, with qualifiers.
    pub ty: Type,
    /// The name.
    pub name: Ident,
    /// `[N]` or `[]` after the name.
    pub array: Option<ArrayLen>,
    /// `= expr`: shader parameters' defaults (may use earlier parameters).
    pub default: Option<Expr>,
    /// OSL `[[ … ]]` after it.
    pub metadata: Vec<Metadata>,
    /// From the type (or the name, for a name sharing an earlier type) to the end.
    pub span: Span,
}

/// One OSL metadata entry `string help = "…"` inside `[[ … ]]`.
#[derive(Clone, Debug, PartialEq)]
pub struct Metadata {
    /// Its type.
    pub ty: Type,
    /// Its name.
    pub name: Ident,
    /// Its value.
    pub value: Expr,
    /// The entry.
    pub span: Span,
}

/// The size in `name[N]` / `name[]`.
#[derive(Clone, Debug, PartialEq)]
pub struct ArrayLen {
    /// `N` (a constant expression the checker evaluates), or `None` for `[]`.
    pub len: Option<Box<Expr>>,
    /// The brackets and what is between them.
    pub span: Span,
}

/// A value's rate as written.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Rate {
    /// `uniform`.
    Uniform,
    /// `varying`.
    Varying,
}

/// A base type name.
#[derive(Clone, Debug, PartialEq)]
pub enum BaseType {
    /// `float`.
    Float,
    /// `int`.
    Int,
    /// `point`.
    Point,
    /// `vector`.
    Vector,
    /// `normal`.
    Normal,
    /// `color`.
    Color,
    /// `matrix`.
    Matrix,
    /// `string`.
    String,
    /// `void`.
    Void,
    /// An OSL struct's name.
    Struct(Ident),
}

/// A type as written: qualifiers, `closure`, base type. Array sizes belong to the declared
/// name ([`Param::array`], [`VarDecl::array`]) as in C.
#[derive(Clone, Debug, PartialEq)]
pub struct Type {
    /// `output`, where written.
    pub output: Option<Span>,
    /// `extern` (RSL, in functions), where written.
    pub external: Option<Span>,
    /// `uniform` / `varying`, where written.
    pub rate: Option<(Rate, Span)>,
    /// OSL `closure`, where written (then the base is `color`).
    pub closure: Option<Span>,
    /// The base type.
    pub base: BaseType,
    /// Where the base type name is.
    pub base_span: Span,
    /// Qualifiers and base.
    pub span: Span,
}

/// `{ … }`.
#[derive(Clone, Debug, PartialEq)]
pub struct Block {
    /// The statements.
    pub stmts: Vec<Stmt>,
    /// Braces included.
    pub span: Span,
}

/// A declaration of locals: `float a = 1, b[3];`.
#[derive(Clone, Debug, PartialEq)]
pub struct Decl {
    /// The shared type.
    pub ty: Type,
    /// The names.
    pub vars: Vec<VarDecl>,
    /// The whole declaration.
    pub span: Span,
}

/// One name of a [`Decl`].
#[derive(Clone, Debug, PartialEq)]
pub struct VarDecl {
    /// The name.
    pub name: Ident,
    /// `[N]`.
    pub array: Option<ArrayLen>,
    /// `= expr` (an [`ExprKind::InitList`] for arrays).
    pub init: Option<Expr>,
    /// Name to the end of the initialiser.
    pub span: Span,
}

/// A statement.
#[derive(Clone, Debug, PartialEq)]
pub struct Stmt {
    /// What it is.
    pub kind: StmtKind,
    /// The whole statement.
    pub span: Span,
}

/// The first clause of a `for`.
#[derive(Clone, Debug, PartialEq)]
pub enum ForInit {
    /// `for (;…`.
    None,
    /// `for (float i = 0;…`.
    Decl(Decl),
    /// `for (i = 0, j = 1;…`.
    Exprs(Vec<Expr>),
}

/// The statement forms.
#[derive(Clone, Debug, PartialEq)]
pub enum StmtKind {
    /// `{ … }`.
    Block(Block),
    /// A declaration of locals.
    Decl(Decl),
    /// `expr;`.
    Expr(Expr),
    /// `;`.
    Empty,
    /// `if (cond) then else els`.
    If {
        /// The condition.
        cond: Expr,
        /// Taken when true.
        then: Box<Stmt>,
        /// Taken when false.
        els: Option<Box<Stmt>>,
    },
    /// `for (init; cond; step) body`.
    For {
        /// The first clause.
        init: ForInit,
        /// The test (absent: forever).
        cond: Option<Expr>,
        /// The step expressions, comma-separated.
        step: Vec<Expr>,
        /// The body.
        body: Box<Stmt>,
    },
    /// `while (cond) body`.
    While {
        /// The test.
        cond: Expr,
        /// The body.
        body: Box<Stmt>,
    },
    /// OSL `do body while (cond);`.
    DoWhile {
        /// The body.
        body: Box<Stmt>,
        /// The test.
        cond: Expr,
    },
    /// `break;`, or RSL's `break N;` leaving `N` nested loops (`levels`, 1 when not written).
    Break {
        /// How many enclosing loops it leaves (at least 1).
        levels: u32,
    },
    /// `continue;`, or RSL's `continue N;` continuing the `N`th enclosing loop.
    Continue {
        /// Which enclosing loop continues (1: the innermost).
        levels: u32,
    },
    /// `return;` / `return expr;`.
    Return(Option<Expr>),
    /// RSL `illuminance([category,] P [, N, angle]) body`.
    Illuminance {
        /// The optional leading category string.
        category: Option<Expr>,
        /// `P` or `P, N, angle`.
        args: Vec<Expr>,
        /// The body.
        body: Box<Stmt>,
    },
    /// RSL `illuminate(P [, axis, angle]) body`.
    Illuminate {
        /// `P` or `P, axis, angle`.
        args: Vec<Expr>,
        /// The body.
        body: Box<Stmt>,
    },
    /// RSL `solar([axis, angle]) body`.
    Solar {
        /// Empty or `axis, angle`.
        args: Vec<Expr>,
        /// The body.
        body: Box<Stmt>,
    },
}

/// An expression.
#[derive(Clone, Debug, PartialEq)]
pub struct Expr {
    /// What it is.
    pub kind: ExprKind,
    /// Its whole text.
    pub span: Span,
}

/// Prefix operators.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum UnaryOp {
    /// `-x`.
    Neg,
    /// `+x`.
    Plus,
    /// `!x`.
    Not,
    /// `~x` (OSL: bitwise complement).
    BitNot,
}

/// Binary operators. Which token means which depends on the dialect (see
/// [`crate::parse::expr::precedence`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum BinaryOp {
    /// `*`.
    Mul,
    /// `/`.
    Div,
    /// `%`.
    Rem,
    /// `+`.
    Add,
    /// `-`.
    Sub,
    /// RSL `.`: dot product.
    Dot,
    /// RSL `^`: cross product.
    Cross,
    /// `<<`.
    Shl,
    /// `>>`.
    Shr,
    /// `<`.
    Lt,
    /// `<=`.
    Le,
    /// `>`.
    Gt,
    /// `>=`.
    Ge,
    /// `==`.
    Eq,
    /// `!=`.
    Ne,
    /// `&`.
    BitAnd,
    /// OSL `^`: bitwise xor.
    BitXor,
    /// `|`.
    BitOr,
    /// `&&`.
    And,
    /// `||`.
    Or,
}

/// `=` and the compound assignments.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum AssignOp {
    /// `=`.
    Set,
    /// `+=`.
    Add,
    /// `-=`.
    Sub,
    /// `*=`.
    Mul,
    /// `/=`.
    Div,
    /// `%=`.
    Rem,
    /// `&=`.
    BitAnd,
    /// `|=`.
    BitOr,
    /// `^=`.
    BitXor,
    /// `<<=`.
    Shl,
    /// `>>=`.
    Shr,
}

/// The expression forms.
#[derive(Clone, Debug, PartialEq)]
pub enum ExprKind {
    /// An integer literal.
    Int(i64),
    /// A floating-point literal.
    Float(f64),
    /// A string literal (adjacent literals joined), escapes decoded.
    Str(String),
    /// A name.
    Ident(Ident),
    /// `f(args)`, including builtins such as `texture("file", s, t)`.
    Call {
        /// The function's name.
        callee: Ident,
        /// The arguments.
        args: Vec<Expr>,
    },
    /// `point "object" (1, 2, 3)`, `color (1)`, `matrix "shader" 1`, RSL `float x`: a type
    /// name, an optional space-name string, then either parenthesised arguments or one
    /// unary expression (`parens` says which).
    Construct {
        /// The type named.
        ty: BaseType,
        /// Where the type name is.
        ty_span: Span,
        /// The space name (`"object"`, `"hsv"`…) and its span.
        space: Option<(String, Span)>,
        /// The components or the value.
        args: Vec<Expr>,
        /// Whether the arguments were in parentheses.
        parens: bool,
    },
    /// `(a, b, c)`: an RSL triple (the checker makes it a point or color where one is
    /// expected).
    Tuple(Vec<Expr>),
    /// `(float) x`.
    Cast {
        /// The target type.
        ty: BaseType,
        /// Where the type name is.
        ty_span: Span,
        /// The operand.
        expr: Box<Expr>,
    },
    /// A prefix operator.
    Unary {
        /// Which.
        op: UnaryOp,
        /// The operand.
        operand: Box<Expr>,
    },
    /// A binary operator.
    Binary {
        /// Which.
        op: BinaryOp,
        /// Left operand.
        lhs: Box<Expr>,
        /// Right operand.
        rhs: Box<Expr>,
    },
    /// `cond ? then : els`.
    Ternary {
        /// The condition.
        cond: Box<Expr>,
        /// Value when true.
        then: Box<Expr>,
        /// Value when false.
        els: Box<Expr>,
    },
    /// `target op= value` (an expression, as in C).
    Assign {
        /// Which.
        op: AssignOp,
        /// What is assigned (the checker requires a place).
        target: Box<Expr>,
        /// The value.
        value: Box<Expr>,
    },
    /// `++x`, `x++`, `--x`, `x--`.
    IncDec {
        /// `++` when true, `--` when false.
        increment: bool,
        /// Prefix when true.
        prefix: bool,
        /// The operand.
        target: Box<Expr>,
    },
    /// `a[i]`.
    Index {
        /// The array or component-indexed value.
        base: Box<Expr>,
        /// The index.
        index: Box<Expr>,
    },
    /// OSL `a.field`.
    Member {
        /// The struct (or point/color, for `.x`/`.r` where OSL allows it).
        base: Box<Expr>,
        /// The field name.
        field: Ident,
    },
    /// `{ a, b, c }` (array initialisers).
    InitList(Vec<Expr>),
}
