//! The lexer: source text to [`Token`]s with spans. It owns the token kinds (every operator
//! and punctuation of RSL and OSL, the keywords of each dialect), the literal forms and
//! comments, and its errors (an unterminated comment or string is reported at its start; a
//! character that starts no token is reported by name and position, and lexing goes on).
//!
//! Literal forms: integers `12`, `0x1F`; floats `1.`, `.5`, `1.5`, `1e-3`, `2.5E+2`. A
//! letter or digit run glued to a number (`1.0f`, `3px`) is an error ("invalid suffix"):
//! neither RSL nor OSL has C's `f` suffix. Strings are `"…"` on one line with the escapes
//! `\n \t \r \a \b \f \v \\ \" \' \?`, octal `\0`–`\377` and hex `\xHH`.
//!
//! A backslash at the end of a line joins it to the next (for multi-line `#define`s).
//! In OSL, the words `and`, `or`, `not` are the operators `&&`, `||`, `!`.

use crate::diag::Diagnostic;
use crate::options::Dialect;
use crate::source::{FileId, Span};

/// A keyword. Which words are keywords depends on the dialect ([`Keyword::lookup`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
#[allow(missing_docs)] // each variant is the keyword of the same name
pub enum Keyword {
    Float,
    Int,
    Point,
    Vector,
    Normal,
    Color,
    Matrix,
    String,
    Void,
    Closure,
    Struct,
    Uniform,
    Varying,
    Output,
    Extern,
    If,
    Else,
    For,
    While,
    Do,
    Break,
    Continue,
    Return,
    Illuminance,
    Illuminate,
    Solar,
    Surface,
    Light,
    Volume,
    Displacement,
    Imager,
    Shader,
}

const KEYWORDS: &[(&str, Keyword, Option<Dialect>)] = &[
    ("float", Keyword::Float, None),
    ("int", Keyword::Int, None),
    ("point", Keyword::Point, None),
    ("vector", Keyword::Vector, None),
    ("normal", Keyword::Normal, None),
    ("color", Keyword::Color, None),
    ("matrix", Keyword::Matrix, None),
    ("string", Keyword::String, None),
    ("void", Keyword::Void, None),
    ("closure", Keyword::Closure, Some(Dialect::Osl)),
    ("struct", Keyword::Struct, Some(Dialect::Osl)),
    ("uniform", Keyword::Uniform, None),
    ("varying", Keyword::Varying, None),
    ("output", Keyword::Output, None),
    ("extern", Keyword::Extern, Some(Dialect::Rsl)),
    ("if", Keyword::If, None),
    ("else", Keyword::Else, None),
    ("for", Keyword::For, None),
    ("while", Keyword::While, None),
    ("do", Keyword::Do, Some(Dialect::Osl)),
    ("break", Keyword::Break, None),
    ("continue", Keyword::Continue, None),
    ("return", Keyword::Return, None),
    ("illuminance", Keyword::Illuminance, Some(Dialect::Rsl)),
    ("illuminate", Keyword::Illuminate, Some(Dialect::Rsl)),
    ("solar", Keyword::Solar, Some(Dialect::Rsl)),
    // OSL's shader types are names, not keywords (`surface` is a parameter of MaterialX's
    // `mx_surfacematerial`): the parser takes them as the kind where an item begins.
    ("surface", Keyword::Surface, Some(Dialect::Rsl)),
    ("light", Keyword::Light, Some(Dialect::Rsl)),
    ("volume", Keyword::Volume, Some(Dialect::Rsl)),
    ("displacement", Keyword::Displacement, Some(Dialect::Rsl)),
    ("imager", Keyword::Imager, Some(Dialect::Rsl)),
    ("shader", Keyword::Shader, Some(Dialect::Osl)),
];

impl Keyword {
    /// The keyword spelled `word` in `dialect`, if it is one there.
    pub fn lookup(word: &str, dialect: Dialect) -> Option<Keyword> {
        KEYWORDS
            .iter()
            .find(|(w, _, d)| *w == word && d.is_none_or(|d| d == dialect))
            .map(|(_, k, _)| *k)
    }

    /// How it is spelled.
    pub fn as_str(self) -> &'static str {
        KEYWORDS
            .iter()
            .find(|(_, k, _)| *k == self)
            .map_or("?", |(w, _, _)| w)
    }
}

