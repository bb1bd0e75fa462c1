//! The preprocessor, on tokens: it lexes each file, runs its directives and expands macros,
//! and hands the parser one token stream whose spans point into the original files.
//!
//! Directives: `#include "f"` (searched in the including file's folder, then the `-I`
//! directories in order) and `#include <f>` (the `-I` directories only, as in C);
//! `#define` (object-like, and function-like when `(` follows the name with no space),
//! `#undef`, `#if`/`#ifdef`/`#ifndef`/`#elif`/`#else`/`#endif` ([`ifexpr`]), `#pragma once`,
//! `#error`, `#warning`. Another `#pragma` is ignored with a warning. An unknown directive
//! is an error. An include cycle, a missing include and every error inside an included
//! file carry the include chain.
//!
//! Predefined macros: `__SHADENET__` (1) in both dialects; `__RSL__` (1) for RSL;
//! `__OSL__` (1), `OSL_VERSION_MAJOR` (1), `OSL_VERSION_MINOR` (13), `OSL_VERSION_PATCH` (0)
//! and `OSL_VERSION` (11300) for OSL, with the constants of OSL's standard header (`M_PI`,
//! `M_2PI`, `M_SQRT2`…; `#include "stdosl.h"` not found on the search path is built in and
//! reads nothing); then the `-D` defines in order. They live in a
//! synthetic file named `<predefined>` so their tokens have spans like any other.
//!
//! Limits: [`MAX_INCLUDE_DEPTH`] nested includes, [`MAX_SCANNED`] tokens read in all,
//! [`expand::MAX_MACRO_DEPTH`] nested expansions, [`expand::MAX_TOKENS`] tokens produced in
//! all, [`ifexpr::MAX_IF_DEPTH`] nesting in `#if` expressions.

pub mod expand;
pub mod ifexpr;

use crate::diag::{Diagnostic, Diagnostics};
use crate::lex::{Token, TokenKind, lex};
use crate::options::{Dialect, Options};
use crate::source::{FileId, MAX_FILE_BYTES, SourceMap, Span};
use expand::{Expander, MAX_TOKENS, Macro};
use std::collections::{HashMap, HashSet};
use std::path::{Path, PathBuf};
use std::rc::Rc;

/// Most `#include`s nested inside one another.
pub const MAX_INCLUDE_DEPTH: usize = 64;

/// Most tokens read over all files, a file counted each time it is included, skipped lines
/// included (2^22): bounds the work of a file included many times behind an include guard.
pub const MAX_SCANNED: usize = 1 << 22;

/// The preprocessor's result.
#[derive(Debug)]
pub struct Preprocessed {
    /// The token stream for the parser.
    pub tokens: Vec<Token>,
    /// Warnings (ignored pragmas, `#warning`).
    pub warnings: Vec<Diagnostic>,
    /// For each included file, the `#include` directives that first led to it, innermost
    /// first (what [`Diagnostic::include_chain`] holds), for later phases' errors.
    pub include_chains: HashMap<FileId, Vec<Span>>,
}

/// Reads `path` into the source map (or finds it there, by canonical path). Returns the id
/// and, for a file that is not valid UTF-8, the error at the first bad byte (the text is kept
/// up to there, so the span is right).
/// [`load_file`] of a file named on the command line (not an `#include`): an error that
/// the file cannot be read names it.
pub(crate) fn load_main(sm: &mut SourceMap, path: &Path) -> Result<FileId, Diagnostics> {
    match load_file(sm, path) {
        Ok((id, None)) => Ok(id),
        Ok((_, Some(d))) => Err(d.into()),
        Err(e) => {
            Err(Diagnostic::error_nowhere(format!("cannot read '{}': {e}", path.display())).into())
        }
    }
}

pub(crate) fn load_file(
    sm: &mut SourceMap,
    path: &Path,
) -> Result<(FileId, Option<Diagnostic>), String> {
    let canon = std::fs::canonicalize(path).unwrap_or_else(|_| path.to_path_buf());
    if let Some(id) = sm.find(&canon) {
        return Ok((id, None));
    }
    let meta = std::fs::metadata(path).map_err(|e| e.to_string())?;
    if meta.len() > MAX_FILE_BYTES as u64 {
        return Err(format!(
            "the file is {} bytes; the limit is {MAX_FILE_BYTES}",
            meta.len()
        ));
    }
    let bytes = std::fs::read(path).map_err(|e| e.to_string())?;
    match String::from_utf8(bytes) {
        Ok(text) => Ok((sm.add(canon, text), None)),
        Err(e) => {
            let at = e.utf8_error().valid_up_to();
            let byte = e.as_bytes()[at];
            let mut text = String::from_utf8_lossy(&e.as_bytes()[..at]).into_owned();
            text.push(' ');
            let id = sm.add(canon, text);
            let d = Diagnostic::error(
                format!("the file is not valid UTF-8: byte 0x{byte:02X} at offset {at}"),
                Span::new(id, at, at + 1),
                "this byte",
            );
            Ok((id, Some(d)))
        }
    }
}

