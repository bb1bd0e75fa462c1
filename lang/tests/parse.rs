//! The parser: every statement form and operator (precedence checked by printing the AST
//! fully parenthesised), the dialect differences, the classic shaders, and rendered errors.

use shadenet_lang::ast::{BinaryOp, ExprKind, Item, ShaderKind, StmtKind};
use shadenet_lang::{Dialect, Options, SourceMap, parse_file, parse_str};
use std::path::Path;

fn parse(d: Dialect, src: &str) -> Result<shadenet_lang::Parsed, String> {
    let mut sm = SourceMap::new();
    parse_str(&mut sm, "t", src, &Options::new(d)).map_err(|e| e.render(&sm))
}

/// The statements of a shader body holding `body`, printed.
fn body(d: Dialect, body: &str) -> String {
    let head = if d == Dialect::Rsl {
        "surface"
    } else {
        "shader"
    };
    let src = format!("{head} t() {{\n{body}\n}}");
    let p = parse(d, &src).unwrap_or_else(|e| panic!("{src}\n{e}"));
    match &p.file.items[0] {
        Item::Shader(s) => s
            .body
            .stmts
            .iter()
            .map(|s| s.to_string())
            .collect::<Vec<_>>()
            .join(" "),
        _ => unreachable!(),
    }
}

/// The expression `e`, parsed as an expression statement and printed.
fn expr(d: Dialect, e: &str) -> String {
    let s = body(d, &format!("{e};"));
    s.strip_suffix(';').unwrap_or(&s).to_string()
}

/// The rendered error of parsing `src` as file `name`.
fn error(d: Dialect, name: &str, src: &str) -> String {
    let mut sm = SourceMap::new();
    match parse_str(&mut sm, name, src, &Options::new(d)) {
        Ok(p) => panic!("parsed: {}", p.file),
        Err(e) => e.render(&sm),
    }
}

const RSL: Dialect = Dialect::Rsl;
const OSL: Dialect = Dialect::Osl;

#[test]
fn binary_precedence_follows_c() {
    for (src, want) in [
        ("a + b * c", "(a + (b * c))"),
        ("a * b + c", "((a * b) + c)"),
        ("a - b - c", "((a - b) - c)"),
        ("a / b % c", "((a / b) % c)"),
        (
            "a || b && c | d & e == f < g << h + i * j",
            "(a || (b && (c | (d & (e == (f < (g << (h + (i * j)))))))))",
        ),
        (
            "a * b + c << d > e != f & g | h && i || j",
            "(((((((((a * b) + c) << d) > e) != f) & g) | h) && i) || j)",
        ),
        ("a < b == c >= d", "((a < b) == (c >= d))"),
        ("a <= b != c > d", "((a <= b) != (c > d))"),
    ] {
        assert_eq!(expr(RSL, src), want, "{src}");
        assert_eq!(expr(OSL, src), want, "{src}");
    }
}

#[test]
fn rsl_dot_and_cross() {
    for (src, want) in [
        ("a * b . c", "(a * (b . c))"),
        ("a . b * c", "((a . b) * c)"),
        ("N . L / length(L)", "((N . L) / length(L))"),
        ("a + b ^ c * d", "(a + (b ^ (c * d)))"),
        ("a ^ b + c", "((a ^ b) + c)"),
        ("a ^ b ^ c", "((a ^ b) ^ c)"),
        ("-a . b", "((-a) . b)"),
    ] {
        assert_eq!(expr(RSL, src), want, "{src}");
    }
    let p = parse(RSL, "surface t() { x = a ^ b; y = a . b; }").unwrap();
    let ops = binary_ops(&p);
    assert_eq!(ops, vec![BinaryOp::Cross, BinaryOp::Dot]);
}

#[test]
fn osl_xor_and_members() {
    for (src, want) in [
        ("a ^ b & c", "(a ^ (b & c))"),
        ("a | b ^ c", "(a | (b ^ c))"),
        ("a ^ b + c", "(a ^ (b + c))"),
        ("P.x * 2", "(P.x * 2)"),
        ("s.inner.r + 1", "(s.inner.r + 1)"),
        ("a[1].b[2]", "a[1].b[2]"),
        ("N.L", "N.L"),
    ] {
        assert_eq!(expr(OSL, src), want, "{src}");
    }
    let p = parse(OSL, "shader t() { x = a ^ b; }").unwrap();
    assert_eq!(binary_ops(&p), vec![BinaryOp::BitXor]);
    assert!(
        error(OSL, "t.osl", "shader t() { x = a . (b); }")
            .contains("expected a name after '.', found '('")
    );
}

