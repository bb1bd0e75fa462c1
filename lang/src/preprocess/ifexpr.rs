//! `#if` / `#elif` expressions: 64-bit integers (wrapping), `defined X` / `defined(X)`,
//! unary `! ~ - +`, binary `* / % + - << >> < <= > >= == != & ^ | && ||` with C's
//! precedence, `?:` and parentheses. An identifier that is not a macro is 0, as in C.
//! Nesting is limited to [`MAX_IF_DEPTH`].

use crate::diag::Diagnostic;
use crate::lex::{Token, TokenKind};
use crate::source::{SourceMap, Span};
use std::collections::HashMap;

/// Deepest nesting of parentheses and unary operators in a `#if` expression.
pub const MAX_IF_DEPTH: usize = 64;

/// Evaluates a macro-expanded `#if` line (`defined` forms left in place). `at` is the
/// directive, for errors about an empty or truncated expression.
pub(super) fn eval<M>(
    tokens: &[Token],
    sm: &SourceMap,
    macros: &HashMap<String, M>,
    at: Span,
) -> Result<i64, Box<Diagnostic>> {
    let mut p = IfParser {
        tokens,
        pos: 0,
        sm,
        macros,
        at,
    };
    let v = p.ternary(0)?;
    if let Some(t) = p.tokens.get(p.pos) {
        return Err(Box::new(Diagnostic::error(
            format!(
                "expected the end of the #if expression, found '{}'",
                sm.text(t.text)
            ),
            t.span,
            "unexpected here",
        )));
    }
    Ok(v)
}

struct IfParser<'a, M> {
    tokens: &'a [Token],
    pos: usize,
    sm: &'a SourceMap,
    macros: &'a HashMap<String, M>,
    at: Span,
}

/// The precedence of a binary operator (higher binds tighter), as in C.
fn precedence(kind: TokenKind) -> Option<u8> {
    Some(match kind {
        TokenKind::OrOr => 1,
        TokenKind::AndAnd => 2,
        TokenKind::Pipe => 3,
        TokenKind::Caret => 4,
        TokenKind::Amp => 5,
        TokenKind::EqEq | TokenKind::NotEq => 6,
        TokenKind::Lt | TokenKind::Le | TokenKind::Gt | TokenKind::Ge => 7,
        TokenKind::Shl | TokenKind::Shr => 8,
        TokenKind::Plus | TokenKind::Minus => 9,
        TokenKind::Star | TokenKind::Slash | TokenKind::Percent => 10,
        _ => return None,
    })
}

