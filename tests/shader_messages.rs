//! OSL's messages (issue 22): `setmessage(name, value)` and `getmessage(name, value)` within
//! a shader and from layer to layer of a shader group — set under a varying `if`, in a
//! loop and in a user function, read where set and left alone where not, of every storable
//! type; interpreter (f32, f64) against values computed here, the JIT's scalar and batch
//! entries bit for bit with the interpreter; errors naming the place.

mod common;
use common::*;
use shadenet::lang::Dialect;

/// Runs `src` (OSL, one shader) at a fragment with `u` and `v`.
fn run_at(p: &shadenet::graph::ir::Program, u: f64, v: f64) -> Outputs {
    let mut f = plane_fragment();
    f.uv = [u as f32, v as f32];
    run_program(p, &f, &[], u32::MAX)
}

/// Messages within one shader: a varying `if` sets one where `u > 0.5`, a loop another, a
/// user function a third, a function called (through another) under a varying `if` a
/// fourth; `getmessage` of a message nothing sets is 0 and leaves its variable alone.
const ONE_SHADER: &str = r#"
    void tag(float x) { setmessage("tagged", color(x, 2 * x, 3)); }
    void mark(int k) { setmessage("marked", k); }
    void mark_twice() { mark(4); mark(5); }
    shader s(output color out = 0, output float found = 0, output matrix m = 1,
             output float marked = -1) {
        if (u > 0.5)
            setmessage("high", u * 10);
        for (int i = 0; i < 3; i++)
            setmessage("count", i + 1);
        tag(v);
        setmessage("mat", matrix(2));
        float h = -1;
        int n = 0;
        color c = 0;
        float none = 7;
        int got_high = getmessage("high", h);
        int got_count = getmessage("count", n);
        int got_tag = getmessage("tagged", c);
        int got_none = getmessage("never set", none);
        getmessage("mat", m);
        if (v > 0.3)
            mark_twice();
        int mk = -1;
        getmessage("marked", mk);
        marked = mk;
        out = c + color(h, n, none);
        found = got_high + 10 * got_count + 100 * got_tag + 1000 * got_none;
    }"#;

#[test]
fn messages_within_a_shader() {
    let p = compile_shader(ONE_SHADER, Dialect::Osl).unwrap_or_else(|e| panic!("{e}"));
    for (u, v) in [(0.25, 0.5), (0.75, 0.125)] {
        let o = run_at(&p, u, v);
        let high = u > 0.5;
        let h = if high { u * 10.0 } else { -1.0 };
        let want = [v + h, 2.0 * v + 3.0, 3.0 + 7.0];
        for (got, what) in [(o.get("out"), "f64"), (o.get32("out"), "f32")] {
            assert_close(&got, &want, 1e-6, &format!("out at u = {u} ({what})"));
        }
        let found = if high { 111.0 } else { 110.0 };
        assert_eq!(o.get("found"), [found], "found at u = {u}");
        // Set in a function called under a varying `if`: where it ran, the last value.
        let marked = if v > 0.3 { 5.0 } else { -1.0 };
        assert_eq!(o.get("marked"), [marked], "marked at v = {v}");
        let m = o.get("m");
        assert_eq!(m[0], 2.0);
        assert_eq!(m[1], 0.0);
        assert_eq!(m[15], 2.0);
    }
}

/// The same shader on a grid: the JIT's scalar and batch entries give the interpreter's bits.
#[test]
fn messages_run_on_the_jit_as_on_the_interpreter() {
    let p = compile_shader(ONE_SHADER, Dialect::Osl).unwrap_or_else(|e| panic!("{e}"));
    assert_jit_is_interp(&p, 9, 7);
}

/// A group: the first layer sets messages (one only where `u > 0.5`), the second reads
/// them; a layer that reads before any layer set a message sees it unset.
#[test]
fn messages_pass_from_layer_to_layer() {
    let early = "shader early(output float seen = 0) {
        float x = 5; seen = getmessage(\"weight\", x) ? x : -1; }";
    let first = "shader first(float k = 2, output float dummy = 0) {
        if (u > 0.5) setmessage(\"weight\", k * u);
        setmessage(\"tint\", color(k, v, 1)); }";
    let second = "surface second(float base = 0, float before = 0, output float w = 0,
                                 output color t = 0, output float early = 0) {
        early = before;
        w = base;
        int got = getmessage(\"weight\", w);
        getmessage(\"tint\", t);
        w += 100 * got;
        Ci = t * emission(); }";
    let group = "shader early e ;\nparam float k 3 ;\nshader first a ;\nshader second b ;\n\
                 connect e.seen b.before ;\n";
    let dir = tmp("messages", "group");
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    for (f, text) in [
        ("early.osl", early),
        ("first.osl", first),
        ("second.osl", second),
        ("g.oslgroup", group),
    ] {
        std::fs::write(dir.join(f), text).unwrap();
    }
    let compiled = shadenet::shader::load(&dir.join("g.oslgroup"), &[], &[]).unwrap();
    let p = &compiled.program;
    for (u, v) in [(0.25, 0.5), (0.75, 0.125)] {
        let o = run_at(p, u, v);
        let w = if u > 0.5 { 3.0 * u + 100.0 } else { 0.0 };
        assert_close(&o.get("w"), &[w], 1e-6, &format!("w at u = {u}"));
        assert_close(&o.get("t"), &[3.0, v, 1.0], 1e-6, &format!("t at u = {u}"));
        assert_eq!(
            o.get("early"),
            [-1.0],
            "the early layer runs before any set"
        );
    }
}

#[test]
fn message_errors_name_the_place() {
    for (body, want) in [
        (
            "setmessage(\"a\", 1.0); setmessage(\"a\", color(1));",
            "message \"a\" is a float; here a color: a message keeps one type",
        ),
        (
            "setmessage(\"c\", diffuse(N));",
            "`setmessage` of a closure color is not built",
        ),
        (
            "setmessage(\"s\");",
            "`setmessage` takes (string name, value)",
        ),
        (
            "setmessage(\"f\", 1.0); string s = \"\"; getmessage(\"f\", s);",
            "`getmessage(\"f\", …)` writes a float (not into a string)",
        ),
    ] {
        let src = format!("surface s() {{ {body} }}");
        let err = compile_shader(&src, Dialect::Osl).unwrap_err();
        assert!(err.contains(want), "{body}\n→ {err}");
    }
}
