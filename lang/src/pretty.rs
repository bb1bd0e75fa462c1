//! Printing the AST back as source, with every operator application parenthesised: `a + b *
//! c` prints `(a + (b * c))`, so tests (and the lead's `--emit ast`) see exactly how the
//! parser grouped an expression. Statements print on one line, items with their bodies.

use crate::ast::*;
use std::fmt::{self, Display, Formatter, Write};

fn list<T: Display>(f: &mut Formatter<'_>, items: &[T], sep: &str) -> fmt::Result {
    for (i, x) in items.iter().enumerate() {
        if i > 0 {
            f.write_str(sep)?;
        }
        write!(f, "{x}")?;
    }
    Ok(())
}

impl UnaryOp {
    /// The operator's spelling.
    pub fn as_str(self) -> &'static str {
        match self {
            UnaryOp::Neg => "-",
            UnaryOp::Plus => "+",
            UnaryOp::Not => "!",
            UnaryOp::BitNot => "~",
        }
    }
}

impl BinaryOp {
    /// The operator's spelling (`.` and `^` for RSL's dot and cross products; `^` for OSL's
    /// xor too).
    pub fn as_str(self) -> &'static str {
        match self {
            BinaryOp::Mul => "*",
            BinaryOp::Div => "/",
            BinaryOp::Rem => "%",
            BinaryOp::Add => "+",
            BinaryOp::Sub => "-",
            BinaryOp::Dot => ".",
            BinaryOp::Cross => "^",
            BinaryOp::Shl => "<<",
            BinaryOp::Shr => ">>",
            BinaryOp::Lt => "<",
            BinaryOp::Le => "<=",
            BinaryOp::Gt => ">",
            BinaryOp::Ge => ">=",
            BinaryOp::Eq => "==",
            BinaryOp::Ne => "!=",
            BinaryOp::BitAnd => "&",
            BinaryOp::BitXor => "^",
            BinaryOp::BitOr => "|",
            BinaryOp::And => "&&",
            BinaryOp::Or => "||",
        }
    }
}

impl AssignOp {
    /// The operator's spelling.
    pub fn as_str(self) -> &'static str {
        match self {
            AssignOp::Set => "=",
            AssignOp::Add => "+=",
            AssignOp::Sub => "-=",
            AssignOp::Mul => "*=",
            AssignOp::Div => "/=",
            AssignOp::Rem => "%=",
            AssignOp::BitAnd => "&=",
            AssignOp::BitOr => "|=",
            AssignOp::BitXor => "^=",
            AssignOp::Shl => "<<=",
            AssignOp::Shr => ">>=",
        }
    }
}

impl Display for BaseType {
    fn fmt(&self, f: &mut Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            BaseType::Float => "float",
            BaseType::Int => "int",
            BaseType::Point => "point",
            BaseType::Vector => "vector",
            BaseType::Normal => "normal",
            BaseType::Color => "color",
            BaseType::Matrix => "matrix",
            BaseType::String => "string",
            BaseType::Void => "void",
            BaseType::Struct(n) => &n.name,
        })
    }
}

impl Display for Type {
    fn fmt(&self, f: &mut Formatter<'_>) -> fmt::Result {
        if self.output.is_some() {
            f.write_str("output ")?;
        }
        if self.external.is_some() {
            f.write_str("extern ")?;
        }
        match self.rate {
            Some((Rate::Uniform, _)) => f.write_str("uniform ")?,
            Some((Rate::Varying, _)) => f.write_str("varying ")?,
            None => {}
        }
        if self.closure.is_some() {
            f.write_str("closure ")?;
        }
        write!(f, "{}", self.base)
    }
}

impl Display for ArrayLen {
    fn fmt(&self, f: &mut Formatter<'_>) -> fmt::Result {
        match &self.len {
            Some(n) => write!(f, "[{n}]"),
            None => f.write_str("[]"),
        }
    }
}

