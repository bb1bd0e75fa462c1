//! The lexer: every token kind, literal forms, comments, and its errors.

use shadenet_lang::lex::{Keyword, TokenKind, lex};
use shadenet_lang::{Dialect, FileId, SourceMap};

/// `(kind, text)` of each token of `src`.
fn toks(src: &str, d: Dialect) -> Vec<(TokenKind, String)> {
    let l = lex(src, FileId(0), d);
    assert!(l.errors.is_empty(), "{:?}", l.errors);
    l.tokens
        .iter()
        .map(|t| (t.kind, src[t.span.range()].to_string()))
        .collect()
}

fn kinds(src: &str, d: Dialect) -> Vec<TokenKind> {
    toks(src, d).into_iter().map(|(k, _)| k).collect()
}

/// The rendered errors of lexing `src` as file `t.sl`.
fn errors(src: &str) -> Vec<String> {
    let mut sm = SourceMap::new();
    let f = sm.add("t.sl", src.to_string());
    let l = lex(src, f, Dialect::Rsl);
    l.errors
        .iter()
        .map(|e| {
            format!(
                "{} at {}",
                e.message,
                sm.describe(e.primary.as_ref().unwrap().span)
            )
        })
        .collect()
}

#[test]
fn every_operator_and_punctuation() {
    use TokenKind::*;
    let src = "+ - * / % ^ . , ; : ? ! ~ = += -= *= /= %= &= |= ^= <<= >>= == != < <= > >= && || \
               & | << >> ++ -- ( ) [ ] { } #";
    let want = vec![
        Plus, Minus, Star, Slash, Percent, Caret, Dot, Comma, Semi, Colon, Question, Bang, Tilde,
        Eq, PlusEq, MinusEq, StarEq, SlashEq, PercentEq, AmpEq, PipeEq, CaretEq, ShlEq, ShrEq,
        EqEq, NotEq, Lt, Le, Gt, Ge, AndAnd, OrOr, Amp, Pipe, Shl, Shr, PlusPlus, MinusMinus,
        LParen, RParen, LBracket, RBracket, LBrace, RBrace, Hash,
    ];
    assert_eq!(kinds(src, Dialect::Rsl), want);
    // Longest match without spaces.
    assert_eq!(
        kinds("a+++b", Dialect::Rsl),
        vec![Ident, PlusPlus, Plus, Ident]
    );
    assert_eq!(
        kinds("a<<=b>>c", Dialect::Rsl),
        vec![Ident, ShlEq, Ident, Shr, Ident]
    );
    for (text, k) in [("+", Plus), ("<<=", ShlEq), ("#", Hash)] {
        assert_eq!(k.as_str(), text);
    }
}

#[test]
fn keywords_depend_on_the_dialect() {
    use TokenKind::*;
    let kw = |k| Keyword(k);
    assert_eq!(
        kinds(
            "float int point vector normal color matrix string void",
            Dialect::Rsl
        ),
        vec![
            kw(self::Keyword::Float),
            kw(self::Keyword::Int),
            kw(self::Keyword::Point),
            kw(self::Keyword::Vector),
            kw(self::Keyword::Normal),
            kw(self::Keyword::Color),
            kw(self::Keyword::Matrix),
            kw(self::Keyword::String),
            kw(self::Keyword::Void),
        ]
    );
    // RSL-only and OSL-only words.
    assert_eq!(
        kinds(
            "illuminance solar light imager extern shader closure struct do",
            Dialect::Rsl
        ),
        vec![
            kw(self::Keyword::Illuminance),
            kw(self::Keyword::Solar),
            kw(self::Keyword::Light),
            kw(self::Keyword::Imager),
            kw(self::Keyword::Extern),
            Ident,
            Ident,
            Ident,
            Ident,
        ]
    );
    assert_eq!(
        kinds(
            "illuminance solar light imager extern shader closure struct do",
            Dialect::Osl
        ),
        vec![
            Ident,
            Ident,
            Ident,
            Ident,
            Ident,
            kw(self::Keyword::Shader),
            kw(self::Keyword::Closure),
            kw(self::Keyword::Struct),
            kw(self::Keyword::Do),
        ]
    );
    // OSL's word operators.
    assert_eq!(
        kinds("a and b or not c", Dialect::Osl),
        vec![Ident, AndAnd, Ident, OrOr, Bang, Ident]
    );
    assert_eq!(kinds("a and b", Dialect::Rsl), vec![Ident, Ident, Ident]);
}