/// What a token is. Identifier, number and string tokens carry no value: their text is the
/// source text at [`Token::text`].
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
#[allow(missing_docs)] // punctuation variants are named after their characters
pub enum TokenKind {
    /// A name that is not a keyword of the dialect.
    Ident,
    /// A keyword.
    Keyword(Keyword),
    /// An integer literal.
    Int,
    /// A floating-point literal.
    Float,
    /// A string literal, quotes included in its text.
    Str,
    /// `#`, only meaningful to the preprocessor.
    Hash,
    Plus,
    Minus,
    Star,
    Slash,
    Percent,
    Caret,
    Dot,
    Comma,
    Semi,
    Colon,
    Question,
    Bang,
    Tilde,
    Eq,
    PlusEq,
    MinusEq,
    StarEq,
    SlashEq,
    PercentEq,
    AmpEq,
    PipeEq,
    CaretEq,
    ShlEq,
    ShrEq,
    EqEq,
    NotEq,
    Lt,
    Le,
    Gt,
    Ge,
    AndAnd,
    OrOr,
    Amp,
    Pipe,
    Shl,
    Shr,
    PlusPlus,
    MinusMinus,
    LParen,
    RParen,
    LBracket,
    RBracket,
    LBrace,
    RBrace,
}

/// Punctuation, longest first (the lexer takes the first that matches).
const PUNCT: &[(&str, TokenKind)] = &[
    ("<<=", TokenKind::ShlEq),
    (">>=", TokenKind::ShrEq),
    ("+=", TokenKind::PlusEq),
    ("-=", TokenKind::MinusEq),
    ("*=", TokenKind::StarEq),
    ("/=", TokenKind::SlashEq),
    ("%=", TokenKind::PercentEq),
    ("&=", TokenKind::AmpEq),
    ("|=", TokenKind::PipeEq),
    ("^=", TokenKind::CaretEq),
    ("==", TokenKind::EqEq),
    ("!=", TokenKind::NotEq),
    ("<=", TokenKind::Le),
    (">=", TokenKind::Ge),
    ("&&", TokenKind::AndAnd),
    ("||", TokenKind::OrOr),
    ("<<", TokenKind::Shl),
    (">>", TokenKind::Shr),
    ("++", TokenKind::PlusPlus),
    ("--", TokenKind::MinusMinus),
    ("+", TokenKind::Plus),
    ("-", TokenKind::Minus),
    ("*", TokenKind::Star),
    ("/", TokenKind::Slash),
    ("%", TokenKind::Percent),
    ("^", TokenKind::Caret),
    (".", TokenKind::Dot),
    (",", TokenKind::Comma),
    (";", TokenKind::Semi),
    (":", TokenKind::Colon),
    ("?", TokenKind::Question),
    ("!", TokenKind::Bang),
    ("~", TokenKind::Tilde),
    ("=", TokenKind::Eq),
    ("<", TokenKind::Lt),
    (">", TokenKind::Gt),
    ("&", TokenKind::Amp),
    ("|", TokenKind::Pipe),
    ("(", TokenKind::LParen),
    (")", TokenKind::RParen),
    ("[", TokenKind::LBracket),
    ("]", TokenKind::RBracket),
    ("{", TokenKind::LBrace),
    ("}", TokenKind::RBrace),
    ("#", TokenKind::Hash),
];

impl TokenKind {
    /// The spelling of a punctuation or keyword token; a description for the others
    /// (`identifier`, `number`, `string`).
    pub fn as_str(self) -> &'static str {
        match self {
            TokenKind::Ident => "identifier",
            TokenKind::Keyword(k) => k.as_str(),
            TokenKind::Int | TokenKind::Float => "number",
            TokenKind::Str => "string",
            p => PUNCT.iter().find(|(_, k)| *k == p).map_or("?", |(s, _)| s),
        }
    }
}

/// One token.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Token {
    /// What it is.
    pub kind: TokenKind,
    /// Where diagnostics point: the token itself, or for a token produced by a macro, the
    /// macro invocation.
    pub span: Span,
    /// Where its text is: the token itself, or its place in the macro's definition.
    pub text: Span,
    /// Whether it is the first token of its line (directives start with such a `#`).
    pub line_start: bool,
}

