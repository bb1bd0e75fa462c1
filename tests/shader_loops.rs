//! Loops in shading-language sources (issue 21): `for` and `while` with `break` and
//! `continue` (RSL's `break N` / `continue N` too) lowered onto the IR's loop region, the
//! rates of what they carry, the iteration limit, and errors that name the place.

mod common;
use common::*;
use shadenet::graph::ir::{LOOP_ITERATION_LIMIT, Op, Program};
use shadenet::lang::Dialect;

/// Compiles RSL `src`'s first shader; `Err` is the rendered diagnostics.
fn compile(src: &str) -> Result<Program, String> {
    compile_shader(src, Dialect::Rsl)
}

/// `Ci` of `src` at texture coordinate `s` (= u), in f64 and f32 (both checked).
fn ci_at(p: &Program, s: f64) -> Vec<f64> {
    let mut f = plane_fragment();
    f.uv = [s as f32, 0.5];
    let o = run_program(p, &f, &[], u32::MAX);
    assert_eq!(o.get("Ci"), o.get32("Ci"), "f32 = f64 for small integers");
    assert_eq!(o.loop_limits, [0, 0]);
    o.get("Ci")
}

fn loops(p: &Program) -> usize {
    let mut n = 0;
    p.walk(&p.body, &mut |v| {
        n += matches!(p.op(v), Op::Loop { .. }) as usize
    });
    n
}

#[test]
fn for_while_break_and_continue() {
    let src = r#"
        surface s(float n = 10) {
            float i, sum = 0;
            for (i = 0; i < n; i += 1) {
                if (i == 3) continue;
                if (i > 7) break;
                sum += i;
            }
            float j = 0, k = 0;
            while (j < s * 10) { j += 1; k += j; }
            Ci = color(sum, i, j * 1000 + k);
        }"#;
    let p = compile(src).unwrap();
    assert_eq!(loops(&p), 2);
    // sum = 0+1+2+4+5+6+7 (3 skipped, 8 breaks before adding, and before the step: i = 8).
    for (s, j) in [
        (0.0, 0.0),
        (0.05, 1.0),
        (0.25, 3.0),
        (0.5, 5.0),
        (0.99, 10.0),
    ] {
        let k = j * (j + 1.0) / 2.0;
        assert_eq!(ci_at(&p, s), [25.0, 8.0, j * 1000.0 + k], "s = {s}");
    }
}

#[test]
fn nested_loops_and_multi_level_jumps() {
    // RSL's `break 2` leaves both loops; `continue 2` goes on with the outer one.
    let src = r#"
        surface s() {
            float i, j, a = 0, b = 0, c = 0;
            for (i = 0; i < 4; i += 1) {
                for (j = 0; j < 4; j += 1) {
                    if (j > i) continue 2;
                    a += 1;
                }
                b += 1;
            }
            for (i = 0; i < 4; i += 1) {
                for (j = 0; j < 4; j += 1) {
                    if (i * 4 + j == 6) break 2;
                    c += 1;
                }
            }
            float n = 0;
            for (i = 0; i < s * 8; i += 1)
                for (j = 0; j <= i; j += 1)
                    n += 1;
            Ci = color(a * 100 + b, c * 100 + i, n);
        }"#;
    let p = compile(src).unwrap();
    assert_eq!(loops(&p), 6);
    // a: inner runs j = 0..=i before continuing the outer loop: 1+2+3+4 = 10; `b += 1`
    // runs only when the inner loop ends by its condition: i = 3 (j reaches 4): b = 1.
    // c: 6 increments before i·4+j = 6 (i = 1, j = 2); the last triangle loop leaves
    // i = ceil(s·8) and counts 1+2+…+i.
    for (s, i) in [(0.0, 0.0), (0.3, 3.0), (0.5, 4.0)] {
        let n = i * (i + 1.0) / 2.0;
        assert_eq!(ci_at(&p, s), [10.0 * 100.0 + 1.0, 600.0 + i, n], "s = {s}");
    }
}

/// A loop that never ends stops at the iteration limit, counted; nested ones share the
/// limit, so a nest of endless loops costs no more than one.
#[test]
fn the_iteration_limit_stops_a_loop_that_never_ends() {
    let src = r#"
        surface s() {
            float x = 0, y = 0;
            while (1 == 1) { x += 1; }
            while (y < 3) { y += 1; }
            Ci = color(x, y, 0);
        }"#;
    let p = compile(src).unwrap();
    let o = run_program(&p, &plane_fragment(), &[], u32::MAX);
    let limit = LOOP_ITERATION_LIMIT as f64;
    assert_eq!(o.get("Ci"), [limit, 3.0, 0.0]);
    assert_eq!(o.get32("Ci"), [limit, 3.0, 0.0]);
    // One stop per run (f32 and f64): the second loop ends by its condition.
    assert_eq!(o.loop_limits, [1, 1]);
    // Nested endless loops share their nest's budget instead of multiplying it: the outer
    // bodies' runs take one each, the innermost loop the rest; every loop of the nest stops.
    let src = r#"
        surface s() {
            float x = 0;
            while (1 == 1) while (2 == 2) while (3 == 3) x += 1;
            Ci = color(x, 0, 0);
        }"#;
    let o = run_program(&compile(src).unwrap(), &plane_fragment(), &[], u32::MAX);
    assert_eq!(o.get("Ci"), [limit - 2.0, 0.0, 0.0]);
    assert_eq!(o.loop_limits, [3, 3]);
}

