//! The preprocessor: each directive, include search order, include cycles and missing
//! includes with their chains, macro limits, `#if` expressions and pragmas.

use shadenet_lang::{Dialect, Options, SourceMap, parse_file, parse_str};
use std::path::{Path, PathBuf};

/// A fresh temporary folder holding `files` (`(relative path, text)`).
fn tree(name: &str, files: &[(&str, &str)]) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("shadenet-lang-{name}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    for (path, text) in files {
        let p = dir.join(path);
        std::fs::create_dir_all(p.parent().unwrap()).unwrap();
        std::fs::write(p, text).unwrap();
    }
    dir.canonicalize().unwrap()
}

/// The parsed file printed, or the rendered errors, with `dir` written `DIR`.
fn run_file(path: &Path, opts: &Options, dir: &Path) -> Result<String, String> {
    let mut sm = SourceMap::new();
    let d = dir.display().to_string();
    match parse_file(&mut sm, path, opts) {
        Ok(p) => Ok(p.file.to_string()),
        Err(e) => Err(e.render(&sm).replace(&d, "DIR")),
    }
}

fn run(d: Dialect, src: &str) -> Result<String, String> {
    run_opts(src, &Options::new(d))
}

fn run_opts(src: &str, opts: &Options) -> Result<String, String> {
    let mut sm = SourceMap::new();
    match parse_str(&mut sm, "t.sl", src, opts) {
        Ok(p) => Ok(p.file.to_string()),
        Err(e) => Err(e.render(&sm)),
    }
}

fn first_line(r: Result<String, String>) -> String {
    match r {
        Ok(s) => panic!("no error: {s}"),
        Err(e) => e.lines().next().unwrap_or("").to_string(),
    }
}

#[test]
fn object_and_function_like_macros() {
    let src = "#define ONE 1\n\
               #define ADD(a, b) ((a) + (b))\n\
               #define TWICE(x) ADD(x, x)\n\
               #define NOARGS() 7\n\
               #define SPACED (x)\n\
               #define x x + 1\n\
               #define pa pb\n\
               #define pb pa\n\
               #define MULTI(a) \\\n  (a * \\\n 2)\n\
               surface s() {\n\
               a = TWICE(ONE); b = ADD(ONE, f(2, 3)); c = NOARGS(); d = SPACED;\n\
               e = pa; g = MULTI(3); h = ADD;\n\
               #undef ONE\n\
               i = ONE;\n\
               }\n";
    assert_eq!(
        run(Dialect::Rsl, src).unwrap(),
        "surface s() { (a = (1 + 1)); (b = (1 + f(2, 3))); (c = 7); (d = (x + 1)); (e = pa); \
         (g = (3 * 2)); (h = ADD); (i = ONE); }\n"
    );
}

#[test]
fn conditionals_and_if_expressions() {
    let src = "surface s() {\n\
               #if defined(__RSL__) && !defined __OSL__\n  rsl;\n#elif 1\n  no1;\n#else\n  no2;\n#endif\n\
               #ifdef NOPE\n  no3;\n#else\n  yes_else;\n#endif\n\
               #ifndef NOPE\n  yes_ifndef;\n#endif\n\
               #if (2 + 3 * 4) == 14 && 7 / 2 == 3 && 7 % 4 == 3 && (1 << 4) == 16 && -1 < 0\n  arith;\n#endif\n\
               #if UNKNOWN == 0 && !UNKNOWN && (0x10 | 1) == 17 && (6 & 3) == 2 && (5 ^ 1) == 4 && ~0 == -1\n  bits;\n#endif\n\
               #if 1 ? 0 : 1\n  no4;\n#elif 0 || 2 >= 2 && 3 > 2 && 2 <= 2 && 1 != 2 && (16 >> 2) == 4\n  elif;\n#endif\n\
               #if 0\n  #if garbage (\n  #bogus directive\n  no5;\n  #else\n  no6;\n  #endif\n#elif 1\n  after_skip;\n#endif\n\
               #define LEVEL 3\n#if LEVEL > 2\n  level;\n#endif\n\
               }\n";
    assert_eq!(
        run(Dialect::Rsl, src).unwrap(),
        "surface s() { rsl; yes_else; yes_ifndef; arith; bits; elif; after_skip; level; }\n"
    );
}

