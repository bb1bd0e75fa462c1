//! Macro expansion: object-like and function-like macros with argument substitution
//! (arguments are expanded before they are substituted, as in C), rescanning with the
//! macro being expanded disabled (so `#define x x` stops), and the limits that keep a
//! recursive or exploding macro from hanging: [`MAX_MACRO_DEPTH`] nested expansions and
//! [`MAX_TOKENS`] tokens produced in all (intermediate expansions included).
//!
//! Not supported: `#` (stringize) and `##` (paste) in bodies (rejected where the macro is
//! defined), variadic macros, and a function-like macro whose name ends an expansion and
//! whose arguments follow it in the text (it stays unexpanded).

use crate::diag::Diagnostic;
use crate::lex::{Token, TokenKind};
use crate::source::SourceMap;
use std::collections::HashMap;

/// Most macro expansions nested inside one another (argument expansion and rescanning
/// both count).
pub const MAX_MACRO_DEPTH: usize = 64;

/// Most tokens one translation unit may produce, counting the tokens of the files, every
/// intermediate macro expansion and argument substitution (2^20). Bounds the memory a
/// macro that doubles its input at each level can take.
pub const MAX_TOKENS: usize = 1 << 20;

/// A defined macro.
pub(crate) struct Macro {
    /// The name in its `#define`.
    pub name_span: crate::source::Span,
    /// Parameter names of a function-like macro; `None` for an object-like one.
    pub params: Option<Vec<String>>,
    /// The replacement tokens.
    pub body: Vec<Token>,
}

/// Expands macros in token lists.
pub(super) struct Expander<'a> {
    pub sm: &'a SourceMap,
    pub macros: &'a HashMap<String, Macro>,
    /// Tokens that may still be produced.
    pub budget: &'a mut usize,
    /// In a `#if` line: `defined X` and `defined(X)` pass through unexpanded.
    pub if_mode: bool,
}

impl<'a> Expander<'a> {
    fn emit(&mut self, out: &mut Vec<Token>, t: Token) -> Result<(), Box<Diagnostic>> {
        if *self.budget == 0 {
            return Err(Box::new(
                Diagnostic::error(
                    format!("the source expands to more than {MAX_TOKENS} tokens"),
                    t.span,
                    "the limit was reached here",
                )
                .with_note("a macro that expands to several copies of itself grows exponentially"),
            ));
        }
        *self.budget -= 1;
        out.push(t);
        Ok(())
    }

    /// Appends `input` with its macros expanded to `out`.
    pub fn expand(
        &mut self,
        input: &[Token],
        disabled: &mut Vec<&'a str>,
        depth: usize,
        out: &mut Vec<Token>,
    ) -> Result<(), Box<Diagnostic>> {
        let mut i = 0;
        while i < input.len() {
            let t = input[i];
            i += 1;
            if !matches!(t.kind, TokenKind::Ident | TokenKind::Keyword(_)) {
                self.emit(out, t)?;
                continue;
            }
            let name = self.sm.text(t.text);
            if self.if_mode && name == "defined" {
                // Copy `defined X` / `defined ( X )` as written.
                self.emit(out, t)?;
                let n = if input.get(i).is_some_and(|p| p.kind == TokenKind::LParen) {
                    3
                } else {
                    1
                };
                for &u in input.iter().skip(i).take(n) {
                    self.emit(out, u)?;
                }
                i = (i + n).min(input.len());
                continue;
            }
            let Some((key, m)) = self.macros.get_key_value(name) else {
                self.emit(out, t)?;
                continue;
            };
            if disabled.contains(&key.as_str()) {
                self.emit(out, t)?;
                continue;
            }
            if depth >= MAX_MACRO_DEPTH {
                return Err(Box::new(Diagnostic::error(
                    format!("macro expansion nested deeper than {MAX_MACRO_DEPTH} levels"),
                    t.span,
                    format!("expanding '{name}' here"),
                )));
            }
            let body = match &m.params {
                None => self.substitute(m, t.span, &[], disabled, depth)?,
                Some(params) => {
                    if input.get(i).is_none_or(|p| p.kind != TokenKind::LParen) {
                        self.emit(out, t)?;
                        continue;
                    }
                    let (args, close) = collect_args(input, i, t, name)?;
                    i = close + 1;
                    let site = t.span.to(input[close].span);
                    let given = if params.is_empty() && args.len() == 1 && args[0].is_empty() {
                        0
                    } else {
                        args.len()
                    };
                    if given != params.len() {
                        return Err(Box::new(
                            Diagnostic::error(
                                format!(
                                    "macro '{name}' takes {} argument{}, but {given} {} given",
                                    params.len(),
                                    if params.len() == 1 { "" } else { "s" },
                                    if given == 1 { "was" } else { "were" }
                                ),
                                site,
                                "in this invocation",
                            )
                            .with_secondary(m.name_span, "defined here"),
                        ));
                    }
                    self.substitute(m, site, &args[..given], disabled, depth)?
                }
            };
            disabled.push(key.as_str());
            let r = self.expand(&body, disabled, depth + 1, out);
            disabled.pop();
            r?;
        }
        Ok(())
    }

    /// The body of `m` with each parameter replaced by its expanded argument; body tokens
    /// report `site` (the invocation) as their span.
    fn substitute(
        &mut self,
        m: &Macro,
        site: crate::source::Span,
        args: &[&[Token]],
        disabled: &mut Vec<&'a str>,
        depth: usize,
    ) -> Result<Vec<Token>, Box<Diagnostic>> {
        let mut expanded = Vec::with_capacity(args.len());
        for a in args {
            let mut e = Vec::new();
            self.expand(a, disabled, depth + 1, &mut e)?;
            expanded.push(e);
        }
        let mut body = Vec::new();
        for &b in &m.body {
            let param = match (&m.params, b.kind) {
                (Some(ps), TokenKind::Ident | TokenKind::Keyword(_)) => {
                    let text = self.sm.text(b.text);
                    ps.iter().position(|p| p == text)
                }
                _ => None,
            };
            match param {
                Some(k) => {
                    for &a in &expanded[k] {
                        self.emit(&mut body, a)?;
                    }
                }
                None => {
                    let t = Token {
                        span: site,
                        line_start: false,
                        ..b
                    };
                    self.emit(&mut body, t)?;
                }
            }
        }
        Ok(body)
    }
}

/// The arguments of the invocation whose `(` is at `open`, split at top-level commas, and the
/// index of its `)`.
fn collect_args<'t>(
    input: &'t [Token],
    open: usize,
    name_tok: Token,
    name: &str,
) -> Result<(Vec<&'t [Token]>, usize), Box<Diagnostic>> {
    let mut args = Vec::new();
    let mut level = 0usize;
    let mut start = open + 1;
    for (j, t) in input.iter().enumerate().skip(open + 1) {
        match t.kind {
            TokenKind::LParen => level += 1,
            TokenKind::RParen if level == 0 => {
                args.push(&input[start..j]);
                return Ok((args, j));
            }
            TokenKind::RParen => level -= 1,
            TokenKind::Comma if level == 0 => {
                args.push(&input[start..j]);
                start = j + 1;
            }
            _ => {}
        }
    }
    Err(Box::new(Diagnostic::error(
        format!("unterminated invocation of macro '{name}'"),
        name_tok.span,
        "its argument list has no closing ')' before the end of the text",
    )))
}