fn binary_ops(p: &shadenet_lang::Parsed) -> Vec<BinaryOp> {
    let Item::Shader(s) = &p.file.items[0] else {
        unreachable!()
    };
    s.body
        .stmts
        .iter()
        .map(|s| match &s.kind {
            StmtKind::Expr(e) => match &e.kind {
                ExprKind::Assign { value, .. } => match value.kind {
                    ExprKind::Binary { op, .. } => op,
                    _ => unreachable!(),
                },
                _ => unreachable!(),
            },
            _ => unreachable!(),
        })
        .collect()
}

#[test]
fn unary_postfix_assignment_and_ternary() {
    for (src, want) in [
        ("-a * b", "((-a) * b)"),
        ("- - a", "(-(-a))"),
        ("!a && +b", "((!a) && (+b))"),
        ("~a | b", "((~a) | b)"),
        ("a[i][j]++", "(a[i][j]++)"),
        ("++a[i]", "(++a[i])"),
        ("--x + y--", "((--x) + (y--))"),
        ("a = b = c", "(a = (b = c))"),
        ("a += b ? c : d ? e : f", "(a += (b ? c : (d ? e : f)))"),
        ("a ? b = 1 : c", "(a ? (b = 1) : c)"),
        ("x < y ? 1 : 0", "((x < y) ? 1 : 0)"),
        ("a -= 1", "(a -= 1)"),
        ("a *= 2", "(a *= 2)"),
        ("a /= 2", "(a /= 2)"),
        ("a %= 2", "(a %= 2)"),
        ("a &= 2", "(a &= 2)"),
        ("a |= 2", "(a |= 2)"),
        ("a <<= 2", "(a <<= 2)"),
        ("a >>= 2", "(a >>= 2)"),
        ("(a + b) * c", "((a + b) * c)"),
    ] {
        assert_eq!(expr(RSL, src), want, "{src}");
    }
    assert_eq!(expr(OSL, "a ^= 2"), "(a ^= 2)");
}

#[test]
fn literals_calls_constructors_casts_and_triples() {
    for (src, want) in [
        (
            "1 + 0x10 + 1. + .5 + 1e-3",
            "((((1 + 16) + 1.0) + 0.5) + 0.001)",
        ),
        ("\"a\" \"b\\n\"", "\"ab\\n\""),
        ("f()", "f()"),
        ("texture(\"file.tx\", s, t)", "texture(\"file.tx\", s, t)"),
        (
            "texture(\"file.tx\"[1], s, t)",
            "texture(\"file.tx\"[1], s, t)",
        ),
        ("point \"object\" (1, 2, 3)", "point \"object\"(1, 2, 3)"),
        (
            "color \"hsv\" (h, s, v) * 2",
            "(color \"hsv\"(h, s, v) * 2)",
        ),
        ("color(1)", "color(1)"),
        ("matrix \"shader\" 1", "(matrix \"shader\" 1)"),
        ("y = float x + 1", "(y = ((float x) + 1))"),
        ("vector \"world\" P - Q", "((vector \"world\" P) - Q)"),
        ("(float) x * y", "(((float) x) * y)"),
        ("(color) -x", "((color) (-x))"),
        ("(a, b, c) * 2", "((a, b, c) * 2)"),
        ("(1, 0, 0)", "(1, 0, 0)"),
        ("(float)(x)", "((float) x)"),
    ] {
        assert_eq!(expr(RSL, src), want, "{src}");
    }
    assert_eq!(
        expr(OSL, "color(0.5, 0.5, 1) * (int) f"),
        "(color(0.5, 0.5, 1) * ((int) f))"
    );
}