#[test]
fn predefined_and_command_line_macros() {
    let src = "surface s() {\n#ifdef __RSL__\nrsl;\n#endif\n#ifdef __OSL__\nosl;\n#endif\n\
               #if OSL_VERSION >= 11300 && OSL_VERSION_MAJOR == 1 && OSL_VERSION_MINOR == 13\nv;\n#endif\n\
               #ifdef __SHADENET__\nsn;\n#endif\n#ifdef DEBUG\ndebug = DEBUG;\n#endif\nl = LEVEL;\n}\n";
    let rsl = Options::new(Dialect::Rsl)
        .define("DEBUG")
        .define("LEVEL=2 + 1");
    assert_eq!(
        run_opts(src, &rsl).unwrap(),
        "surface s() { rsl; sn; (debug = 1); (l = (2 + 1)); }\n"
    );
    let osl = Options::new(Dialect::Osl);
    assert_eq!(
        run_opts(src, &osl).unwrap(),
        "surface s() { osl; v; sn; (l = LEVEL); }\n"
    );
}

#[test]
fn pragmas() {
    let mut sm = SourceMap::new();
    let src = "#pragma once\n#pragma shadenet fast\nsurface s() { }\n";
    let p = parse_str(&mut sm, "t.sl", src, &Options::new(Dialect::Rsl)).unwrap();
    assert_eq!(p.warnings.len(), 1);
    assert!(!p.warnings.has_errors());
    assert_eq!(
        p.warnings.render(&sm),
        "warning: unknown pragma 'shadenet' ignored\n  --> t.sl:2:1\n  |\n\
         2 | #pragma shadenet fast\n  | ^^^^^^^^^^^^^^^^^^^^^ ignored\n  |\n  \
         = the only pragma understood is '#pragma once'\n\n"
    );
    // `#pragma once` stops a second inclusion; `#warning` is a warning too.
    let dir = tree(
        "once",
        &[
            (
                "main.sl",
                "#include \"o.h\"\n#include \"o.h\"\n#warning careful\nsurface s() { }\n",
            ),
            ("o.h", "#pragma once\nfloat f() { return 1; }\n"),
        ],
    );
    let mut sm = SourceMap::new();
    let p = parse_file(&mut sm, &dir.join("main.sl"), &Options::new(Dialect::Rsl)).unwrap();
    assert_eq!(
        p.file.to_string(),
        "float f() { return 1; }\nsurface s() { }\n"
    );
    assert_eq!(p.warnings.0[0].message, "#warning careful");
}

#[test]
fn include_search_order() {
    let dir = tree(
        "search",
        &[
            (
                "main.sl",
                "#include \"a.h\"\n#include \"b.h\"\n#include <c.h>\n#include \"sub/d.h\"\n\
                 surface s() { a = A; b = B; c = C; d = D; e = E; }\n",
            ),
            ("a.h", "#define A root\n"),
            ("inc1/a.h", "#define A inc1\n"),
            ("inc1/b.h", "#define B inc1\n"),
            ("inc2/b.h", "#define B inc2\n"),
            ("c.h", "#define C root\n"),
            ("inc2/c.h", "#define C inc2\n"),
            ("sub/d.h", "#define D sub\n#include \"e.h\"\n"),
            ("sub/e.h", "#define E sub\n"),
            ("e.h", "#define E root\n"),
        ],
    );
    let opts = Options::new(Dialect::Rsl)
        .include_dir(dir.join("inc1"))
        .include_dir(dir.join("inc2"));
    assert_eq!(
        run_file(&dir.join("main.sl"), &opts, &dir).unwrap(),
        "surface s() { (a = root); (b = inc1); (c = inc2); (d = sub); (e = sub); }\n"
    );
}

