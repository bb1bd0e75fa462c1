//! Expressions, and the one table of binary operator precedence ([`precedence`]).
//!
//! From loosest to tightest: assignment (`= += -= *= /= %= &= |= ^= <<= >>=`, right to
//! left) < `?:` (right to left) < the binary operators of [`precedence`] (left to right) <
//! prefix `- + ! ~ ++ --` and casts `(float) x` < postfix `[i]`, `++`, `--`, OSL `.field`.
//! Primaries: literals (adjacent strings join), names, calls `f(…)`, constructors
//! `type ["space"] (…)` or `type ["space"] operand`, parentheses and RSL triples `(a, b, c)`.

use super::{PResult, Parser};
use crate::ast::*;
use crate::diag::Diagnostic;
use crate::lex::{Keyword, TokenKind, decode_string};
use crate::options::Dialect;

/// The binary operator a token is in `dialect`, and its precedence (higher binds tighter).
/// The only dialect differences: RSL's `^` is the cross product (between `+` and `*`) and
/// its `.` the dot product (tighter than `*`); OSL's `^` is bitwise xor (between `|` and
/// `&`, as in C) and its `.` is field selection (postfix, not here).
///
/// | prec | operators |
/// |---|---|
/// | 1 | `\|\|` |
/// | 2 | `&&` |
/// | 3 | `\|` |
/// | 4 | `^` (OSL xor) |
/// | 5 | `&` |
/// | 6 | `==` `!=` |
/// | 7 | `<` `<=` `>` `>=` |
/// | 8 | `<<` `>>` |
/// | 9 | `+` `-` |
/// | 10 | `^` (RSL cross) |
/// | 11 | `*` `/` `%` |
/// | 12 | `.` (RSL dot) |
pub fn precedence(kind: TokenKind, dialect: Dialect) -> Option<(BinaryOp, u8)> {
    Some(match (kind, dialect) {
        (TokenKind::OrOr, _) => (BinaryOp::Or, 1),
        (TokenKind::AndAnd, _) => (BinaryOp::And, 2),
        (TokenKind::Pipe, _) => (BinaryOp::BitOr, 3),
        (TokenKind::Caret, Dialect::Osl) => (BinaryOp::BitXor, 4),
        (TokenKind::Amp, _) => (BinaryOp::BitAnd, 5),
        (TokenKind::EqEq, _) => (BinaryOp::Eq, 6),
        (TokenKind::NotEq, _) => (BinaryOp::Ne, 6),
        (TokenKind::Lt, _) => (BinaryOp::Lt, 7),
        (TokenKind::Le, _) => (BinaryOp::Le, 7),
        (TokenKind::Gt, _) => (BinaryOp::Gt, 7),
        (TokenKind::Ge, _) => (BinaryOp::Ge, 7),
        (TokenKind::Shl, _) => (BinaryOp::Shl, 8),
        (TokenKind::Shr, _) => (BinaryOp::Shr, 8),
        (TokenKind::Plus, _) => (BinaryOp::Add, 9),
        (TokenKind::Minus, _) => (BinaryOp::Sub, 9),
        (TokenKind::Caret, Dialect::Rsl) => (BinaryOp::Cross, 10),
        (TokenKind::Star, _) => (BinaryOp::Mul, 11),
        (TokenKind::Slash, _) => (BinaryOp::Div, 11),
        (TokenKind::Percent, _) => (BinaryOp::Rem, 11),
        (TokenKind::Dot, Dialect::Rsl) => (BinaryOp::Dot, 12),
        _ => return None,
    })
}

/// The assignment operator a token is, if any.
fn assign_op(kind: TokenKind) -> Option<AssignOp> {
    Some(match kind {
        TokenKind::Eq => AssignOp::Set,
        TokenKind::PlusEq => AssignOp::Add,
        TokenKind::MinusEq => AssignOp::Sub,
        TokenKind::StarEq => AssignOp::Mul,
        TokenKind::SlashEq => AssignOp::Div,
        TokenKind::PercentEq => AssignOp::Rem,
        TokenKind::AmpEq => AssignOp::BitAnd,
        TokenKind::PipeEq => AssignOp::BitOr,
        TokenKind::CaretEq => AssignOp::BitXor,
        TokenKind::ShlEq => AssignOp::Shl,
        TokenKind::ShrEq => AssignOp::Shr,
        _ => return None,
    })
}