#[test]
fn statements() {
    for (src, want) in [
        (
            "float a = 1, b[3] = {1, 2, 3}, c;",
            "float a = 1, b[3] = {1, 2, 3}, c;",
        ),
        ("uniform float x = 2;", "uniform float x = 2;"),
        ("varying color c;", "varying color c;"),
        ("string s = \"x\";", "string s = \"x\";"),
        ("matrix m = 1;", "matrix m = 1;"),
        ("int n = 3;", "int n = 3;"),
        (
            "point p; vector v; normal n;",
            "point p; vector v; normal n;",
        ),
        ("color(1, 0, 0);", "color(1, 0, 0);"),
        ("color \"rgb\" (1, 0, 0);", "color \"rgb\"(1, 0, 0);"),
        (
            "if (a) b = 1; else { c = 2; }",
            "if (a) (b = 1); else { (c = 2); }",
        ),
        (
            "if (a) if (b) x = 1; else x = 2;",
            "if (a) if (b) (x = 1); else (x = 2);",
        ),
        (
            "for (float i = 0; i < 10; i += 1) s += i;",
            "for (float i = 0; (i < 10); (i += 1)) (s += i);",
        ),
        (
            "for (i = 0, j = 1; ; i++, j--) break;",
            "for ((i = 0), (j = 1);; (i++), (j--)) break;",
        ),
        ("for (;;) continue;", "for (;;) continue;"),
        (
            "while (a) while (b) { break 2; continue 2; }",
            "while (a) while (b) { break 2; continue 2; }",
        ),
        ("while (x > 0) x -= 1;", "while ((x > 0)) (x -= 1);"),
        ("return x * 2;", "return (x * 2);"),
        ("return;", "return;"),
        (";", ";"),
        ("{ }", "{ }"),
        ("{ { a; } b; }", "{ { a; } b; }"),
        (
            "illuminance(P, N, PI / 2) { C += Cl; }",
            "illuminance(P, N, (PI / 2)) { (C += Cl); }",
        ),
        (
            "illuminance(\"specular\", P, N, 1) ;",
            "illuminance(\"specular\", P, N, 1) ;",
        ),
        ("illuminance(P) C += Cl;", "illuminance(P) (C += Cl);"),
        ("illuminance(\"rim\", P) ;", "illuminance(\"rim\", P) ;"),
    ] {
        assert_eq!(body(RSL, src), want, "{src}");
    }
    assert_eq!(
        body(OSL, "do x++; while (x < 3); break; continue;"),
        "do (x++); while ((x < 3)); break; continue;"
    );
    assert_eq!(body(OSL, "closure color c = 0;"), "closure color c = 0;");
}

#[test]
fn light_statements_and_their_argument_counts() {
    let src = "light l() { illuminate(from) Cl = 1; illuminate(from, A, 1) {} \
               solar() Cl = 1; solar(D, 0) {} }";
    let p = parse(RSL, src).unwrap();
    assert_eq!(
        p.file.to_string(),
        "light l() { illuminate(from) (Cl = 1); illuminate(from, A, 1) { } solar() (Cl = 1); \
         solar(D, 0) { } }\n"
    );
    let Item::Shader(s) = &p.file.items[0] else {
        unreachable!()
    };
    assert!(matches!(s.body.stmts[0].kind, StmtKind::Illuminate { .. }));
    assert!(matches!(s.body.stmts[2].kind, StmtKind::Solar { .. }));
    let p = parse(RSL, "surface s() { illuminance(\"c\", P, N, a) ; }").unwrap();
    let Item::Shader(s) = &p.file.items[0] else {
        unreachable!()
    };
    match &s.body.stmts[0].kind {
        StmtKind::Illuminance { category, args, .. } => {
            assert_eq!(category.as_ref().unwrap().to_string(), "\"c\"");
            assert_eq!(args.len(), 3);
        }
        k => panic!("{k:?}"),
    }
    for (src, msg) in [
        (
            "illuminance(P, N) ;",
            "'illuminance' takes (P) or (P, N, angle), with an optional category string first; found 2 arguments",
        ),
        (
            "illuminate() ;",
            "'illuminate' takes (P) or (P, axis, angle); found 0 arguments",
        ),
        (
            "solar(D) ;",
            "'solar' takes () or (axis, angle); found 1 argument",
        ),
    ] {
        let e = error(RSL, "t.sl", &format!("surface s() {{ {src} }}"));
        assert!(e.starts_with(&format!("error: {msg}\n")), "{e}");
    }
}