#[test]
fn uniform_counters_stay_uniform_and_varying_trip_counts_do_not() {
    let ok = r#"
        surface s(float octaves = 4) {
            uniform float i;
            float sum = 0;
            for (i = 0; i < octaves; i += 1) sum += pow(2, -i) * s;
            Ci = sum;
        }"#;
    let p = compile(ok).unwrap();
    assert_eq!(ci_at(&p, 0.5), [0.9375; 3]);
    let bad = r#"
        surface s() {
            uniform float i = 0;
            while (i < s) i += 1;
            Ci = i;
        }"#;
    let e = compile(bad).unwrap_err();
    assert!(
        e.contains("uniform variable `i` is assigned a varying value"),
        "{e}"
    );
}

#[test]
fn jumps_and_loops_refuse_what_they_cannot_do() {
    for (src, want) in [
        ("surface s() { break; }", "`break` outside a loop"),
        (
            "surface s() { float i; for (i = 0; i < 2; i += 1) break 2; }",
            "`break 2` leaves 2 loops, but only 1 enclose it",
        ),
        (
            "surface s() { float i; for (i = 0; i < 2; i += 1) { illuminance(P) { break; } } }",
            "`break` inside an `illuminance` body",
        ),
        (
            "float f() { break; return 1; } surface s() { float i; for (i = 0; i < 2; i += 1) Ci = f(); }",
            "`break` outside a loop",
        ),
        (
            "surface s() { float i = 0; while ((i += 1) < 3) { } }",
            "assignments in a loop's condition are not built",
        ),
        (
            "surface s() { float i = 0; while (i) { } }",
            "a loop condition must be a comparison, not a float",
        ),
    ] {
        let e = compile(src).unwrap_err();
        assert!(e.contains(want), "{src}:\n{e}");
        assert!(e.contains("t.sl:1:"), "the place: {e}");
    }
}

/// A `for` loop with a constant trip count (parameters baked) unrolls into straight-line
/// code: no loop left, the same bits as the loop in f32; a varying trip count stays a loop;
/// the JIT (scalar and batch entries) gives the interpreter's bits either way.
#[test]
fn constant_loops_unroll_and_every_cpu_entry_agrees() {
    use shadenet::graph::opt::{self, Specialization};
    use shadenet::runtime::Backend;
    let src = r#"
        surface s(float octaves = 4) {
            uniform float i;
            float sum = 0, amp = 1;
            point PP = P * 3;
            for (i = 0; i < octaves; i += 1) {
                sum += amp * noise(PP);
                amp *= 0.5;
                PP *= 2.1;
            }
            float n = 0, j = 0;
            while (j < s * 12) { j += 1; if (j == 5) continue; n += noise(P * j); }
            Ci = color(sum, n, j);
        }"#;
    let p = compile(src).unwrap();
    assert_eq!(loops(&p), 2);
    let spec = Specialization::default();
    let (o, report) = opt::run(&p, &spec);
    assert_eq!(
        loops(&o),
        1,
        "the octave loop unrolls, the varying one stays:\n{o}"
    );
    let unroll = report.passes.iter().find(|s| s.pass == "unroll").unwrap();
    assert_eq!(unroll.changes, 1);
    let mut keep = spec.clone();
    keep.passes.unroll = false;
    let (kept, _) = opt::run(&p, &keep);
    assert_eq!(loops(&kept), 2);
    let env = shadenet::shade::grid_env(&[]);
    let grid = |prog: &Program| {
        let g = shadenet::shade::shade_grid::<f32>(prog, &env, 17, 9, u32::MAX).unwrap();
        g.pixel_values()
            .iter()
            .map(|x| (*x as f32).to_bits())
            .collect::<Vec<_>>()
    };
    let want = grid(&p);
    assert!(want.iter().any(|b| *b != 0));
    assert_eq!(grid(&o), want, "unrolled = loop, bit for bit");
    assert_eq!(grid(&kept), want);
    let m = shadenet_jit::JitBackend::new().compile(&p, &spec).unwrap();
    assert_eq!(m.info().fallback, None, "the JIT compiles loops");
    for batch in [false, true] {
        let g = shadenet::shade::shade_grid_with(&*m, &env, 17, 9, u32::MAX, batch);
        let bits: Vec<u32> = g
            .pixel_values()
            .iter()
            .map(|x| (*x as f32).to_bits())
            .collect();
        assert_eq!(bits, want, "jit batch {batch}");
    }
}