impl<M> IfParser<'_, M> {
    fn peek(&self) -> Option<Token> {
        self.tokens.get(self.pos).copied()
    }

    fn missing(&self, what: &str) -> Diagnostic {
        match self.peek() {
            Some(t) => Diagnostic::error(
                format!("expected {what} in #if, found '{}'", self.sm.text(t.text)),
                t.span,
                format!("expected {what}"),
            ),
            None => Diagnostic::error(
                format!("expected {what} in #if, found the end of the line"),
                self.at,
                "in this directive",
            ),
        }
    }

    fn expect(&mut self, kind: TokenKind, what: &str) -> Result<(), Box<Diagnostic>> {
        if self.peek().is_some_and(|t| t.kind == kind) {
            self.pos += 1;
            Ok(())
        } else {
            Err(Box::new(self.missing(what)))
        }
    }

    fn ternary(&mut self, depth: usize) -> Result<i64, Box<Diagnostic>> {
        if depth > MAX_IF_DEPTH {
            let at = self.peek().map_or(self.at, |t| t.span);
            return Err(Box::new(Diagnostic::error(
                format!("#if expression nested deeper than {MAX_IF_DEPTH} levels"),
                at,
                "too deep here",
            )));
        }
        let c = self.binary(1, depth)?;
        if self.peek().is_some_and(|t| t.kind == TokenKind::Question) {
            self.pos += 1;
            let a = self.ternary(depth + 1)?;
            self.expect(TokenKind::Colon, "':'")?;
            let b = self.ternary(depth + 1)?;
            return Ok(if c != 0 { a } else { b });
        }
        Ok(c)
    }

    /// Binary operators of precedence `min` and tighter (precedence climbing).
    fn binary(&mut self, min: u8, depth: usize) -> Result<i64, Box<Diagnostic>> {
        let mut l = self.unary(depth)?;
        while let Some((t, prec)) = self
            .peek()
            .and_then(|t| precedence(t.kind).map(|p| (t, p)))
            .filter(|(_, p)| *p >= min)
        {
            self.pos += 1;
            let r = self.binary(prec + 1, depth)?;
            l = match t.kind {
                TokenKind::OrOr => i64::from(l != 0 || r != 0),
                TokenKind::AndAnd => i64::from(l != 0 && r != 0),
                TokenKind::Pipe => l | r,
                TokenKind::Caret => l ^ r,
                TokenKind::Amp => l & r,
                TokenKind::EqEq => i64::from(l == r),
                TokenKind::NotEq => i64::from(l != r),
                TokenKind::Lt => i64::from(l < r),
                TokenKind::Le => i64::from(l <= r),
                TokenKind::Gt => i64::from(l > r),
                TokenKind::Ge => i64::from(l >= r),
                TokenKind::Shl => l.wrapping_shl((r & 63) as u32),
                TokenKind::Shr => l.wrapping_shr((r & 63) as u32),
                TokenKind::Plus => l.wrapping_add(r),
                TokenKind::Minus => l.wrapping_sub(r),
                TokenKind::Star => l.wrapping_mul(r),
                _ if r == 0 => {
                    return Err(Box::new(Diagnostic::error(
                        "division by zero in #if",
                        t.span,
                        "the right operand is 0",
                    )));
                }
                TokenKind::Slash => l.wrapping_div(r),
                _ => l.wrapping_rem(r),
            };
        }
        Ok(l)
    }

    fn unary(&mut self, depth: usize) -> Result<i64, Box<Diagnostic>> {
        let Some(t) = self.peek() else {
            return Err(Box::new(self.missing("a value")));
        };
        let nested = |s: &mut Self| s.unary_nested(depth);
        match t.kind {
            TokenKind::Bang => {
                self.pos += 1;
                Ok(i64::from(nested(self)? == 0))
            }
            TokenKind::Tilde => {
                self.pos += 1;
                Ok(!nested(self)?)
            }
            TokenKind::Minus => {
                self.pos += 1;
                Ok(nested(self)?.wrapping_neg())
            }
            TokenKind::Plus => {
                self.pos += 1;
                nested(self)
            }
            TokenKind::LParen => {
                self.pos += 1;
                let v = self.ternary(depth + 1)?;
                self.expect(TokenKind::RParen, "')'")?;
                Ok(v)
            }
            TokenKind::Int => {
                self.pos += 1;
                let text = self.sm.text(t.text);
                let v = match text.strip_prefix("0x").or_else(|| text.strip_prefix("0X")) {
                    Some(h) => u64::from_str_radix(h, 16).ok().map(|v| v as i64),
                    None => text.parse::<i64>().ok(),
                };
                v.ok_or_else(|| {
                    Box::new(Diagnostic::error(
                        format!("integer '{text}' does not fit in 64 bits"),
                        t.span,
                        "too large",
                    ))
                })
            }
            TokenKind::Ident | TokenKind::Keyword(_) if self.sm.text(t.text) == "defined" => {
                self.pos += 1;
                let paren = self.peek().is_some_and(|p| p.kind == TokenKind::LParen);
                if paren {
                    self.pos += 1;
                }
                let name = match self.peek() {
                    Some(n) if matches!(n.kind, TokenKind::Ident | TokenKind::Keyword(_)) => n,
                    _ => return Err(Box::new(self.missing("a macro name after 'defined'"))),
                };
                self.pos += 1;
                if paren {
                    self.expect(TokenKind::RParen, "')'")?;
                }
                Ok(i64::from(self.macros.contains_key(self.sm.text(name.text))))
            }
            TokenKind::Ident | TokenKind::Keyword(_) => {
                self.pos += 1;
                Ok(0)
            }
            TokenKind::Float | TokenKind::Str => Err(Box::new(Diagnostic::error(
                format!(
                    "#if expressions are integers, found '{}'",
                    self.sm.text(t.text)
                ),
                t.span,
                "not an integer",
            ))),
            _ => Err(Box::new(self.missing("a value"))),
        }
    }

    fn unary_nested(&mut self, depth: usize) -> Result<i64, Box<Diagnostic>> {
        if depth > MAX_IF_DEPTH {
            return Err(Box::new(Diagnostic::error(
                format!("#if expression nested deeper than {MAX_IF_DEPTH} levels"),
                self.peek().map_or(self.at, |t| t.span),
                "too deep here",
            )));
        }
        self.unary(depth + 1)
    }
}
