//! OSL shader groups in OSL's serialized text (what `ShaderGroupBegin` reads and `testshade
//! --group` takes): statements ending in `;`
//!
//! ```text
//! param float scale 4.0 ;        // an instance value for the next layer's parameter
//! param color Cd 0.8 0.2 0.1 ;   // (the type may be left out; [[…]] metadata is skipped)
//! shader noisetex tex1 ;         // a layer `tex1` of shader `noisetex`
//! shader plastic mat ;
//! connect tex1.Cout mat.Cd ;     // an output of an earlier layer into a parameter
//! ```
//!
//! [`load`] reads a group file and the `.osl` source of each shader it names (looked up as
//! `NAME.osl` in the group file's folder, then the include folders), each parsed once;
//! [`crate::lower::compile_group`] lowers the whole group into one program. It owns the
//! group syntax and the shader lookup; it must not hold lowering rules.

use crate::diag::{Diagnostic, Diagnostics};
use crate::lex::{Token, TokenKind, lex};
use crate::source::{FileId, SourceMap, Span};
use crate::{Dialect, Options, Parsed};
use std::collections::HashMap;
use std::path::Path;

/// The most statements a group file may hold (a 2047-layer tree needs about 6 000).
pub const MAX_STATEMENTS: usize = 1 << 20;

/// A name in the group file, with where it is.
#[derive(Clone, Debug, PartialEq)]
pub struct Name {
    /// The text.
    pub name: String,
    /// Where.
    pub span: Span,
}

/// A value of a `param` statement.
#[derive(Clone, Debug, PartialEq)]
pub enum ParamValue {
    /// A number (ints and floats alike).
    Number(f64),
    /// A string.
    Str(String),
}

/// `param [TYPE] NAME VALUE… ;`: an instance value of the next layer's parameter.
#[derive(Clone, Debug, PartialEq)]
pub struct GroupParam {
    /// The type as written, if it was.
    pub ty: Option<String>,
    /// The parameter's name.
    pub name: Name,
    /// The values (one, or three for a triple).
    pub values: Vec<ParamValue>,
    /// The statement.
    pub span: Span,
}

/// `shader SHADER LAYER ;` with the `param` statements before it.
#[derive(Clone, Debug, PartialEq)]
pub struct Layer {
    /// The shader's name (its source is `SHADER.osl`).
    pub shader: Name,
    /// The layer's name, unique in the group.
    pub name: Name,
    /// Its instance values.
    pub params: Vec<GroupParam>,
}

/// `connect LAYER.OUTPUT LAYER.PARAM ;`.
#[derive(Clone, Debug, PartialEq)]
pub struct Connection {
    /// The upstream layer and its output parameter.
    pub from: (Name, Name),
    /// The downstream layer and its parameter.
    pub to: (Name, Name),
    /// The statement.
    pub span: Span,
}

/// A parsed group: its layers in order (the last is the group's output) and connections.
#[derive(Clone, Debug, PartialEq)]
pub struct Group {
    /// The group file in the source map.
    pub file: FileId,
    /// The layers, in order.
    pub layers: Vec<Layer>,
    /// The connections.
    pub connections: Vec<Connection>,
}

/// A group with the parsed source of every shader it names (by shader name).
#[derive(Debug)]
pub struct LoadedGroup {
    /// The group.
    pub group: Group,
    /// Each shader's parsed source.
    pub shaders: HashMap<String, Parsed>,
}