#[test]
fn items_shader_kinds_functions_and_params() {
    let src = "float f(float x; output float y) { y = x; return x; }\n\
               void g(float a, b; extern float c) { }\n\
               surface s(float Ks = .5, Kd = .5; uniform color c = 1; varying float v[2] = {1, 2}) { }\n\
               light l() { } volume v() { } displacement d() { } imager i() { }";
    let p = parse(RSL, src).unwrap();
    assert_eq!(
        p.file.to_string(),
        "float f(float x; output float y) { (y = x); return x; }\n\
         void g(float a; float b; extern float c) { }\n\
         surface s(float Ks = 0.5; float Kd = 0.5; uniform color c = 1; varying float v[2] = {1, 2}) { }\n\
         light l() { }\nvolume v() { }\ndisplacement d() { }\nimager i() { }\n"
    );
    let kinds: Vec<ShaderKind> = p
        .file
        .items
        .iter()
        .filter_map(|i| match i {
            Item::Shader(s) => Some(s.kind),
            _ => None,
        })
        .collect();
    use ShaderKind::*;
    assert_eq!(kinds, vec![Surface, Light, Volume, Displacement, Imager]);
    let p = parse(
        OSL,
        "shader a(float x = 1, output color c = 0) { } surface b() { }",
    )
    .unwrap();
    assert_eq!(
        p.file.to_string(),
        "shader a(float x = 1; output color c = 0) { }\nsurface b() { }\n"
    );
    // Every node carries its span: the shader's covers the definition.
    let mut sm = SourceMap::new();
    let src = "  surface s(float a = 1) { x = a; }";
    let p = parse_str(&mut sm, "t.sl", src, &Options::new(RSL)).unwrap();
    let Item::Shader(s) = &p.file.items[0] else {
        unreachable!()
    };
    assert_eq!(sm.text(s.span), src.trim());
    assert_eq!(sm.text(s.params[0].span), "float a = 1");
    assert_eq!(sm.text(s.params[0].ty.span), "float");
    assert_eq!(sm.text(s.body.stmts[0].span), "x = a;");
    let StmtKind::Expr(e) = &s.body.stmts[0].kind else {
        unreachable!()
    };
    assert_eq!(sm.text(e.span), "x = a");
}

#[test]
fn the_classic_rsl_shaders() {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/shaders");
    let expect = [
        (
            "matte.sl",
            "surface matte(float Ka = 1; float Kd = 1) { normal Nf = faceforward(normalize(N), I); \
             (Oi = Os); (Ci = ((Os * Cs) * ((Ka * ambient()) + (Kd * diffuse(Nf))))); }\n",
        ),
        (
            "plastic.sl",
            "surface plastic(float Ks = 0.5; float Kd = 0.5; float Ka = 1; float roughness = 0.1; \
             color specularcolor = 1) { normal Nf = faceforward(normalize(N), I); \
             vector V = (-normalize(I)); (Oi = Os); (Ci = (Os * ((Cs * ((Ka * ambient()) + \
             (Kd * diffuse(Nf)))) + ((specularcolor * Ks) * specular(Nf, V, roughness))))); }\n",
        ),
        (
            "pointlight.sl",
            "light pointlight(float intensity = 1; color lightcolor = 1; \
             point from = point \"shader\"(0, 0, 0)) { illuminate(from) \
             (Cl = ((intensity * lightcolor) / (L . L))); }\n",
        ),
        (
            "spotlight.sl",
            "light spotlight(float intensity = 1; color lightcolor = 1; \
             point from = point \"shader\"(0, 0, 0); point to = point \"shader\"(0, 0, 1); \
             float coneangle = radians(30); float conedeltaangle = radians(5); \
             float beamdistribution = 2) { uniform vector A = ((to - from) / length((to - from))); \
             uniform float cosoutside = cos(coneangle), cosinside = cos((coneangle - conedeltaangle)); \
             float atten, cosangle; illuminate(from, A, coneangle) { \
             (cosangle = ((L . A) / length(L))); \
             (atten = (pow(cosangle, beamdistribution) / (L . L))); \
             (atten *= smoothstep(cosoutside, cosinside, cosangle)); \
             (Cl = ((atten * intensity) * lightcolor)); } }\n",
        ),
        (
            "fog.sl",
            "volume fog(float distance = 1; color background = 0) { \
             float d = (1 - exp(((-length(I)) / distance))); (Ci = mix(Ci, background, d)); \
             (Oi = mix(Oi, color(1, 1, 1), d)); }\n",
        ),
    ];
    for (name, want) in expect {
        let mut sm = SourceMap::new();
        // The dialect comes from the extension.
        let opts = Options::default();
        let p = parse_file(&mut sm, &dir.join(name), &opts)
            .unwrap_or_else(|e| panic!("{}", e.render(&sm)));
        assert_eq!(p.dialect, RSL);
        assert_eq!(p.file.to_string(), want, "{name}");
    }
}