/// The tokens of one file and the errors found while lexing it.
pub struct Lexed {
    /// The tokens, in order.
    pub tokens: Vec<Token>,
    /// Errors (the lexer skips a stray character and goes on; it stops at an unterminated
    /// comment).
    pub errors: Vec<Diagnostic>,
}

/// Lexes `text`, the contents of `file`, in `dialect`.
pub fn lex(text: &str, file: FileId, dialect: Dialect) -> Lexed {
    let b = text.as_bytes();
    let mut tokens = Vec::new();
    let mut errors = Vec::new();
    let mut i = 0;
    let mut line_start = true;
    let span = |s: usize, e: usize| Span::new(file, s, e);
    while i < b.len() {
        let c = b[i];
        // Whitespace, line continuations and comments.
        if c == b'\n' {
            line_start = true;
            i += 1;
            continue;
        }
        if c == b' ' || c == b'\t' || c == b'\r' || c == 0x0c || c == 0x0b {
            i += 1;
            continue;
        }
        if c == b'\\' {
            let mut j = i + 1;
            if b.get(j) == Some(&b'\r') {
                j += 1;
            }
            if b.get(j) == Some(&b'\n') {
                i = j + 1;
                continue;
            }
        }
        if b[i..].starts_with(b"//") {
            while i < b.len() && b[i] != b'\n' {
                i += 1;
            }
            continue;
        }
        if b[i..].starts_with(b"/*") {
            match text[i + 2..].find("*/") {
                Some(k) => {
                    // A comment spanning lines still ends a directive line.
                    if text[i..i + 2 + k].contains('\n') {
                        line_start = true;
                    }
                    i += k + 4;
                }
                None => {
                    errors.push(Diagnostic::error(
                        "unterminated comment",
                        span(i, i + 2),
                        "this comment has no closing '*/'",
                    ));
                    break;
                }
            }
            continue;
        }
        let start = i;
        let kind = if c.is_ascii_alphabetic() || c == b'_' {
            while i < b.len() && (b[i].is_ascii_alphanumeric() || b[i] == b'_') {
                i += 1;
            }
            let word = &text[start..i];
            match (dialect, word) {
                (Dialect::Osl, "and") => TokenKind::AndAnd,
                (Dialect::Osl, "or") => TokenKind::OrOr,
                (Dialect::Osl, "not") => TokenKind::Bang,
                _ => Keyword::lookup(word, dialect).map_or(TokenKind::Ident, TokenKind::Keyword),
            }
        } else if c.is_ascii_digit() || (c == b'.' && b.get(i + 1).is_some_and(u8::is_ascii_digit))
        {
            let (kind, end) = lex_number(text, start, file, &mut errors);
            i = end;
            kind
        } else if c == b'"' {
            match string_end(b, start) {
                Ok(end) => {
                    if let Err((bad, msg)) = decode_string(&text[start + 1..end - 1]) {
                        let (s, e) = (start + 1 + bad.start, start + 1 + bad.end);
                        errors.push(Diagnostic::error(msg, span(s, e), "in this string"));
                    }
                    i = end;
                    TokenKind::Str
                }
                Err(()) => {
                    errors.push(Diagnostic::error(
                        "unterminated string",
                        span(start, start + 1),
                        "this string has no closing '\"' on its line",
                    ));
                    while i < b.len() && b[i] != b'\n' {
                        i += 1;
                    }
                    continue;
                }
            }
        } else if let Some((p, k)) = PUNCT.iter().find(|(p, _)| b[i..].starts_with(p.as_bytes())) {
            i += p.len();
            *k
        } else {
            let ch = text[i..].chars().next().unwrap_or('\u{fffd}');
            i += ch.len_utf8();
            errors.push(Diagnostic::error(
                format!("unexpected character {:?} (U+{:04X})", ch, ch as u32),
                span(start, i),
                "no token starts with this character",
            ));
            continue;
        };
        tokens.push(Token {
            kind,
            span: span(start, i),
            text: span(start, i),
            line_start,
        });
        line_start = false;
    }
    Lexed { tokens, errors }
}

