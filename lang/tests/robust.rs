//! Bad input never panics, hangs or overflows the stack: deep nesting hits the documented
//! limit with an error, and random bytes and token soups always return.

use proptest::prelude::*;
use shadenet_lang::parse::MAX_NESTING;
use shadenet_lang::{Dialect, Options, SourceMap, parse_str};

fn first_line(d: Dialect, src: &str) -> String {
    let mut sm = SourceMap::new();
    match parse_str(&mut sm, "t", src, &Options::new(d)) {
        Ok(p) => panic!("parsed: {}", p.file),
        Err(e) => e.render(&sm).lines().next().unwrap_or("").to_string(),
    }
}

/// Runs `f` on a thread with a 256 KiB stack: the front end runs on its own thread
/// (`STACK_BYTES`), so the caller's stack does not matter.
fn small_stack(f: impl FnOnce() + Send + 'static) {
    std::thread::Builder::new()
        .stack_size(256 << 10)
        .spawn(f)
        .unwrap()
        .join()
        .unwrap();
}

#[test]
fn deep_nesting_is_an_error_not_a_stack_overflow() {
    small_stack(|| {
        let want = format!("error: nesting deeper than {MAX_NESTING} levels");
        for d in [Dialect::Rsl, Dialect::Osl] {
            let head = if d == Dialect::Rsl {
                "surface"
            } else {
                "shader"
            };
            let n = 100_000;
            let cases = [
                format!("{head} s() {{ x = {}1{}; }}", "(".repeat(n), ")".repeat(n)),
                format!("{head} s() {{ x = {}1; }}", "-".repeat(n)),
                format!("{head} s() {{ x = {}1; }}", "!".repeat(n)),
                format!("{head} s() {{ {} }}", "{".repeat(n)),
                format!("{head} s() {{ {}x = 1; }}", "if (a) ".repeat(n)),
                format!("{head} s() {{ {}1; }}", "x = ".repeat(n)),
                format!("{head} s() {{ x = {}1; }}", "a ? b : ".repeat(n)),
                format!("{head} s() {{ x = {}1; }}", "f(".repeat(n)),
                format!("{head} s() {{ x = a{}; }}", "[b".repeat(n)),
                format!("{head} s() {{ float x[1] = {}; }}", "{".repeat(n)),
                format!("{head} s() {{ x = {}1; }}", "(float)".repeat(n)),
                format!("{head} s() {{ x = {}1; }}", "color ".repeat(n)),
            ];
            for src in &cases {
                assert_eq!(first_line(d, src), want, "{}", &src[..40]);
            }
        }
        // Just under the limit parses.
        let k = MAX_NESTING / 3;
        let src = format!("surface s() {{ x = {}1{}; }}", "(".repeat(k), ")".repeat(k));
        let mut sm = SourceMap::new();
        assert!(parse_str(&mut sm, "t.sl", &src, &Options::new(Dialect::Rsl)).is_ok());
    });
}

/// Every token the languages have, and some they do not.
const SOUP: &[&str] = &[
    "surface",
    "light",
    "volume",
    "displacement",
    "imager",
    "shader",
    "struct",
    "float",
    "int",
    "point",
    "vector",
    "normal",
    "color",
    "matrix",
    "string",
    "void",
    "closure",
    "uniform",
    "varying",
    "output",
    "extern",
    "if",
    "else",
    "for",
    "while",
    "do",
    "break",
    "continue",
    "return",
    "illuminance",
    "illuminate",
    "solar",
    "x",
    "P",
    "N",
    "f",
    "1",
    "2.5",
    ".5",
    "1e3",
    "\"s\"",
    "+",
    "-",
    "*",
    "/",
    "%",
    "^",
    ".",
    ",",
    ";",
    ":",
    "?",
    "!",
    "~",
    "=",
    "+=",
    "-=",
    "*=",
    "/=",
    "==",
    "!=",
    "<",
    "<=",
    ">",
    ">=",
    "&&",
    "||",
    "&",
    "|",
    "<<",
    ">>",
    "++",
    "--",
    "(",
    ")",
    "[",
    "]",
    "{",
    "}",
    "[[",
    "]]",
    "\n#define A(x) x x\n",
    "\n#define B A(B)\n",
    "\n#if 1\n",
    "\n#else\n",
    "\n#endif\n",
    "\n#include \"nope.h\"\n",
    "A(",
    "B",
    "#",
    "@",
    "/*",
    "*/",
    "//",
    "\\\n",
    "\n",
];

fn soup() -> impl Strategy<Value = String> {
    prop::collection::vec(0..SOUP.len(), 0..200)
        .prop_map(|ix| ix.iter().map(|&i| SOUP[i]).collect::<Vec<_>>().join(" "))
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 300, ..ProptestConfig::default() })]

    #[test]
    fn random_bytes_never_panic(bytes in prop::collection::vec(any::<u8>(), 0..400)) {
        let text = String::from_utf8_lossy(&bytes).into_owned();
        for d in [Dialect::Rsl, Dialect::Osl] {
            let mut sm = SourceMap::new();
            if let Err(e) = parse_str(&mut sm, "t", &text, &Options::new(d)) {
                prop_assert!(e.has_errors());
                prop_assert!(!e.render(&sm).is_empty());
            }
        }
    }

    #[test]
    fn token_soups_never_panic(text in soup()) {
        for d in [Dialect::Rsl, Dialect::Osl] {
            let mut sm = SourceMap::new();
            match parse_str(&mut sm, "t", &text, &Options::new(d)) {
                Ok(p) => { let _ = p.file.to_string(); }
                Err(e) => {
                    prop_assert!(e.has_errors());
                    prop_assert!(e.render(&sm).starts_with("error: "));
                }
            }
        }
    }

    #[test]
    fn shader_shaped_soups_never_panic(inner in soup()) {
        let text = format!("surface s(float a = 1) {{ {inner} }}");
        let mut sm = SourceMap::new();
        if let Err(e) = parse_str(&mut sm, "t", &text, &Options::new(Dialect::Rsl)) {
            prop_assert!(e.render(&sm).starts_with("error: "));
        }
    }
}