#[test]
fn include_cycle_and_missing_include_show_the_chain() {
    let dir = tree(
        "cycle",
        &[
            ("main.sl", "#include \"x.h\"\nsurface s() { }\n"),
            ("x.h", "// x\n#include \"y.h\"\n"),
            ("y.h", "#include \"x.h\"\n"),
        ],
    );
    let e = run_file(&dir.join("main.sl"), &Options::new(Dialect::Rsl), &dir).unwrap_err();
    assert_eq!(
        e,
        "error: #include cycle\n  --> DIR/y.h:1:1\n  |\n1 | #include \"x.h\"\n  \
         | ^^^^^^^^^^^^^^ 'x.h' is already being included\n  |\n  \
         = cycle: DIR/x.h -> DIR/y.h -> DIR/x.h\n  \
         = included from DIR/x.h:2:1\n  = included from DIR/main.sl:1:1\n\n"
    );
    let dir = tree(
        "missing",
        &[
            ("main.sl", "#include \"x.h\"\nsurface s() { }\n"),
            ("x.h", "\n#include <nope.h>\n"),
        ],
    );
    let opts = Options::new(Dialect::Rsl).include_dir(dir.join("inc"));
    let e = run_file(&dir.join("main.sl"), &opts, &dir).unwrap_err();
    assert_eq!(
        e,
        "error: cannot find include file 'nope.h'\n  --> DIR/x.h:2:1\n  |\n\
         2 | #include <nope.h>\n  | ^^^^^^^^^^^^^^^^^ included here\n  |\n  \
         = searched: DIR/inc\n  = included from DIR/main.sl:1:1\n\n"
    );
    // An error inside an included file carries the chain too.
    let dir = tree(
        "inner",
        &[
            ("main.sl", "#include \"x.h\"\nsurface s() { }\n"),
            ("x.h", "float f() { return 1 @ 2; }\n"),
        ],
    );
    let e = run_file(&dir.join("main.sl"), &Options::new(Dialect::Rsl), &dir).unwrap_err();
    assert!(
        e.starts_with("error: unexpected character '@' (U+0040)\n  --> DIR/x.h:1:22"),
        "{e}"
    );
    assert!(e.contains("= included from DIR/main.sl:1:1"), "{e}");
    // So does a syntax error the parser finds in it.
    let dir = tree(
        "syntax",
        &[
            ("main.sl", "\n#include \"x.h\"\nsurface s() { }\n"),
            ("x.h", "#include \"y.h\"\n"),
            ("y.h", "float f() { return 1 }\n"),
        ],
    );
    let e = run_file(&dir.join("main.sl"), &Options::new(Dialect::Rsl), &dir).unwrap_err();
    assert_eq!(
        e,
        "error: expected ';' after the return value, found '}'\n  --> DIR/y.h:1:22\n  |\n\
         1 | float f() { return 1 }\n  |                      ^ expected ';'\n  |\n  \
         = included from DIR/x.h:1:1\n  = included from DIR/main.sl:2:1\n\n"
    );
}

#[test]
fn directive_errors() {
    let cases = [
        (
            "#if 1\nsurface s() { }\n",
            "error: unterminated conditional directive",
        ),
        ("#else\n", "error: #else without #if"),
        ("#endif\n", "error: #endif without #if"),
        (
            "#if 1\n#else\n#elif 1\n#endif\n",
            "error: #elif after #else",
        ),
        ("#bogus\n", "error: unknown preprocessor directive '#bogus'"),
        ("#error stop here\n", "error: #error stop here"),
        (
            "#define F(a, b) a\nF(1)\n",
            "error: macro 'F' takes 2 arguments, but 1 was given",
        ),
        (
            "#define F(a) a\nF(1, (2\n",
            "error: unterminated invocation of macro 'F'",
        ),
        (
            "#define S(a) #a\n",
            "error: '#' and '##' are not supported in macro bodies",
        ),
        (
            "#define F(a, a) a\n",
            "error: duplicate macro parameter 'a'",
        ),
        (
            "#define F(a b) a\n",
            "error: bad parameter list in the definition of macro 'F'",
        ),
        ("#define\n", "error: expected a macro name after #define"),
        ("#if 1 / 0\n#endif\n", "error: division by zero in #if"),
        (
            "#if 1.5\n#endif\n",
            "error: #if expressions are integers, found '1.5'",
        ),
        (
            "#if (1\n#endif\n",
            "error: expected ')' in #if, found the end of the line",
        ),
        (
            "#if 1 2\n#endif\n",
            "error: expected the end of the #if expression, found '2'",
        ),
        (
            "#include nope\n",
            "error: expected \"file\" or <file> after #include",
        ),
    ];
    for (src, want) in cases {
        assert_eq!(first_line(run(Dialect::Rsl, src)), want, "{src}");
    }
    // The unterminated `#if` is reported at the `#if`.
    let e = run(Dialect::Rsl, "\n  #ifdef X\nsurface s() { }\n").unwrap_err();
    assert!(e.contains("--> t.sl:2:3"), "{e}");
}

#[test]
fn macro_budget_limit() {
    // Each level doubles: 2^31 tokens, stopped at the budget.
    let mut src = String::from("#define A0 x x\n");
    for i in 1..=30 {
        src.push_str(&format!("#define A{i} A{j} A{j}\n", j = i - 1));
    }
    src.push_str("A30\n");
    assert_eq!(
        first_line(run(Dialect::Rsl, &src)),
        "error: the source expands to more than 1048576 tokens"
    );
}