/// Unrolling has a budget: a constant loop longer than `MAX_TRIPS` stays a loop, and one
/// that never ends is never unrolled (the iteration limit stops it at run time).
#[test]
fn unrolling_stays_within_its_budget() {
    use shadenet::graph::opt::{self, Specialization, unroll};
    let long = format!(
        "surface s() {{ float i, x = 0; for (i = 0; i < {}; i += 1) x += s; Ci = x; }}",
        unroll::MAX_TRIPS + 1
    );
    let short = format!(
        "surface s() {{ float i, x = 0; for (i = 0; i < {}; i += 1) x += s; Ci = x; }}",
        unroll::MAX_TRIPS
    );
    let endless = "surface s() { float x = 0; while (1 == 1) x += s; Ci = x; }";
    let spec = Specialization::default();
    for (src, left) in [(long.as_str(), 1), (short.as_str(), 0), (endless, 1)] {
        let (o, _) = opt::run(&compile(src).unwrap(), &spec);
        assert_eq!(loops(&o), left, "{src}");
    }
}

/// `--param NAME=VALUE` sets a parameter before compiling: a baked octave count changes the
/// unrolled program; unknown names and bad values are errors that name them.
#[test]
fn the_cli_sets_parameters_before_compiling() {
    let dir = tmp("shader_loops", "param");
    std::fs::create_dir_all(&dir).unwrap();
    let sl = dir.join("oct.sl");
    std::fs::write(
        &sl,
        "surface oct(float octaves = 4) { uniform float i; float x = 0;\n\
         for (i = 0; i < octaves; i += 1) x += noise(P * pow(2, i)); Ci = x; }\n",
    )
    .unwrap();
    let sl = sl.to_str().unwrap();
    let calls = |args: &[&str]| {
        let (code, out, err) = shadenet(args);
        assert_eq!(code, 0, "{args:?}: {err}");
        out.matches("call osl_perlin3").count()
    };
    assert_eq!(calls(&["compile", sl]), 4);
    assert_eq!(calls(&["compile", sl, "--param", "octaves=2"]), 2);
    for (p, want) in [
        (
            "octave=2",
            "`oct` has no parameter `octave` (its parameters: octaves)",
        ),
        (
            "octaves=two",
            "`two` is not a number or comma-separated numbers",
        ),
        (
            "octaves=1,2,3",
            "parameter `octaves` is a float: (1, 2, 3) is not one",
        ),
        ("octaves", "expected NAME=VALUE"),
    ] {
        let (code, _, err) = shadenet(&["compile", sl, "--param", p]);
        assert_eq!(code, 1, "{p}");
        assert!(err.contains(&format!("--param {p}: {want}")), "{p}: {err}");
    }
}

/// Nested constant loops unroll inner first, then outer: the outer copies read the inner
/// copies' results (they once read the inner loop's removed results: an invalid program,
/// found compiling MaterialX's `mx_worleynoise2d_float`). The unrolled program gives the
/// loop program's bits.
#[test]
fn nested_constant_loops_unroll_to_the_same_values() {
    let src = r#"
        surface s(float jitter = 1.5) {
            float best = 1e6, x, y, n = 0;
            for (x = -1; x <= 1; x += 1) {
                for (y = -1; y <= 1; y += 1) {
                    float d = (x - s) * jitter + (y - t) * (y - t);
                    if (d < best) { best = d; n += 1; }
                }
                n += 0.5;
            }
            Ci = color(best, n, x + y);
        }"#;
    let p = compile(src).unwrap();
    let (o, report) = shadenet::graph::opt::run(&p, &Default::default());
    shadenet::graph::ir::validate(&o).unwrap();
    assert_eq!(loops(&o), 0, "both loops unrolled");
    let unrolled: usize = report
        .passes
        .iter()
        .filter(|s| s.pass == "unroll")
        .map(|s| s.changes)
        .sum();
    assert!(unrolled >= 2, "{:?}", report.passes);
    for st in [(0.1, 0.9), (0.5, 0.5), (0.93, 0.2)] {
        let mut f = plane_fragment();
        f.uv = [st.0 as f32, st.1 as f32];
        let a = run_program(&p, &f, &[], u32::MAX);
        let b = run_program(&o, &f, &[], u32::MAX);
        assert_eq!(a.get32("Ci"), b.get32("Ci"), "at {st:?}");
        assert_eq!(a.get("Ci"), b.get("Ci"), "at {st:?} (f64)");
    }
}
