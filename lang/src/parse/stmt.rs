//! Statements: blocks, declarations of locals, expression statements, `if`/`else`, `for`,
//! `while`, OSL `do … while`, `break`, `continue`, `return`, and RSL's `illuminance`,
//! `illuminate` and `solar` with their argument counts checked.

use super::{PResult, Parser};
use crate::ast::*;
use crate::diag::Diagnostic;
use crate::lex::{Keyword, TokenKind};

impl Parser<'_> {
    /// `{ statements }`.
    pub(super) fn block(&mut self, context: &str) -> PResult<Block> {
        let open = self.expect(TokenKind::LBrace, context)?;
        self.enter()?;
        let mut stmts = Vec::new();
        while !self.at(TokenKind::RBrace) {
            if self.peek().is_none() {
                return Err(Box::new(
                    self.expected("'}'", "to end the block")
                        .with_secondary(open.span, "block opened here"),
                ));
            }
            stmts.push(self.stmt()?);
        }
        let close = self.bump();
        self.leave();
        Ok(Block {
            stmts,
            span: open.span.to(close.span),
        })
    }

    /// Whether a declaration starts here (rather than an expression such as `color(1)`).
    fn is_decl_start(&self) -> bool {
        if Self::is_qualifier(self.nth_kind(0)) {
            return true;
        }
        (Self::base_type_kw(self.nth_kind(0)).is_some() || self.is_type_start(0))
            && self.nth_kind(1) == Some(TokenKind::Ident)
    }

    /// `type name [N] = init, …;`.
    pub(super) fn decl(&mut self, context: &str) -> PResult<Decl> {
        let ty = self.ty(context)?;
        let mut vars = Vec::new();
        loop {
            let name = self.ident("in the declaration")?;
            if self.at(TokenKind::LParen) {
                return Err(Box::new(
                    Diagnostic::error(
                        "function definitions inside a body are not supported yet",
                        name.span,
                        "a function defined here",
                    )
                    .with_note("define the function at file scope"),
                ));
            }
            let array = self.array_len()?;
            let init = match self.eat(TokenKind::Eq) {
                Some(_) => Some(self.initializer()?),
                None => None,
            };
            let span = name.span.to(self.prev_span());
            vars.push(VarDecl {
                name,
                array,
                init,
                span,
            });
            if self.eat(TokenKind::Comma).is_none() {
                break;
            }
        }
        self.expect(TokenKind::Semi, "after the declaration")?;
        let span = ty.span.to(self.prev_span());
        Ok(Decl { ty, vars, span })
    }

    /// One statement.
    pub(super) fn stmt(&mut self) -> PResult<Stmt> {
        self.enter()?;
        let s = self.stmt_inner();
        self.leave();
        s
    }

    fn stmt_inner(&mut self) -> PResult<Stmt> {
        let start = self.here();
        let kind = match self.peek_kind() {
            Some(TokenKind::LBrace) => StmtKind::Block(self.block("")?),
            Some(TokenKind::Semi) => {
                self.bump();
                StmtKind::Empty
            }
            Some(TokenKind::Keyword(k)) if !self.is_decl_start() => match self.keyword_stmt(k)? {
                Some(kind) => kind,
                None => self.expr_stmt()?,
            },
            _ if self.is_decl_start() => StmtKind::Decl(self.decl("for the declaration")?),
            _ => self.expr_stmt()?,
        };
        Ok(Stmt {
            kind,
            span: start.to(self.prev_span()),
        })
    }

    fn expr_stmt(&mut self) -> PResult<StmtKind> {
        let e = self.expr()?;
        self.expect(TokenKind::Semi, "after the expression")?;
        Ok(StmtKind::Expr(e))
    }

    /// `( expr )` after `if`, `while`.
    fn paren_cond(&mut self, after: &str) -> PResult<Expr> {
        let open = self.expect(TokenKind::LParen, &format!("after '{after}'"))?;
        let e = self.expr()?;
        self.expect_close(TokenKind::RParen, open, "after the condition")?;
        Ok(e)
    }

    /// A statement that starts with keyword `k`, or `None` if `k` starts an expression.
    fn keyword_stmt(&mut self, k: Keyword) -> PResult<Option<StmtKind>> {
        Ok(Some(match k {
            Keyword::If => {
                self.bump();
                let cond = self.paren_cond("if")?;
                let then = Box::new(self.stmt()?);
                let els = match self.eat(TokenKind::Keyword(Keyword::Else)) {
                    Some(_) => Some(Box::new(self.stmt()?)),
                    None => None,
                };
                StmtKind::If { cond, then, els }
            }
            Keyword::While => {
                self.bump();
                let cond = self.paren_cond("while")?;
                let body = Box::new(self.stmt()?);
                StmtKind::While { cond, body }
            }
            Keyword::Do => {
                self.bump();
                let body = Box::new(self.stmt()?);
                self.expect(TokenKind::Keyword(Keyword::While), "after the body of 'do'")?;
                let cond = self.paren_cond("while")?;
                self.expect(TokenKind::Semi, "after 'do … while (…)'")?;
                StmtKind::DoWhile { body, cond }
            }
            Keyword::For => self.for_stmt()?,
            Keyword::Break | Keyword::Continue => {
                let t = self.bump();
                let word = self.text(t);
                let mut levels = 1;
                if let Some(n) = self.eat(TokenKind::Int) {
                    levels = match self.text(n).parse::<u32>() {
                        Ok(v) if v >= 1 => v,
                        _ => {
                            return Err(Box::new(Diagnostic::error(
                                format!("'{word}' takes a loop count of at least 1"),
                                n.span,
                                "not a loop count",
                            )));
                        }
                    };
                }
                self.expect(TokenKind::Semi, &format!("after '{word}'"))?;
                if k == Keyword::Break {
                    StmtKind::Break { levels }
                } else {
                    StmtKind::Continue { levels }
                }
            }
            Keyword::Return => {
                self.bump();
                let value = if self.at(TokenKind::Semi) {
                    None
                } else {
                    Some(self.expr()?)
                };
                self.expect(TokenKind::Semi, "after the return value")?;
                StmtKind::Return(value)
            }
            Keyword::Illuminance | Keyword::Illuminate | Keyword::Solar => self.light_stmt(k)?,
            Keyword::Else => {
                return Err(Box::new(
                    self.expected("a statement", "('else' without 'if')"),
                ));
            }
            _ => return Ok(None),
        }))
    }

    fn for_stmt(&mut self) -> PResult<StmtKind> {
        self.bump();
        let open = self.expect(TokenKind::LParen, "after 'for'")?;
        let init = if self.eat(TokenKind::Semi).is_some() {
            ForInit::None
        } else if self.is_decl_start() {
            ForInit::Decl(self.decl("in the loop's first clause")?)
        } else {
            let es = self.expr_list()?;
            self.expect(TokenKind::Semi, "after the loop's first clause")?;
            ForInit::Exprs(es)
        };
        let cond = if self.at(TokenKind::Semi) {
            None
        } else {
            Some(self.expr()?)
        };
        self.expect(TokenKind::Semi, "after the loop condition")?;
        let step = if self.at(TokenKind::RParen) {
            Vec::new()
        } else {
            self.expr_list()?
        };
        self.expect_close(TokenKind::RParen, open, "after the loop's clauses")?;
        let body = Box::new(self.stmt()?);
        Ok(StmtKind::For {
            init,
            cond,
            step,
            body,
        })
    }

    /// `e, e, …` (at least one).
    fn expr_list(&mut self) -> PResult<Vec<Expr>> {
        let mut es = vec![self.expr()?];
        while self.eat(TokenKind::Comma).is_some() {
            es.push(self.expr()?);
        }
        Ok(es)
    }

    /// `illuminance`, `illuminate`, `solar`: arguments, then the body statement.
    fn light_stmt(&mut self, k: Keyword) -> PResult<StmtKind> {
        let kw = self.bump();
        let name = k.as_str();
        let open = self.expect(TokenKind::LParen, &format!("after '{name}'"))?;
        let mut args = if self.at(TokenKind::RParen) {
            Vec::new()
        } else {
            self.expr_list()?
        };
        let close = self.expect_close(
            TokenKind::RParen,
            open,
            &format!("after the arguments of '{name}'"),
        )?;
        let mut category = None;
        if k == Keyword::Illuminance
            && matches!(args.len(), 2 | 4)
            && matches!(args[0].kind, ExprKind::Str(_))
        {
            category = Some(args.remove(0));
        }
        let (ok, forms) = match k {
            Keyword::Illuminance => (
                matches!(args.len(), 1 | 3),
                "(P) or (P, N, angle), with an optional category string first",
            ),
            Keyword::Illuminate => (matches!(args.len(), 1 | 3), "(P) or (P, axis, angle)"),
            _ => (matches!(args.len(), 0 | 2), "() or (axis, angle)"),
        };
        if !ok {
            let n = args.len() + usize::from(category.is_some());
            return Err(Box::new(Diagnostic::error(
                format!(
                    "'{name}' takes {forms}; found {n} argument{}",
                    if n == 1 { "" } else { "s" }
                ),
                kw.span.to(close.span),
                "wrong number of arguments",
            )));
        }
        let body = Box::new(self.stmt()?);
        Ok(match k {
            Keyword::Illuminance => StmtKind::Illuminance {
                category,
                args,
                body,
            },
            Keyword::Illuminate => StmtKind::Illuminate { args, body },
            _ => StmtKind::Solar { args, body },
        })
    }
}