/// Reads the group file at `path` and the source of every shader it names. The shaders
/// are OSL whatever `options.dialect` says; `options`' include folders are searched after
/// the group file's own folder, and its defines apply.
pub fn load(
    sources: &mut SourceMap,
    path: &Path,
    options: &Options,
) -> Result<LoadedGroup, Diagnostics> {
    let file = crate::preprocess::load_main(sources, path)?;
    let group = parse(sources, file)?;
    let mut dirs = vec![
        path.parent()
            .filter(|p| !p.as_os_str().is_empty())
            .unwrap_or(Path::new("."))
            .to_path_buf(),
    ];
    dirs.extend(options.include_dirs.iter().cloned());
    let options = Options {
        dialect: Some(Dialect::Osl),
        ..options.clone()
    };
    let mut shaders = HashMap::new();
    let mut errors = Diagnostics::new();
    for layer in &group.layers {
        let name = &layer.shader.name;
        if shaders.contains_key(name) {
            continue;
        }
        let file_name = format!("{name}.osl");
        let Some(found) = dirs
            .iter()
            .map(|d| d.join(&file_name))
            .find(|p| p.is_file())
        else {
            let searched: Vec<String> = dirs.iter().map(|d| d.display().to_string()).collect();
            errors.push(
                Diagnostic::error(
                    format!("no source for shader `{name}`: '{file_name}' not found"),
                    layer.shader.span,
                    "this shader",
                )
                .with_note(format!("searched: {}", searched.join(", "))),
            );
            continue;
        };
        match crate::parse_file(sources, &found, &options) {
            Ok(p) => {
                shaders.insert(name.clone(), p);
            }
            Err(d) => errors.0.extend(d.0),
        }
    }
    if errors.has_errors() {
        return Err(errors);
    }
    Ok(LoadedGroup { group, shaders })
}

/// Parses group text already in the source map as `file`.
pub fn parse(sources: &SourceMap, file: FileId) -> Result<Group, Diagnostics> {
    let text = &sources.file(file).text;
    let lexed = lex(text, file, Dialect::Osl);
    if !lexed.errors.is_empty() {
        return Err(Diagnostics(lexed.errors));
    }
    let mut p = GroupParser {
        sources,
        tokens: &lexed.tokens,
        at: 0,
        file,
    };
    p.group()
}

struct GroupParser<'s> {
    sources: &'s SourceMap,
    tokens: &'s [Token],
    at: usize,
    file: FileId,
}