impl Display for Expr {
    fn fmt(&self, f: &mut Formatter<'_>) -> fmt::Result {
        match &self.kind {
            ExprKind::Int(v) => write!(f, "{v}"),
            ExprKind::Float(v) => write!(f, "{v:?}"),
            ExprKind::Str(s) => write!(f, "{s:?}"),
            ExprKind::Ident(n) => f.write_str(&n.name),
            ExprKind::Call { callee, args } => {
                write!(f, "{}(", callee.name)?;
                list(f, args, ", ")?;
                f.write_char(')')
            }
            ExprKind::Construct {
                ty,
                space,
                args,
                parens,
                ..
            } => {
                let space = space
                    .as_ref()
                    .map(|(s, _)| format!(" {s:?}"))
                    .unwrap_or_default();
                if *parens {
                    write!(f, "{ty}{space}(")?;
                    list(f, args, ", ")?;
                    f.write_char(')')
                } else {
                    write!(f, "({ty}{space} ")?;
                    list(f, args, ", ")?;
                    f.write_char(')')
                }
            }
            ExprKind::Tuple(items) => {
                f.write_char('(')?;
                list(f, items, ", ")?;
                f.write_char(')')
            }
            ExprKind::Cast { ty, expr, .. } => write!(f, "(({ty}) {expr})"),
            ExprKind::Unary { op, operand } => write!(f, "({}{operand})", op.as_str()),
            ExprKind::Binary { op, lhs, rhs } => write!(f, "({lhs} {} {rhs})", op.as_str()),
            ExprKind::Ternary { cond, then, els } => write!(f, "({cond} ? {then} : {els})"),
            ExprKind::Assign { op, target, value } => {
                write!(f, "({target} {} {value})", op.as_str())
            }
            ExprKind::IncDec {
                increment,
                prefix,
                target,
            } => {
                let op = if *increment { "++" } else { "--" };
                if *prefix {
                    write!(f, "({op}{target})")
                } else {
                    write!(f, "({target}{op})")
                }
            }
            ExprKind::Index { base, index } => write!(f, "{base}[{index}]"),
            ExprKind::Member { base, field } => write!(f, "{base}.{}", field.name),
            ExprKind::InitList(items) => {
                f.write_char('{')?;
                list(f, items, ", ")?;
                f.write_char('}')
            }
        }
    }
}

impl Display for VarDecl {
    fn fmt(&self, f: &mut Formatter<'_>) -> fmt::Result {
        f.write_str(&self.name.name)?;
        if let Some(a) = &self.array {
            write!(f, "{a}")?;
        }
        if let Some(i) = &self.init {
            write!(f, " = {i}")?;
        }
        Ok(())
    }
}

impl Display for Decl {
    fn fmt(&self, f: &mut Formatter<'_>) -> fmt::Result {
        write!(f, "{} ", self.ty)?;
        list(f, &self.vars, ", ")?;
        f.write_char(';')
    }
}

impl Display for Block {
    fn fmt(&self, f: &mut Formatter<'_>) -> fmt::Result {
        f.write_char('{')?;
        for s in &self.stmts {
            write!(f, " {s}")?;
        }
        f.write_str(" }")
    }
}

fn args_in_parens(f: &mut Formatter<'_>, head: &str, args: &[&Expr]) -> fmt::Result {
    write!(f, "{head}(")?;
    list(f, args, ", ")?;
    f.write_char(')')
}