#[test]
fn literal_forms() {
    use TokenKind::*;
    let got = toks(
        "1 12 0x1F 1. .5 1.5 1e-3 2.5E+2 3e4 \"a\\n\\\"b\\\"\"",
        Dialect::Rsl,
    );
    let want: Vec<(TokenKind, String)> = [
        (Int, "1"),
        (Int, "12"),
        (Int, "0x1F"),
        (Float, "1."),
        (Float, ".5"),
        (Float, "1.5"),
        (Float, "1e-3"),
        (Float, "2.5E+2"),
        (Float, "3e4"),
        (Str, "\"a\\n\\\"b\\\"\""),
    ]
    .iter()
    .map(|(k, s)| (*k, s.to_string()))
    .collect();
    assert_eq!(got, want);
    // RSL's dot product between names is not a number.
    assert_eq!(kinds("N.L", Dialect::Rsl), vec![Ident, Dot, Ident]);
    assert_eq!(
        shadenet_lang::lex::decode_string(r#"a\tb\\\x41\101\"\?"#),
        Ok("a\tb\\AA\"?".to_string())
    );
}

#[test]
fn comments_and_line_starts() {
    use TokenKind::*;
    let src = "a // one\n/* two\n lines */ b /* c */ c\n  #x";
    let l = lex(src, FileId(0), Dialect::Rsl);
    let got: Vec<(TokenKind, &str, bool)> = l
        .tokens
        .iter()
        .map(|t| (t.kind, &src[t.span.range()], t.line_start))
        .collect();
    assert_eq!(
        got,
        vec![
            (Ident, "a", true),
            (Ident, "b", true),
            (Ident, "c", false),
            (Hash, "#", true),
            (Ident, "x", false),
        ]
    );
    // A backslash-newline joins lines.
    let l = lex("#define A \\\n 1\nb", FileId(0), Dialect::Rsl);
    let starts: Vec<bool> = l.tokens.iter().map(|t| t.line_start).collect();
    assert_eq!(starts, vec![true, false, false, false, true]);
}

#[test]
fn errors_name_the_place() {
    assert_eq!(
        errors("a /* open\n\n"),
        vec!["unterminated comment at t.sl:1:3"]
    );
    assert_eq!(
        errors("x = \"open\ny"),
        vec!["unterminated string at t.sl:1:5"]
    );
    assert_eq!(errors("\"open"), vec!["unterminated string at t.sl:1:1"]);
    assert_eq!(
        errors("a @ b\n  é $"),
        vec![
            "unexpected character '@' (U+0040) at t.sl:1:3",
            "unexpected character 'é' (U+00E9) at t.sl:2:3",
            "unexpected character '$' (U+0024) at t.sl:2:5",
        ]
    );
    assert_eq!(
        errors("1.0f + 3px"),
        vec![
            "invalid suffix 'f' on number '1.0' at t.sl:1:1",
            "invalid suffix 'px' on number '3' at t.sl:1:8",
        ]
    );
    assert_eq!(errors("1e+"), vec!["exponent has no digits at t.sl:1:1"]);
    assert_eq!(
        errors("0x"),
        vec!["hexadecimal number has no digits at t.sl:1:1"]
    );
    assert_eq!(
        errors("\"a\\qb\""),
        vec!["unknown escape '\\q' in a string at t.sl:1:3"]
    );
}
