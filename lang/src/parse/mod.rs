//! The parser: hand-written recursive descent from the preprocessed token stream to the
//! [`crate::ast`]. This file owns the parser state, token helpers, error messages, the
//! recursion limit, types, parameters, metadata and top-level items; [`stmt`] owns
//! statements and [`expr`] expressions and the operator precedence table
//! ([`expr::precedence`]).
//!
//! Errors say what was expected and what was found (`expected ';' after the expression,
//! found 'float'`) with the primary span on the found token. The parser stops at the first
//! syntax error. Nesting (blocks, parentheses, prefix operators, right-associative chains)
//! deeper than [`MAX_NESTING`] is an error, so no input overflows the stack.
//!
//! OSL `struct`s are parsed (a struct name declared earlier in the file is a type after
//! it). Function definitions inside a shader or function body are refused ("not supported
//! yet"); define helpers at file scope.

pub mod expr;
pub mod stmt;

use crate::ast::*;
use crate::diag::Diagnostic;
use crate::lex::{Keyword, Token, TokenKind};
use crate::options::Dialect;
use crate::source::{SourceMap, Span};
use std::collections::HashSet;

/// Deepest nesting of blocks, statements, parentheses, prefix operators and
/// right-associative operator chains. Deeper input is an error, never a stack overflow.
pub const MAX_NESTING: usize = 256;

/// Result of a parsing step (the error boxed: results stay small on the recursive path).
pub type PResult<T> = Result<T, Box<Diagnostic>>;

/// Parses a preprocessed token stream into a [`File`]. `end` is where "the end of the file"
/// is reported (the end of the main file).
pub fn parse(tokens: &[Token], sources: &SourceMap, dialect: Dialect, end: Span) -> PResult<File> {
    let mut p = Parser {
        toks: tokens,
        pos: 0,
        sm: sources,
        dialect,
        depth: 0,
        structs: HashSet::new(),
        end,
    };
    let mut items = Vec::new();
    while p.peek().is_some() {
        items.push(p.item()?);
    }
    Ok(File { items })
}

/// The parser's state.
pub struct Parser<'a> {
    toks: &'a [Token],
    pos: usize,
    sm: &'a SourceMap,
    dialect: Dialect,
    depth: usize,
    /// Struct names declared so far (they are types from there on).
    structs: HashSet<String>,
    end: Span,
}

impl<'a> Parser<'a> {
    fn peek(&self) -> Option<Token> {
        self.toks.get(self.pos).copied()
    }

    fn peek_kind(&self) -> Option<TokenKind> {
        self.peek().map(|t| t.kind)
    }

    fn nth_kind(&self, k: usize) -> Option<TokenKind> {
        self.toks.get(self.pos + k).map(|t| t.kind)
    }

    fn at(&self, kind: TokenKind) -> bool {
        self.peek_kind() == Some(kind)
    }

    fn at_kw(&self, kw: Keyword) -> bool {
        self.at(TokenKind::Keyword(kw))
    }