impl GroupParser<'_> {
    fn group(&mut self) -> Result<Group, Diagnostics> {
        let mut layers = Vec::new();
        let mut connections = Vec::new();
        let mut pending: Vec<GroupParam> = Vec::new();
        let mut statements = 0;
        while let Some(t) = self.peek() {
            statements += 1;
            if statements > MAX_STATEMENTS {
                return Err(Diagnostic::error(
                    format!("more than {MAX_STATEMENTS} statements in a shader group"),
                    t.span,
                    "here",
                )
                .into());
            }
            if t.kind == TokenKind::Semi {
                self.at += 1;
                continue;
            }
            let word = self.word("`param`, `shader` or `connect`")?;
            match word.name.as_str() {
                "param" => pending.push(self.param(word.span)?),
                "shader" => {
                    let shader = self.word("a shader name")?;
                    let name = self.word("a layer name")?;
                    self.end()?;
                    layers.push(Layer {
                        shader,
                        name,
                        params: std::mem::take(&mut pending),
                    });
                }
                "connect" => {
                    let from = self.dotted()?;
                    let to = self.dotted()?;
                    let span = word.span.to(to.1.span);
                    self.end()?;
                    connections.push(Connection { from, to, span });
                }
                other => {
                    return Err(Diagnostic::error(
                        format!("expected `param`, `shader` or `connect`, found `{other}`"),
                        word.span,
                        "not a group statement",
                    )
                    .into());
                }
            }
        }
        if let Some(p) = pending.first() {
            return Err(Diagnostic::error(
                "`param` after the last `shader`: a param sets the next layer's parameter",
                p.span,
                "no layer follows",
            )
            .into());
        }
        if layers.is_empty() {
            return Err(
                Diagnostic::error_nowhere("the shader group has no `shader` statement").into(),
            );
        }
        Ok(Group {
            file: self.file,
            layers,
            connections,
        })
    }

    /// `[TYPE] NAME VALUE… [[metadata]] ;` after `param`.
    fn param(&mut self, start: Span) -> Result<GroupParam, Diagnostics> {
        let first = self.word("a type or a parameter name")?;
        const TYPES: &[&str] = &[
            "float", "int", "color", "point", "vector", "normal", "string", "matrix",
        ];
        let next_is_word = self
            .peek()
            .is_some_and(|t| matches!(t.kind, TokenKind::Ident | TokenKind::Keyword(_)));
        let (ty, name) = if TYPES.contains(&first.name.as_str()) && next_is_word {
            (Some(first.name), self.word("a parameter name")?)
        } else {
            (None, first)
        };
        let mut values = Vec::new();
        loop {
            let Some(t) = self.peek().cloned() else {
                return Err(self.missing_semi(start));
            };
            match t.kind {
                TokenKind::Semi => {
                    self.at += 1;
                    break;
                }
                TokenKind::LBracket => self.skip_metadata()?,
                TokenKind::Str => {
                    let s = self.sources.text(t.text);
                    values.push(ParamValue::Str(s[1..s.len() - 1].to_string()));
                    self.at += 1;
                }
                TokenKind::Minus | TokenKind::Int | TokenKind::Float => {
                    values.push(ParamValue::Number(self.number()?))
                }
                _ => {
                    return Err(Diagnostic::error(
                        format!("expected a value or `;` in `param {}`", name.name),
                        t.span,
                        "not a value",
                    )
                    .into());
                }
            }
        }
        if values.is_empty() {
            return Err(Diagnostic::error(
                format!("`param {}` has no value", name.name),
                name.span,
                "no value",
            )
            .into());
        }
        let end = self.tokens[self.at - 1].span;
        Ok(GroupParam {
            ty,
            name,
            values,
            span: start.to(end),
        })
    }

    fn number(&mut self) -> Result<f64, Diagnostics> {
        let mut sign = 1.0;
        let t = self.peek().cloned();
        if t.as_ref().is_some_and(|t| t.kind == TokenKind::Minus) {
            sign = -1.0;
            self.at += 1;
        }
        match self.peek().cloned() {
            Some(t) if matches!(t.kind, TokenKind::Int | TokenKind::Float) => {
                self.at += 1;
                let text = self.sources.text(t.text).trim_end_matches(['f', 'F']);
                text.parse::<f64>()
                    .ok()
                    .filter(|x| x.is_finite())
                    .map(|x| sign * x)
                    .ok_or_else(|| {
                        Diagnostic::error(
                            format!("`{text}` is not a finite number"),
                            t.span,
                            "here",
                        )
                        .into()
                    })
            }
            other => Err(self.expected("a number", other.map(|t| t.span))),
        }
    }

    /// `[[ … ]]`, skipped.
    fn skip_metadata(&mut self) -> Result<(), Diagnostics> {
        let start = self.tokens[self.at].span;
        let mut depth = 0usize;
        while let Some(kind) = self.peek().map(|t| t.kind) {
            self.at += 1;
            match kind {
                TokenKind::LBracket => depth += 1,
                TokenKind::RBracket => {
                    depth = depth.saturating_sub(1);
                    if depth == 0 {
                        return Ok(());
                    }
                }
                _ => {}
            }
        }
        Err(Diagnostic::error("unterminated `[[` metadata", start, "opened here").into())
    }

    /// `LAYER.PARAM`.
    fn dotted(&mut self) -> Result<(Name, Name), Diagnostics> {
        let layer = self.word("LAYER.PARAM")?;
        match self.peek() {
            Some(t) if t.kind == TokenKind::Dot => self.at += 1,
            other => return Err(self.expected("`.` in LAYER.PARAM", other.map(|t| t.span))),
        }
        let param = self.word("a parameter name after `.`")?;
        Ok((layer, param))
    }

    fn end(&mut self) -> Result<(), Diagnostics> {
        match self.peek() {
            Some(t) if t.kind == TokenKind::Semi => {
                self.at += 1;
                Ok(())
            }
            None => Ok(()),
            Some(t) => Err(self.expected("`;`", Some(t.span))),
        }
    }

    fn word(&mut self, what: &str) -> Result<Name, Diagnostics> {
        match self.peek().cloned() {
            Some(t) if matches!(t.kind, TokenKind::Ident | TokenKind::Keyword(_)) => {
                self.at += 1;
                Ok(Name {
                    name: self.sources.text(t.text).to_string(),
                    span: t.span,
                })
            }
            other => Err(self.expected(what, other.map(|t| t.span))),
        }
    }

    fn expected(&self, what: &str, at: Option<Span>) -> Diagnostics {
        match at {
            Some(span) => Diagnostic::error(format!("expected {what}"), span, "here").into(),
            None => {
                Diagnostic::error_nowhere(format!("expected {what}, found the end of the group"))
                    .into()
            }
        }
    }

    fn missing_semi(&self, start: Span) -> Diagnostics {
        Diagnostic::error("a `param` statement must end with `;`", start, "this param").into()
    }

    fn peek(&self) -> Option<&Token> {
        self.tokens.get(self.at)
    }
}