#[test]
fn an_osl_shader_with_metadata_closures_and_a_struct() {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/shaders");
    let mut sm = SourceMap::new();
    let opts = Options::default();
    let p = parse_file(&mut sm, &dir.join("layered.osl"), &opts)
        .unwrap_or_else(|e| panic!("{}", e.render(&sm)));
    assert_eq!(p.dialect, OSL);
    assert_eq!(
        p.file.to_string(),
        "struct Layer { color tint; float weight; };\n\
         float layer_weight(Layer l; output float total) { (total += l.weight); return l.weight; }\n\
         shader layered [[ string help = \"Diffuse layers over a glossy base\", \
         string category = \"surface\" ]](color base = color(0.8, 0.2, 0.1) [[ string help = \
         \"Base colour\", float min = 0, float max = 1 ]]; float roughness = 0.3; int count = 3; \
         float weights[3] = {0.5, 0.25, 0.125}; output closure color bsdf = 0; \
         output float total = 0) { Layer l; (l.tint = base); int i = 0; do { \
         (l.weight = weights[i]); float w = layer_weight(l, total); \
         (bsdf += ((w * l.tint) * diffuse(N))); (i++); } while (((i < count) && (i < 3))); \
         (bsdf += ((1 - total) * microfacet(\"ggx\", N, roughness, 1.5, 0))); \
         int mask = (count ^ 1); if (((mask & 2) || (!(count > 1)))) (bsdf *= 0.5); }\n"
    );
    let Item::Shader(s) = &p.file.items[2] else {
        unreachable!()
    };
    assert!(s.params[4].ty.closure.is_some() && s.params[4].ty.output.is_some());
    assert_eq!(s.metadata.len(), 2);
    assert_eq!(s.params[0].metadata.len(), 3);
}

#[test]
fn errors_render_with_place_and_caret() {
    let e = error(RSL, "t.sl", "surface s() {\n    x = 1\n    float y;\n}\n");
    assert_eq!(
        e,
        "error: expected ';' after the expression, found 'float'\n  \
         --> t.sl:3:5\n  |\n3 |     float y;\n  |     ^^^^^ expected ';'\n\n"
    );
    let e = error(RSL, "t.sl", "surface s() {\n    x = f(1, 2;\n}\n");
    assert_eq!(
        e,
        "error: expected ')' to end the argument list, found ';'\n  \
         --> t.sl:2:15\n  |\n2 |     x = f(1, 2;\n  |          -    ^ expected ')'\n  \
         |          |     \n  |          opened here\n\n"
    );
    let e = error(RSL, "t.sl", "surface s() {\n    x = 1;\n");
    assert!(
        e.starts_with(
            "error: expected '}' to end the block, found the end of the file\n  --> t.sl:3:1"
        ),
        "{e}"
    );
    let e = error(RSL, "t.sl", "x = 1;");
    assert!(e.starts_with(
        "error: expected a shader ('surface', 'light', 'volume', 'displacement', 'imager') or a \
         function at file scope, found 'x'\n  --> t.sl:1:1"
    ));
    let e = error(
        OSL,
        "t.osl",
        "shader s() { float f(float x) { return x; } }",
    );
    assert!(e.starts_with(
        "error: function definitions inside a body are not supported yet\n  --> t.osl:1:20"
    ));
    let e = error(RSL, "t.sl", "surface s() { x = ; }");
    assert!(
        e.starts_with("error: expected an expression, found ';'\n  --> t.sl:1:19"),
        "{e}"
    );
    let e = error(RSL, "t.sl", "surface s(float a = 1 float b) { }");
    assert!(
        e.starts_with("error: expected ',', ';' or ')' after the parameter, found 'float'"),
        "{e}"
    );
    let e = error(RSL, "t.sl", "surface s() { while (1) break 0; }");
    assert!(
        e.starts_with("error: 'break' takes a loop count of at least 1\n  --> t.sl:1:31"),
        "{e}"
    );
    let e = error(RSL, "t.sl", "surface s() { uniform varying float x; }");
    assert!(
        e.starts_with("error: more than one of 'uniform' and 'varying'"),
        "{e}"
    );
    let e = error(RSL, "t.sl", "surface s() { x = 99999999999999999999; }");
    assert!(
        e.starts_with("error: integer '99999999999999999999' is too large"),
        "{e}"
    );
    // An error in a macro expansion points at the invocation.
    let e = error(
        RSL,
        "t.sl",
        "#define BAD (1 +)\nsurface s() {\n  x = BAD;\n}\n",
    );
    assert!(
        e.starts_with("error: expected an expression, found ')'\n  --> t.sl:3:7"),
        "{e}"
    );
}