/// The header every OSL shader may include; not found on the search path, it is built in.
const STDOSL: &str = "stdosl.h";

/// The mathematical constants OSL's standard header defines (`M_PI`…), predefined in OSL.
const OSL_CONSTANTS: &[(&str, f64)] = &[
    ("M_PI", std::f64::consts::PI),
    ("M_PI_2", std::f64::consts::FRAC_PI_2),
    ("M_PI_4", std::f64::consts::FRAC_PI_4),
    ("M_2_PI", std::f64::consts::FRAC_2_PI),
    ("M_2PI", std::f64::consts::TAU),
    ("M_4PI", 2.0 * std::f64::consts::TAU),
    ("M_2_SQRTPI", std::f64::consts::FRAC_2_SQRT_PI),
    ("M_E", std::f64::consts::E),
    ("M_LN2", std::f64::consts::LN_2),
    ("M_LN10", std::f64::consts::LN_10),
    ("M_LOG2E", std::f64::consts::LOG2_E),
    ("M_LOG10E", std::f64::consts::LOG10_E),
    ("M_SQRT2", std::f64::consts::SQRT_2),
    ("M_SQRT1_2", std::f64::consts::FRAC_1_SQRT_2),
];

/// Preprocesses `main` (already in `sm`) in `dialect` with `options`' include directories
/// and defines.
pub fn preprocess(
    sm: &mut SourceMap,
    main: FileId,
    dialect: Dialect,
    options: &Options,
) -> Result<Preprocessed, Diagnostics> {
    let mut pp = Pp {
        sm,
        dialect,
        include_dirs: &options.include_dirs,
        macros: HashMap::new(),
        out: Vec::new(),
        errors: Vec::new(),
        warnings: Vec::new(),
        chain: Vec::new(),
        once: HashSet::new(),
        include_chains: HashMap::new(),
        lexed: HashMap::new(),
        budget: MAX_TOKENS,
        scan_budget: MAX_SCANNED,
        stop: false,
    };
    let mut pre = String::from("#define __SHADENET__ 1\n");
    match dialect {
        Dialect::Rsl => pre.push_str("#define __RSL__ 1\n"),
        Dialect::Osl => {
            pre.push_str(
                "#define __OSL__ 1\n#define OSL_VERSION_MAJOR 1\n#define OSL_VERSION_MINOR 13\n\
                 #define OSL_VERSION_PATCH 0\n#define OSL_VERSION 11300\n",
            );
            for (name, value) in OSL_CONSTANTS {
                pre.push_str(&format!("#define {name} {value:?}\n"));
            }
        }
    }
    for (name, value) in &options.defines {
        let value = value.replace(['\n', '\r'], " ");
        pre.push_str(&format!("#define {name} {value}\n"));
    }
    let pre_id = pp.sm.add("<predefined>", pre);
    pp.file(pre_id);
    pp.out.clear();
    pp.file(main);
    if pp.errors.is_empty() {
        Ok(Preprocessed {
            tokens: pp.out,
            warnings: pp.warnings,
            include_chains: pp.include_chains,
        })
    } else {
        Err(Diagnostics(pp.errors))
    }
}

/// One `#if` group being read.
struct Cond {
    /// The `#if`/`#ifdef`/`#ifndef` that opened it.
    at: Span,
    /// Whether the lines of the current branch are kept.
    active: bool,
    /// Whether a branch was taken already (or the whole group is inside a skipped one).
    taken: bool,
    /// Whether `#else` was seen.
    seen_else: bool,
}

struct Pp<'a> {
    sm: &'a mut SourceMap,
    dialect: Dialect,
    include_dirs: &'a [PathBuf],
    macros: HashMap<String, Macro>,
    out: Vec<Token>,
    errors: Vec<Diagnostic>,
    warnings: Vec<Diagnostic>,
    /// The `#include` directives being processed, outermost first.
    chain: Vec<(FileId, Span)>,
    /// Files with `#pragma once`.
    once: HashSet<FileId>,
    include_chains: HashMap<FileId, Vec<Span>>,
    /// Each file's tokens, lexed once.
    lexed: HashMap<FileId, Rc<Vec<Token>>>,
    budget: usize,
    /// Tokens that may still be read ([`MAX_SCANNED`]).
    scan_budget: usize,
    /// Set by an error after which going on would only add noise.
    stop: bool,
}