/// Lexes the number starting at `start`; returns its kind and end.
fn lex_number(
    text: &str,
    start: usize,
    file: FileId,
    errors: &mut Vec<Diagnostic>,
) -> (TokenKind, usize) {
    let b = text.as_bytes();
    let mut i = start;
    let digits = |i: &mut usize| {
        while *i < b.len() && b[*i].is_ascii_digit() {
            *i += 1;
        }
    };
    let mut kind = TokenKind::Int;
    if b[i] == b'0' && matches!(b.get(i + 1), Some(b'x' | b'X')) {
        i += 2;
        let h = i;
        while i < b.len() && b[i].is_ascii_hexdigit() {
            i += 1;
        }
        if i == h {
            errors.push(Diagnostic::error(
                "hexadecimal number has no digits",
                Span::new(file, start, i),
                "expected hexadecimal digits after '0x'",
            ));
        }
    } else {
        digits(&mut i);
        if b.get(i) == Some(&b'.') {
            kind = TokenKind::Float;
            i += 1;
            digits(&mut i);
        }
        if matches!(b.get(i), Some(b'e' | b'E')) {
            let mut j = i + 1;
            if matches!(b.get(j), Some(b'+' | b'-')) {
                j += 1;
            }
            if b.get(j).is_some_and(u8::is_ascii_digit) {
                kind = TokenKind::Float;
                i = j;
                digits(&mut i);
            } else {
                errors.push(Diagnostic::error(
                    "exponent has no digits",
                    Span::new(file, start, j),
                    "expected digits after the exponent",
                ));
                i = j;
            }
        }
    }
    if i < b.len() && (b[i].is_ascii_alphanumeric() || b[i] == b'_') {
        let s = i;
        while i < b.len() && (b[i].is_ascii_alphanumeric() || b[i] == b'_') {
            i += 1;
        }
        errors.push(Diagnostic::error(
            format!(
                "invalid suffix '{}' on number '{}'",
                &text[s..i],
                &text[start..s]
            ),
            Span::new(file, start, i),
            "numbers take no suffix in RSL or OSL",
        ));
    }
    (kind, i)
}

/// End (one past the closing quote) of the string starting at `start`, or `Err` if it is
/// not closed on its line.
fn string_end(b: &[u8], start: usize) -> Result<usize, ()> {
    let mut i = start + 1;
    while i < b.len() {
        match b[i] {
            b'"' => return Ok(i + 1),
            b'\n' => return Err(()),
            b'\\' if i + 1 < b.len() && b[i + 1] != b'\n' => i += 2,
            _ => i += 1,
        }
    }
    Err(())
}

/// The value of a string literal's contents (`raw`, without the quotes), or the byte range
/// in `raw` and message of its first bad escape.
pub fn decode_string(raw: &str) -> Result<String, (std::ops::Range<usize>, String)> {
    let mut out = String::with_capacity(raw.len());
    let mut chars = raw.char_indices().peekable();
    while let Some((at, c)) = chars.next() {
        if c != '\\' {
            out.push(c);
            continue;
        }
        let Some((_, e)) = chars.next() else {
            return Err((at..at + 1, "a string ends with a lone '\\'".into()));
        };
        let bad = at..at + 1 + e.len_utf8();
        let simple = match e {
            'n' => Some('\n'),
            't' => Some('\t'),
            'r' => Some('\r'),
            'a' => Some('\x07'),
            'b' => Some('\x08'),
            'f' => Some('\x0c'),
            'v' => Some('\x0b'),
            '\\' | '"' | '\'' | '?' => Some(e),
            _ => None,
        };
        if let Some(s) = simple {
            out.push(s);
        } else if e.is_digit(8) {
            let mut v = e.to_digit(8).unwrap_or(0);
            for _ in 0..2 {
                match chars.peek() {
                    Some((_, d)) if d.is_digit(8) => {
                        v = v * 8 + d.to_digit(8).unwrap_or(0);
                        chars.next();
                    }
                    _ => break,
                }
            }
            if v > 0xff {
                return Err((bad, format!("octal escape '\\{v:o}' is over \\377")));
            }
            out.push(char::from(v as u8));
        } else if e == 'x' {
            let mut v = 0u32;
            let mut n = 0;
            while let Some((_, d)) = chars.peek() {
                match d.to_digit(16) {
                    Some(h) if n < 2 => {
                        v = v * 16 + h;
                        n += 1;
                        chars.next();
                    }
                    _ => break,
                }
            }
            if n == 0 {
                return Err((bad, "'\\x' escape has no hexadecimal digits".into()));
            }
            out.push(char::from(v as u8));
        } else {
            return Err((bad, format!("unknown escape '\\{e}' in a string")));
        }
    }
    Ok(out)
}