    fn text(&self, t: Token) -> &'a str {
        self.sm.text(t.text)
    }

    fn bump(&mut self) -> Token {
        let t = self.toks[self.pos];
        self.pos += 1;
        t
    }

    fn eat(&mut self, kind: TokenKind) -> Option<Token> {
        if self.at(kind) {
            Some(self.bump())
        } else {
            None
        }
    }

    /// Span of the last token taken (for the end of a node).
    fn prev_span(&self) -> Span {
        self.pos
            .checked_sub(1)
            .and_then(|i| self.toks.get(i))
            .map_or(self.end, |t| t.span)
    }

    /// Span of the next token, or the end of the file.
    fn here(&self) -> Span {
        self.peek().map_or(self.end, |t| t.span)
    }

    /// How the next token is named in an error: `'float'`, or `the end of the file`.
    fn found(&self) -> String {
        match self.peek() {
            Some(t) => format!("'{}'", self.text(t)),
            None => "the end of the file".to_string(),
        }
    }

    /// `expected {what} {context}, found {next}`, at the next token.
    fn expected(&self, what: &str, context: &str) -> Diagnostic {
        let context = if context.is_empty() {
            String::new()
        } else {
            format!(" {context}")
        };
        Diagnostic::error(
            format!("expected {what}{context}, found {}", self.found()),
            self.here(),
            format!("expected {what}"),
        )
    }

    /// Takes a token of `kind` or fails with `expected 'x' {context}`.
    fn expect(&mut self, kind: TokenKind, context: &str) -> PResult<Token> {
        match self.eat(kind) {
            Some(t) => Ok(t),
            None => Err(Box::new(
                self.expected(&format!("'{}'", kind.as_str()), context),
            )),
        }
    }

    /// Takes the `)` (or `]`, `}`) closing `open`, or fails pointing at both.
    fn expect_close(&mut self, kind: TokenKind, open: Token, context: &str) -> PResult<Token> {
        match self.eat(kind) {
            Some(t) => Ok(t),
            None => Err(Box::new(
                self.expected(&format!("'{}'", kind.as_str()), context)
                    .with_secondary(open.span, "opened here"),
            )),
        }
    }

    fn ident(&mut self, context: &str) -> PResult<Ident> {
        match self.peek() {
            Some(t) if t.kind == TokenKind::Ident => {
                self.pos += 1;
                Ok(Ident {
                    name: self.text(t).to_string(),
                    span: t.span,
                })
            }
            _ => Err(Box::new(self.expected("a name", context))),
        }
    }

    /// Enters one nesting level; fails past [`MAX_NESTING`].
    fn enter(&mut self) -> PResult<()> {
        if self.depth >= MAX_NESTING {
            return Err(Box::new(
                Diagnostic::error(
                    format!("nesting deeper than {MAX_NESTING} levels"),
                    self.here(),
                    "too deep here",
                )
                .with_note("split the expression or statement"),
            ));
        }
        self.depth += 1;
        Ok(())
    }

    fn leave(&mut self) {
        self.depth -= 1;
    }

    /// The base type a keyword names, if any.
    fn base_type_kw(kind: Option<TokenKind>) -> Option<BaseType> {
        let TokenKind::Keyword(k) = kind? else {
            return None;
        };
        Some(match k {
            Keyword::Float => BaseType::Float,
            Keyword::Int => BaseType::Int,
            Keyword::Point => BaseType::Point,
            Keyword::Vector => BaseType::Vector,
            Keyword::Normal => BaseType::Normal,
            Keyword::Color => BaseType::Color,
            Keyword::Matrix => BaseType::Matrix,
            Keyword::String => BaseType::String,
            Keyword::Void => BaseType::Void,
            _ => return None,
        })
    }

    fn is_qualifier(kind: Option<TokenKind>) -> bool {
        matches!(
            kind,
            Some(TokenKind::Keyword(
                Keyword::Output
                    | Keyword::Extern
                    | Keyword::Uniform
                    | Keyword::Varying
                    | Keyword::Closure
            ))
        )
    }

    /// Whether the token `k` ahead starts a type (qualifier, base type or struct name).
    fn is_type_start(&self, k: usize) -> bool {
        let kind = self.nth_kind(k);
        Self::is_qualifier(kind)
            || Self::base_type_kw(kind).is_some()
            || (kind == Some(TokenKind::Ident)
                && self
                    .toks
                    .get(self.pos + k)
                    .is_some_and(|t| self.structs.contains(self.text(*t))))
    }

    /// A type with its qualifiers.
    fn ty(&mut self, context: &str) -> PResult<Type> {
        let start = self.here();
        let (mut output, mut external, mut rate, mut closure) = (None, None, None, None);
        loop {
            let t = self.peek();
            let slot = match self.peek_kind() {
                Some(TokenKind::Keyword(Keyword::Output)) => &mut output,
                Some(TokenKind::Keyword(Keyword::Extern)) => &mut external,
                Some(TokenKind::Keyword(Keyword::Closure)) => &mut closure,
                Some(TokenKind::Keyword(k @ (Keyword::Uniform | Keyword::Varying))) => {
                    let t = self.bump();
                    if rate.is_some() {
                        return Err(Box::new(Diagnostic::error(
                            "more than one of 'uniform' and 'varying'",
                            t.span,
                            "a second rate",
                        )));
                    }
                    let r = if k == Keyword::Uniform {
                        Rate::Uniform
                    } else {
                        Rate::Varying
                    };
                    rate = Some((r, t.span));
                    continue;
                }
                _ => break,
            };
            let t = t.map_or(self.end, |t| t.span);
            if slot.is_some() {
                return Err(Box::new(Diagnostic::error(
                    format!("'{}' written twice", self.sm.text(t)),
                    t,
                    "repeated",
                )));
            }
            *slot = Some(t);
            self.pos += 1;
        }
        let base = match Self::base_type_kw(self.peek_kind()) {
            Some(b) => {
                self.pos += 1;
                b
            }
            None if self.is_type_start(0) => BaseType::Struct(self.ident(context)?),
            None => return Err(Box::new(self.expected("a type", context))),
        };
        let base_span = self.prev_span();
        if closure.is_some() && base != BaseType::Color {
            return Err(Box::new(Diagnostic::error(
                "'closure' must be followed by 'color'",
                base_span,
                "not 'color'",
            )));
        }
        Ok(Type {
            output,
            external,
            rate,
            closure,
            base,
            base_span,
            span: start.to(base_span),
        })
    }

    /// `[N]` or `[]` after a declared name, if present.
    fn array_len(&mut self) -> PResult<Option<ArrayLen>> {
        let Some(open) = self.eat(TokenKind::LBracket) else {
            return Ok(None);
        };
        let len = if self.at(TokenKind::RBracket) {
            None
        } else {
            Some(Box::new(self.expr()?))
        };
        let close = self.expect_close(TokenKind::RBracket, open, "after the array size")?;
        Ok(Some(ArrayLen {
            len,
            span: open.span.to(close.span),
        }))
    }

    /// An initialiser: an expression or `{ … }`.
    fn initializer(&mut self) -> PResult<Expr> {
        let Some(open) = self.eat(TokenKind::LBrace) else {
            return self.expr();
        };
        self.enter()?;
        let mut items = Vec::new();
        while !self.at(TokenKind::RBrace) {
            items.push(self.initializer()?);
            if self.eat(TokenKind::Comma).is_none() {
                break;
            }
        }
        let close = self.expect_close(TokenKind::RBrace, open, "to end the initialiser list")?;
        self.leave();
        Ok(Expr {
            kind: ExprKind::InitList(items),
            span: open.span.to(close.span),
        })
    }

    /// OSL metadata `[[ type name = value, … ]]`, if present.
    fn metadata(&mut self) -> PResult<Vec<Metadata>> {
        if !(self.at(TokenKind::LBracket) && self.nth_kind(1) == Some(TokenKind::LBracket)) {
            return Ok(Vec::new());
        }
        let open = self.bump();
        self.bump();
        let mut out = Vec::new();
        loop {
            let ty = self.ty("in metadata")?;
            let name = self.ident("after the metadata type")?;
            self.expect(TokenKind::Eq, "after the metadata name")?;
            let value = self.initializer()?;
            let span = ty.span.to(value.span);
            out.push(Metadata {
                ty,
                name,
                value,
                span,
            });
            if self.eat(TokenKind::Comma).is_none() {
                break;
            }
        }
        self.expect_close(TokenKind::RBracket, open, "to end the metadata")?;
        self.expect_close(TokenKind::RBracket, open, "to end the metadata")?;
        Ok(out)
    }

    /// A parameter list after its `(`, through the `)`. Declarations are separated by `;`
    /// (RSL) or `,` (OSL; also RSL names sharing a type: `float a = 1, b = 2`).
    fn params(&mut self, open: Token) -> PResult<Vec<Param>> {
        let mut params = Vec::new();
        loop {
            if self.eat(TokenKind::RParen).is_some() {
                return Ok(params);
            }
            if self.peek().is_none() {
                return Err(Box::new(
                    self.expected("')'", "to end the parameter list")
                        .with_secondary(open.span, "opened here"),
                ));
            }
            let ty = self.ty("for the parameter")?;
            loop {
                let name = self.ident("for the parameter")?;
                let array = self.array_len()?;
                let default = match self.eat(TokenKind::Eq) {
                    Some(_) => Some(self.initializer()?),
                    None => None,
                };
                let metadata = self.metadata()?;
                let first = if params.last().is_some_and(|p: &Param| p.ty == ty) {
                    name.span
                } else {
                    ty.span
                };
                params.push(Param {
                    ty: ty.clone(),
                    name,
                    array,
                    default,
                    metadata,
                    span: first.to(self.prev_span()),
                });
                if self.eat(TokenKind::Comma).is_some() {
                    if self.is_type_start(0) {
                        break;
                    }
                    continue;
                }
                if self.eat(TokenKind::Semi).is_some() || self.at(TokenKind::RParen) {
                    break;
                }
                return Err(Box::new(
                    self.expected("',', ';' or ')'", "after the parameter")
                        .with_secondary(open.span, "parameter list opened here"),
                ));
            }
        }
    }

    fn item(&mut self) -> PResult<Item> {
        let kind = match self.peek_kind() {
            Some(TokenKind::Keyword(Keyword::Surface)) => Some(ShaderKind::Surface),
            Some(TokenKind::Keyword(Keyword::Light)) => Some(ShaderKind::Light),
            Some(TokenKind::Keyword(Keyword::Volume)) => Some(ShaderKind::Volume),
            Some(TokenKind::Keyword(Keyword::Displacement)) => Some(ShaderKind::Displacement),
            Some(TokenKind::Keyword(Keyword::Imager)) => Some(ShaderKind::Imager),
            Some(TokenKind::Keyword(Keyword::Shader)) => Some(ShaderKind::Shader),
            // OSL: `surface`, `displacement` and `volume` are names, a shader's kind where
            // a name follows (a function's return type is a type keyword or a struct).
            Some(TokenKind::Ident) if self.nth_kind(1) == Some(TokenKind::Ident) => {
                match self.peek().map(|t| self.text(t)) {
                    Some("surface") => Some(ShaderKind::Surface),
                    Some("displacement") => Some(ShaderKind::Displacement),
                    Some("volume") => Some(ShaderKind::Volume),
                    _ => None,
                }
            }
            _ => None,
        };
        if let Some(kind) = kind {
            let kw = self.bump();
            let name = self.ident("after the shader kind")?;
            let metadata = self.metadata()?;
            let open = self.expect(TokenKind::LParen, "after the shader name")?;
            let params = self.params(open)?;
            let body = self.block("for the shader body")?;
            let span = kw.span.to(body.span);
            return Ok(Item::Shader(ShaderDef {
                kind,
                kind_span: kw.span,
                name,
                metadata,
                params,
                body,
                span,
            }));
        }
        if self.at_kw(Keyword::Struct) {
            return self.struct_def().map(Item::Struct);
        }
        if !self.is_type_start(0) {
            let what = match self.dialect {
                Dialect::Rsl => {
                    "a shader ('surface', 'light', 'volume', 'displacement', 'imager') or a function"
                }
                Dialect::Osl => {
                    "a shader ('shader', 'surface', 'displacement', 'volume'), a function or a struct"
                }
            };
            return Err(Box::new(self.expected(what, "at file scope")));
        }
        let ret = self.ty("as the function's return type")?;
        let name = self.ident("for the function")?;
        let open = self.expect(TokenKind::LParen, "after the function name")?;
        let params = self.params(open)?;
        let body = self.block("for the function body")?;
        let span = ret.span.to(body.span);
        Ok(Item::Function(FunctionDef {
            ret,
            name,
            params,
            body,
            span,
        }))
    }

    fn struct_def(&mut self) -> PResult<StructDef> {
        let kw = self.bump();
        let name = self.ident("after 'struct'")?;
        self.structs.insert(name.name.clone());
        let open = self.expect(TokenKind::LBrace, "after the struct name")?;
        let mut fields = Vec::new();
        while !self.at(TokenKind::RBrace) && self.peek().is_some() {
            let d = self.decl("for the struct field")?;
            if let Some(v) = d.vars.iter().find(|v| v.init.is_some()) {
                return Err(Box::new(Diagnostic::error(
                    "struct fields cannot have initialisers",
                    v.span,
                    "initialised here",
                )));
            }
            fields.push(d);
        }
        self.expect_close(TokenKind::RBrace, open, "to end the struct")?;
        let semi = self.expect(TokenKind::Semi, "after the struct definition")?;
        Ok(StructDef {
            name,
            fields,
            span: kw.span.to(semi.span),
        })
    }
}