impl Pp<'_> {
    fn error(&mut self, mut d: Diagnostic) {
        d.include_chain = self.chain.iter().rev().map(|(_, s)| *s).collect();
        self.errors.push(d);
    }

    fn warning(&mut self, mut d: Diagnostic) {
        d.include_chain = self.chain.iter().rev().map(|(_, s)| *s).collect();
        self.warnings.push(d);
    }

    /// Processes one file's tokens into `self.out`.
    fn file(&mut self, file: FileId) {
        let tokens = match self.lexed.get(&file) {
            Some(t) => Rc::clone(t),
            None => {
                let lexed = lex(&self.sm.file(file).text, file, self.dialect);
                if !lexed.errors.is_empty() {
                    for e in lexed.errors {
                        self.error(e);
                    }
                    self.stop = true;
                    return;
                }
                let t = Rc::new(lexed.tokens);
                self.lexed.insert(file, Rc::clone(&t));
                t
            }
        };
        if tokens.len() > self.scan_budget {
            self.error(
                Diagnostic::error(
                    format!("the files read hold more than {MAX_SCANNED} tokens in all"),
                    Span::new(file, 0, 0),
                    "the limit was reached reading this file",
                )
                .with_note("a file included many times is read each time"),
            );
            self.stop = true;
            return;
        }
        self.scan_budget -= tokens.len();
        let mut conds: Vec<Cond> = Vec::new();
        let mut run: Vec<Token> = Vec::new();
        let mut i = 0;
        while i < tokens.len() && !self.stop {
            let t = tokens[i];
            if t.kind == TokenKind::Hash && t.line_start {
                self.flush(&mut run);
                let end = tokens[i + 1..]
                    .iter()
                    .position(|u| u.line_start)
                    .map_or(tokens.len(), |k| i + 1 + k);
                self.directive(file, t, &tokens[i + 1..end], &mut conds);
                i = end;
                continue;
            }
            if conds.last().is_none_or(|c| c.active) {
                run.push(t);
            }
            i += 1;
        }
        self.flush(&mut run);
        if !self.stop
            && let Some(c) = conds.first()
        {
            let at = c.at;
            self.error(Diagnostic::error(
                "unterminated conditional directive",
                at,
                "this group has no '#endif'",
            ));
        }
    }

    /// Expands the pending text tokens into `self.out`.
    fn flush(&mut self, run: &mut Vec<Token>) {
        if run.is_empty() || self.stop {
            run.clear();
            return;
        }
        let mut ex = Expander {
            sm: self.sm,
            macros: &self.macros,
            budget: &mut self.budget,
            if_mode: false,
        };
        let r = ex.expand(run, &mut Vec::new(), 0, &mut self.out);
        run.clear();
        if let Err(e) = r {
            self.error(*e);
            self.stop = true;
        }
    }

    fn directive(&mut self, file: FileId, hash: Token, line: &[Token], conds: &mut Vec<Cond>) {
        let Some(&name_tok) = line.first() else {
            return; // the null directive
        };
        let name = self.sm.text(name_tok.text).to_string();
        let at = hash.span.to(name_tok.span);
        let rest = &line[1..];
        let active = conds.last().is_none_or(|c| c.active);
        match name.as_str() {
            "if" | "ifdef" | "ifndef" => {
                let v = if !active {
                    None
                } else if name == "if" {
                    self.if_value(rest, at)
                } else {
                    self.defined_value(rest, at, name == "ifndef")
                };
                let on = v == Some(true);
                conds.push(Cond {
                    at,
                    active: on,
                    taken: on || !active,
                    seen_else: false,
                });
            }
            "elif" | "else" => {
                let Some(c) = conds.last() else {
                    self.error(Diagnostic::error(
                        format!("#{name} without #if"),
                        at,
                        "no open #if",
                    ));
                    return;
                };
                if c.seen_else {
                    self.error(Diagnostic::error(
                        format!("#{name} after #else"),
                        at,
                        "this group already had its #else",
                    ));
                    return;
                }
                let (taken, is_else) = (c.taken, name == "else");
                let on = !taken && (is_else || self.if_value(rest, at) == Some(true));
                if let Some(c) = conds.last_mut() {
                    c.active = on;
                    c.taken |= on;
                    c.seen_else = is_else;
                }
            }
            "endif" => {
                if conds.pop().is_none() {
                    self.error(Diagnostic::error("#endif without #if", at, "no open #if"));
                }
            }
            _ if !active => {}
            "define" => self.define(rest, at),
            "undef" => match rest.first() {
                Some(n) if matches!(n.kind, TokenKind::Ident | TokenKind::Keyword(_)) => {
                    let n = self.sm.text(n.text).to_string();
                    self.macros.remove(&n);
                }
                _ => self.error(Diagnostic::error(
                    "expected a macro name after #undef",
                    at,
                    "no name",
                )),
            },
            "include" => self.include(file, rest, at),
            "pragma" => {
                let what = rest
                    .first()
                    .map_or("", |t| self.sm.text(t.text))
                    .to_string();
                if what == "once" {
                    self.once.insert(file);
                } else {
                    let span = rest.iter().fold(at, |s, t| s.to(t.span));
                    self.warning(
                        Diagnostic::warning(
                            format!("unknown pragma '{what}' ignored"),
                            span,
                            "ignored",
                        )
                        .with_note("the only pragma understood is '#pragma once'"),
                    );
                }
            }
            "error" | "warning" => {
                let span = rest.iter().fold(at, |s, t| s.to(t.span));
                let msg = match (rest.first(), rest.last()) {
                    (Some(a), Some(b)) => self.sm.text(a.span.to(b.span)).to_string(),
                    _ => String::new(),
                };
                let msg = format!("#{name} {msg}");
                if name == "error" {
                    self.error(Diagnostic::error(msg, span, ""));
                } else {
                    self.warning(Diagnostic::warning(msg, span, ""));
                }
            }
            _ => self.error(
                Diagnostic::error(
                    format!("unknown preprocessor directive '#{name}'"),
                    at,
                    "not a directive",
                )
                .with_note(
                    "directives: include, define, undef, if, ifdef, ifndef, elif, else, endif, \
                 pragma, error, warning",
                ),
            ),
        }
    }

    /// The value of `#ifdef X` (or `#ifndef X` when `negate`).
    fn defined_value(&mut self, rest: &[Token], at: Span, negate: bool) -> Option<bool> {
        match rest.first() {
            Some(n) if matches!(n.kind, TokenKind::Ident | TokenKind::Keyword(_)) => {
                let d = self.macros.contains_key(self.sm.text(n.text));
                Some(d != negate)
            }
            _ => {
                self.error(Diagnostic::error(
                    "expected a macro name",
                    at,
                    "this directive needs a name",
                ));
                None
            }
        }
    }

    /// The value of a `#if` / `#elif` expression (`None` after an error).
    fn if_value(&mut self, rest: &[Token], at: Span) -> Option<bool> {
        let mut expanded = Vec::new();
        let mut ex = Expander {
            sm: self.sm,
            macros: &self.macros,
            budget: &mut self.budget,
            if_mode: true,
        };
        let r = ex
            .expand(rest, &mut Vec::new(), 0, &mut expanded)
            .and_then(|()| ifexpr::eval(&expanded, self.sm, &self.macros, at));
        match r {
            Ok(v) => Some(v != 0),
            Err(e) => {
                self.error(*e);
                None
            }
        }
    }

    fn define(&mut self, rest: &[Token], at: Span) {
        let Some(&name) = rest
            .first()
            .filter(|n| matches!(n.kind, TokenKind::Ident | TokenKind::Keyword(_)))
        else {
            self.error(Diagnostic::error(
                "expected a macro name after #define",
                rest.first().map_or(at, |t| t.span),
                "not a name",
            ));
            return;
        };
        let name_text = self.sm.text(name.text).to_string();
        if name_text == "defined" {
            self.error(Diagnostic::error(
                "'defined' cannot be a macro name",
                name.span,
                "reserved",
            ));
            return;
        }
        let mut body_start = 1;
        let mut params = None;
        if rest
            .get(1)
            .is_some_and(|p| p.kind == TokenKind::LParen && p.span.start == name.span.end)
        {
            let mut ps: Vec<String> = Vec::new();
            let mut j = 2;
            let mut ok = false;
            let mut expect_name = true;
            while let Some(t) = rest.get(j) {
                j += 1;
                match t.kind {
                    TokenKind::RParen if !expect_name || ps.is_empty() => {
                        ok = true;
                        break;
                    }
                    TokenKind::Comma if !expect_name => expect_name = true,
                    TokenKind::Ident | TokenKind::Keyword(_) if expect_name => {
                        let p = self.sm.text(t.text).to_string();
                        if ps.contains(&p) {
                            self.error(Diagnostic::error(
                                format!("duplicate macro parameter '{p}'"),
                                t.span,
                                "already a parameter",
                            ));
                            return;
                        }
                        ps.push(p);
                        expect_name = false;
                    }
                    _ => break,
                }
            }
            if !ok {
                let bad = rest.get(j.saturating_sub(1)).map_or(name.span, |t| t.span);
                self.error(Diagnostic::error(
                    format!("bad parameter list in the definition of macro '{name_text}'"),
                    bad,
                    "expected a parameter name, ',' or ')'",
                ));
                return;
            }
            body_start = j;
            params = Some(ps);
        }
        let body = rest[body_start.min(rest.len())..].to_vec();
        if let Some(h) = body.iter().find(|t| t.kind == TokenKind::Hash) {
            self.error(Diagnostic::error(
                "'#' and '##' are not supported in macro bodies",
                h.span,
                "stringizing and token pasting are not implemented",
            ));
            return;
        }
        self.macros.insert(
            name_text,
            Macro {
                name_span: name.span,
                params,
                body,
            },
        );
    }

    fn include(&mut self, file: FileId, rest: &[Token], at: Span) {
        let (target, angle) = match rest {
            [s] if s.kind == TokenKind::Str => {
                let t = self.sm.text(s.text);
                (t[1..t.len() - 1].to_string(), false)
            }
            [lt, .., gt] if lt.kind == TokenKind::Lt && gt.kind == TokenKind::Gt => {
                let inner = Span {
                    file,
                    start: lt.span.end,
                    end: gt.span.start,
                };
                (self.sm.text(inner).trim().to_string(), true)
            }
            _ => {
                self.error(Diagnostic::error(
                    "expected \"file\" or <file> after #include",
                    rest.iter().fold(at, |s, t| s.to(t.span)),
                    "not a file name",
                ));
                return;
            }
        };
        let at = rest.iter().fold(at, |s, t| s.to(t.span));
        if self.chain.len() >= MAX_INCLUDE_DEPTH {
            self.error(Diagnostic::error(
                format!("#include nested deeper than {MAX_INCLUDE_DEPTH} levels"),
                at,
                "too deep here",
            ));
            self.stop = true;
            return;
        }
        let mut dirs: Vec<PathBuf> = Vec::new();
        if !angle {
            let here = self.sm.file(file).path.parent().map(Path::to_path_buf);
            dirs.push(
                here.filter(|p| !p.as_os_str().is_empty())
                    .unwrap_or(".".into()),
            );
        }
        dirs.extend(self.include_dirs.iter().cloned());
        let found = dirs.iter().map(|d| d.join(&target)).find(|p| p.is_file());
        if found.is_none() && self.dialect == Dialect::Osl && target == STDOSL {
            // OSL's standard header: its functions are our builtins and its constants are
            // predefined, so there is nothing to read.
            return;
        }
        let Some(path) = found else {
            let searched: Vec<String> = dirs.iter().map(|d| d.display().to_string()).collect();
            self.error(
                Diagnostic::error(
                    format!("cannot find include file '{target}'"),
                    at,
                    "included here",
                )
                .with_note(format!("searched: {}", searched.join(", "))),
            );
            return;
        };
        let id = match load_file(self.sm, &path) {
            Ok((id, None)) => id,
            Ok((_, Some(d))) => {
                self.chain.push((file, at));
                self.error(d);
                self.chain.pop();
                self.stop = true;
                return;
            }
            Err(e) => {
                self.error(Diagnostic::error(
                    format!("cannot read include file '{}': {e}", path.display()),
                    at,
                    "included here",
                ));
                return;
            }
        };
        if id == file || self.chain.iter().any(|(f, _)| *f == id) {
            let mut names: Vec<String> = self
                .chain
                .iter()
                .map(|(f, _)| self.sm.file(*f).name.clone())
                .collect();
            names.push(self.sm.file(file).name.clone());
            names.push(self.sm.file(id).name.clone());
            let first = names
                .iter()
                .position(|n| *n == self.sm.file(id).name)
                .unwrap_or(0);
            self.error(
                Diagnostic::error(
                    "#include cycle",
                    at,
                    format!("'{target}' is already being included"),
                )
                .with_note(format!("cycle: {}", names[first..].join(" -> "))),
            );
            self.stop = true;
            return;
        }
        if self.once.contains(&id) {
            return;
        }
        self.chain.push((file, at));
        let chain = self.chain.iter().rev().map(|(_, s)| *s).collect();
        self.include_chains.entry(id).or_insert(chain);
        self.file(id);
        self.chain.pop();
    }
}