impl Display for Stmt {
    fn fmt(&self, f: &mut Formatter<'_>) -> fmt::Result {
        match &self.kind {
            StmtKind::Block(b) => write!(f, "{b}"),
            StmtKind::Decl(d) => write!(f, "{d}"),
            StmtKind::Expr(e) => write!(f, "{e};"),
            StmtKind::Empty => f.write_char(';'),
            StmtKind::If { cond, then, els } => {
                write!(f, "if ({cond}) {then}")?;
                match els {
                    Some(e) => write!(f, " else {e}"),
                    None => Ok(()),
                }
            }
            StmtKind::For {
                init,
                cond,
                step,
                body,
            } => {
                f.write_str("for (")?;
                match init {
                    ForInit::None => f.write_str(";")?,
                    ForInit::Decl(d) => write!(f, "{d}")?,
                    ForInit::Exprs(es) => {
                        list(f, es, ", ")?;
                        f.write_char(';')?;
                    }
                }
                if let Some(c) = cond {
                    write!(f, " {c}")?;
                }
                f.write_char(';')?;
                if !step.is_empty() {
                    f.write_char(' ')?;
                    list(f, step, ", ")?;
                }
                write!(f, ") {body}")
            }
            StmtKind::While { cond, body } => write!(f, "while ({cond}) {body}"),
            StmtKind::DoWhile { body, cond } => write!(f, "do {body} while ({cond});"),
            StmtKind::Break { levels: 1 } => f.write_str("break;"),
            StmtKind::Break { levels } => write!(f, "break {levels};"),
            StmtKind::Continue { levels: 1 } => f.write_str("continue;"),
            StmtKind::Continue { levels } => write!(f, "continue {levels};"),
            StmtKind::Return(None) => f.write_str("return;"),
            StmtKind::Return(Some(e)) => write!(f, "return {e};"),
            StmtKind::Illuminance {
                category,
                args,
                body,
            } => {
                let all: Vec<&Expr> = category.iter().chain(args.iter()).collect();
                args_in_parens(f, "illuminance", &all)?;
                write!(f, " {body}")
            }
            StmtKind::Illuminate { args, body } => {
                args_in_parens(f, "illuminate", &args.iter().collect::<Vec<_>>())?;
                write!(f, " {body}")
            }
            StmtKind::Solar { args, body } => {
                args_in_parens(f, "solar", &args.iter().collect::<Vec<_>>())?;
                write!(f, " {body}")
            }
        }
    }
}

impl Display for Metadata {
    fn fmt(&self, f: &mut Formatter<'_>) -> fmt::Result {
        write!(f, "{} {} = {}", self.ty, self.name.name, self.value)
    }
}

fn metadata(f: &mut Formatter<'_>, m: &[Metadata]) -> fmt::Result {
    if m.is_empty() {
        return Ok(());
    }
    f.write_str(" [[ ")?;
    list(f, m, ", ")?;
    f.write_str(" ]]")
}

impl Display for Param {
    fn fmt(&self, f: &mut Formatter<'_>) -> fmt::Result {
        write!(f, "{} {}", self.ty, self.name.name)?;
        if let Some(a) = &self.array {
            write!(f, "{a}")?;
        }
        if let Some(d) = &self.default {
            write!(f, " = {d}")?;
        }
        metadata(f, &self.metadata)
    }
}

impl Display for ShaderKind {
    fn fmt(&self, f: &mut Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            ShaderKind::Surface => "surface",
            ShaderKind::Light => "light",
            ShaderKind::Volume => "volume",
            ShaderKind::Displacement => "displacement",
            ShaderKind::Imager => "imager",
            ShaderKind::Shader => "shader",
        })
    }
}

impl Display for Item {
    fn fmt(&self, f: &mut Formatter<'_>) -> fmt::Result {
        match self {
            Item::Shader(s) => {
                write!(f, "{} {}", s.kind, s.name.name)?;
                metadata(f, &s.metadata)?;
                f.write_char('(')?;
                list(f, &s.params, "; ")?;
                write!(f, ") {}", s.body)
            }
            Item::Function(d) => {
                write!(f, "{} {}(", d.ret, d.name.name)?;
                list(f, &d.params, "; ")?;
                write!(f, ") {}", d.body)
            }
            Item::Struct(s) => {
                write!(f, "struct {} {{", s.name.name)?;
                for d in &s.fields {
                    write!(f, " {d}")?;
                }
                f.write_str(" };")
            }
        }
    }
}

impl Display for File {
    fn fmt(&self, f: &mut Formatter<'_>) -> fmt::Result {
        for i in &self.items {
            writeln!(f, "{i}")?;
        }
        Ok(())
    }
}