impl Parser<'_> {
    /// A full expression (assignment level).
    pub(super) fn expr(&mut self) -> PResult<Expr> {
        self.enter()?;
        let e = self.assign();
        self.leave();
        e
    }

    fn assign(&mut self) -> PResult<Expr> {
        let target = self.ternary()?;
        let Some(op) = self.peek_kind().and_then(assign_op) else {
            return Ok(target);
        };
        self.bump();
        let value = self.expr()?;
        let span = target.span.to(value.span);
        Ok(Expr {
            kind: ExprKind::Assign {
                op,
                target: Box::new(target),
                value: Box::new(value),
            },
            span,
        })
    }

    fn ternary(&mut self) -> PResult<Expr> {
        let cond = self.binary(1)?;
        if self.eat(TokenKind::Question).is_none() {
            return Ok(cond);
        }
        let then = self.expr()?;
        self.expect(TokenKind::Colon, "in the conditional expression")?;
        let els = self.expr()?;
        let span = cond.span.to(els.span);
        Ok(Expr {
            kind: ExprKind::Ternary {
                cond: Box::new(cond),
                then: Box::new(then),
                els: Box::new(els),
            },
            span,
        })
    }

    /// Binary operators of precedence `min` and tighter (precedence climbing).
    fn binary(&mut self, min: u8) -> PResult<Expr> {
        let mut lhs = self.unary()?;
        while let Some((op, prec)) = self
            .peek_kind()
            .and_then(|k| precedence(k, self.dialect))
            .filter(|(_, p)| *p >= min)
        {
            self.bump();
            let rhs = self.binary(prec + 1)?;
            let span = lhs.span.to(rhs.span);
            lhs = Expr {
                kind: ExprKind::Binary {
                    op,
                    lhs: Box::new(lhs),
                    rhs: Box::new(rhs),
                },
                span,
            };
        }
        Ok(lhs)
    }

    fn unary(&mut self) -> PResult<Expr> {
        self.enter()?;
        let e = self.unary_inner();
        self.leave();
        e
    }

    fn unary_inner(&mut self) -> PResult<Expr> {
        let Some(t) = self.peek() else {
            return Err(Box::new(self.expected("an expression", "")));
        };
        let op = match t.kind {
            TokenKind::Minus => Some(UnaryOp::Neg),
            TokenKind::Plus => Some(UnaryOp::Plus),
            TokenKind::Bang => Some(UnaryOp::Not),
            TokenKind::Tilde => Some(UnaryOp::BitNot),
            _ => None,
        };
        if let Some(op) = op {
            self.bump();
            let operand = self.unary()?;
            let span = t.span.to(operand.span);
            return Ok(Expr {
                kind: ExprKind::Unary {
                    op,
                    operand: Box::new(operand),
                },
                span,
            });
        }
        if matches!(t.kind, TokenKind::PlusPlus | TokenKind::MinusMinus) {
            self.bump();
            let target = self.unary()?;
            let span = t.span.to(target.span);
            return Ok(Expr {
                kind: ExprKind::IncDec {
                    increment: t.kind == TokenKind::PlusPlus,
                    prefix: true,
                    target: Box::new(target),
                },
                span,
            });
        }
        // `(type) operand`: a cast.
        if t.kind == TokenKind::LParen
            && self.nth_kind(2) == Some(TokenKind::RParen)
            && let Some(ty) = Self::base_type_kw(self.nth_kind(1))
        {
            self.bump();
            let ty_span = self.bump().span;
            self.bump();
            let expr = self.unary()?;
            let span = t.span.to(expr.span);
            return Ok(Expr {
                kind: ExprKind::Cast {
                    ty,
                    ty_span,
                    expr: Box::new(expr),
                },
                span,
            });
        }
        self.postfix()
    }

    fn postfix(&mut self) -> PResult<Expr> {
        let mut e = self.primary()?;
        loop {
            match self.peek_kind() {
                // `[[` starts OSL metadata, not an index.
                Some(TokenKind::LBracket) if self.nth_kind(1) != Some(TokenKind::LBracket) => {
                    let open = self.bump();
                    let index = self.expr()?;
                    let close = self.expect_close(TokenKind::RBracket, open, "after the index")?;
                    let span = e.span.to(close.span);
                    e = Expr {
                        kind: ExprKind::Index {
                            base: Box::new(e),
                            index: Box::new(index),
                        },
                        span,
                    };
                }
                Some(k @ (TokenKind::PlusPlus | TokenKind::MinusMinus)) => {
                    let t = self.bump();
                    let span = e.span.to(t.span);
                    e = Expr {
                        kind: ExprKind::IncDec {
                            increment: k == TokenKind::PlusPlus,
                            prefix: false,
                            target: Box::new(e),
                        },
                        span,
                    };
                }
                Some(TokenKind::Dot) if self.dialect == Dialect::Osl => {
                    self.bump();
                    let field = self.ident("after '.'")?;
                    let span = e.span.to(field.span);
                    e = Expr {
                        kind: ExprKind::Member {
                            base: Box::new(e),
                            field,
                        },
                        span,
                    };
                }
                _ => return Ok(e),
            }
        }
    }

    /// `( args )` after a callee or a constructor's type; `open` is taken.
    fn call_args(
        &mut self,
        open: crate::lex::Token,
        context: &str,
    ) -> PResult<(Vec<Expr>, crate::source::Span)> {
        let mut args = Vec::new();
        if !self.at(TokenKind::RParen) {
            args = self.arg_list()?;
        }
        let close = self.expect_close(TokenKind::RParen, open, context)?;
        Ok((args, open.span.to(close.span)))
    }

    fn arg_list(&mut self) -> PResult<Vec<Expr>> {
        let mut es = vec![self.expr()?];
        while self.eat(TokenKind::Comma).is_some() {
            es.push(self.expr()?);
        }
        Ok(es)
    }

    fn primary(&mut self) -> PResult<Expr> {
        let Some(t) = self.peek() else {
            return Err(Box::new(self.expected("an expression", "")));
        };
        let text = self.text(t);
        let kind = match t.kind {
            TokenKind::Int => {
                self.bump();
                let v = match text.strip_prefix("0x").or_else(|| text.strip_prefix("0X")) {
                    // A hex literal of 32 bits is its bit pattern, as C's and OSL's
                    // (`0xdeadbeef` is a negative int): hashes are written that way.
                    Some(h) => i64::from_str_radix(h, 16)
                        .ok()
                        .map(|v| match u32::try_from(v) {
                            Ok(bits) => i64::from(bits as i32),
                            Err(_) => v,
                        }),
                    None => text.parse::<i64>().ok(),
                };
                match v {
                    Some(v) => ExprKind::Int(v),
                    None => {
                        return Err(Box::new(Diagnostic::error(
                            format!("integer '{text}' is too large"),
                            t.span,
                            "over 2^63 - 1",
                        )));
                    }
                }
            }
            TokenKind::Float => {
                self.bump();
                match text.parse::<f64>() {
                    Ok(v) => ExprKind::Float(v),
                    Err(_) => {
                        return Err(Box::new(Diagnostic::error(
                            format!("bad number '{text}'"),
                            t.span,
                            "not a number",
                        )));
                    }
                }
            }
            TokenKind::Str => return self.string(),
            TokenKind::Ident => {
                let name = self.ident("")?;
                if let Some(open) = self.eat(TokenKind::LParen) {
                    let (args, span) = self.call_args(open, "to end the argument list")?;
                    return Ok(Expr {
                        span: name.span.to(span),
                        kind: ExprKind::Call { callee: name, args },
                    });
                }
                return Ok(Expr {
                    span: name.span,
                    kind: ExprKind::Ident(name),
                });
            }
            TokenKind::LParen => return self.paren(),
            // OSL's compound initialiser as a value (`s = { a, b }`, `return { a, b }`).
            TokenKind::LBrace if self.dialect == Dialect::Osl => return self.initializer(),
            TokenKind::Keyword(_) if Self::base_type_kw(Some(t.kind)).is_some() => {
                return self.construct();
            }
            TokenKind::Keyword(Keyword::Closure) => {
                return Err(Box::new(Diagnostic::error(
                    "'closure' names a type, not a value",
                    t.span,
                    "expected an expression",
                )));
            }
            _ => return Err(Box::new(self.expected("an expression", ""))),
        };
        Ok(Expr { kind, span: t.span })
    }

    /// One or more adjacent string literals, joined.
    fn string(&mut self) -> PResult<Expr> {
        let mut value = String::new();
        let first = self.here();
        while let Some(t) = self.eat(TokenKind::Str) {
            let raw = self.text(t);
            let inner = raw.get(1..raw.len().saturating_sub(1)).unwrap_or("");
            match decode_string(inner) {
                Ok(s) => value.push_str(&s),
                Err((_, msg)) => {
                    return Err(Box::new(Diagnostic::error(msg, t.span, "in this string")));
                }
            }
        }
        Ok(Expr {
            kind: ExprKind::Str(value),
            span: first.to(self.prev_span()),
        })
    }

    /// `( expr )`, or the triple `(a, b, c)`.
    fn paren(&mut self) -> PResult<Expr> {
        let open = self.bump();
        let first = self.expr()?;
        let mut items = vec![first];
        while self.eat(TokenKind::Comma).is_some() {
            items.push(self.expr()?);
        }
        let close = self.expect_close(TokenKind::RParen, open, "to close the parenthesis")?;
        if items.len() == 1 {
            let mut e = items.remove(0);
            // The parentheses belong to the expression's text.
            e.span = open.span.to(close.span);
            return Ok(e);
        }
        Ok(Expr {
            kind: ExprKind::Tuple(items),
            span: open.span.to(close.span),
        })
    }

    /// `type ["space"] (args)` or `type ["space"] operand`.
    fn construct(&mut self) -> PResult<Expr> {
        let t = self.bump();
        let ty = Self::base_type_kw(Some(t.kind)).unwrap_or(BaseType::Float);
        let space = if self.at(TokenKind::Str) {
            let s = self.string()?;
            match s.kind {
                ExprKind::Str(v) => Some((v, s.span)),
                _ => None,
            }
        } else {
            None
        };
        if let Some(open) = self.eat(TokenKind::LParen) {
            let (args, span) =
                self.call_args(open, &format!("to end the arguments of '{}'", ty))?;
            return Ok(Expr {
                kind: ExprKind::Construct {
                    ty,
                    ty_span: t.span,
                    space,
                    args,
                    parens: true,
                },
                span: t.span.to(span),
            });
        }
        let operand = self.unary()?;
        let span = t.span.to(operand.span);
        Ok(Expr {
            kind: ExprKind::Construct {
                ty,
                ty_span: t.span,
                space,
                args: vec![operand],
                parens: false,
            },
            span,
        })
    }
}