#[test]
fn macro_depth_limit() {
    // A chain of 70 macros is deeper than the limit of 64.
    let mut src = String::from("#define M0 1\n");
    for i in 1..70 {
        src.push_str(&format!("#define M{i} M{}\n", i - 1));
    }
    src.push_str("surface s() { x = M69; }\n");
    assert_eq!(
        first_line(run(Dialect::Rsl, &src)),
        "error: macro expansion nested deeper than 64 levels"
    );
    // 60 levels are fine.
    let ok = src.replace("x = M69", "x = M59");
    assert_eq!(
        run(Dialect::Rsl, &ok).unwrap(),
        "surface s() { (x = 1); }\n"
    );
    // Deeply nested invocations in arguments.
    let src = format!(
        "#define F(a) a\n{}1{}\n",
        "F(".repeat(100_000),
        ")".repeat(100_000)
    );
    assert_eq!(
        first_line(run(Dialect::Rsl, &src)),
        "error: macro expansion nested deeper than 64 levels"
    );
}

#[test]
fn include_depth_limit() {
    // Includes nested deeper than 64 (a chain of distinct files).
    let mut files: Vec<(String, String)> = (0..70)
        .map(|i| (format!("f{i}.h"), format!("#include \"f{}.h\"\n", i + 1)))
        .collect();
    files.push(("f70.h".into(), String::new()));
    files.push(("main.sl".into(), "#include \"f0.h\"\n".into()));
    let refs: Vec<(&str, &str)> = files
        .iter()
        .map(|(a, b)| (a.as_str(), b.as_str()))
        .collect();
    let dir = tree("deep", &refs);
    let e = run_file(&dir.join("main.sl"), &Options::new(Dialect::Rsl), &dir).unwrap_err();
    assert!(
        e.starts_with("error: #include nested deeper than 64 levels\n  --> DIR/f63.h:1:1"),
        "{e}"
    );
}

#[test]
fn a_header_included_many_times_is_bounded() {
    // 500 inclusions of a guarded header holding 10 013 tokens (10 000 skipped): the 419th
    // passes 2^22 with the main file's 2 000.
    let header = format!(
        "#ifndef G\n#define G\n#endif\n#if 0\n{}\n#endif\n",
        "a ".repeat(10_000)
    );
    let main = "#include \"h.h\"\n".repeat(500);
    let dir = tree("many", &[("h.h", &header), ("main.sl", &main)]);
    let e = run_file(&dir.join("main.sl"), &Options::new(Dialect::Rsl), &dir).unwrap_err();
    assert!(
        e.starts_with(
            "error: the files read hold more than 4194304 tokens in all\n  --> DIR/h.h:1:1"
        ),
        "{e}"
    );
    assert!(e.contains("= included from DIR/main.sl:419:1"), "{e}");
    // 400 inclusions are within the limit.
    let main = "#include \"h.h\"\n".repeat(400) + "surface s() { }\n";
    let dir = tree("many-ok", &[("h.h", &header), ("main.sl", &main)]);
    assert_eq!(
        run_file(&dir.join("main.sl"), &Options::new(Dialect::Rsl), &dir).unwrap(),
        "surface s() { }\n"
    );
}

#[test]
fn if_depth_limit() {
    // Deep `#if` parentheses.
    let src = format!(
        "#if {}1{}\n#endif\n",
        "(".repeat(100_000),
        ")".repeat(100_000)
    );
    assert_eq!(
        first_line(run(Dialect::Rsl, &src)),
        "error: #if expression nested deeper than 64 levels"
    );
    let src = format!("#if {}1\n#endif\n", "!".repeat(100_000));
    assert_eq!(
        first_line(run(Dialect::Rsl, &src)),
        "error: #if expression nested deeper than 64 levels"
    );
}

#[test]
fn files_that_cannot_be_read() {
    let dir = tree("bad", &[("bad.sl", "surface s() { }\n")]);
    std::fs::write(dir.join("latin1.sl"), b"surface s() { x = \"caf\xe9\"; }\n").unwrap();
    let e = run_file(&dir.join("latin1.sl"), &Options::new(Dialect::Rsl), &dir).unwrap_err();
    assert!(
        e.starts_with(
            "error: the file is not valid UTF-8: byte 0xE9 at offset 22\n  --> DIR/latin1.sl:1:23"
        ),
        "{e}"
    );
    let e = run_file(&dir.join("none.sl"), &Options::new(Dialect::Rsl), &dir).unwrap_err();
    assert!(e.starts_with("error: cannot read 'DIR/none.sl': "), "{e}");
    let opts = Options::default();
    let e = run_file(&dir.join("bad.txt"), &opts, &dir).unwrap_err();
    assert_eq!(
        e,
        "error: cannot tell the language of 'DIR/bad.txt': name it .sl (RSL) or .osl (OSL), or give the dialect\n\n"
    );
}
