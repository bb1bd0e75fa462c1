//! Messages (issue 22, item 3): OSL's `printf`, `warning` and `error` become print ops that
//! the optimizer keeps and every CPU back end writes in fragment order — the interpreter in
//! f32 and f64, the JIT's scalar entry and its batch entry (whose packets run four fragments
//! in lockstep; masked and padding lanes write nothing) — with the same text; `shade` prints
//! exactly what the shader prints, and the GPU path falls back.

mod common;
use common::*;
use shadenet::graph::ir::{Op, Program, Severity};
use shadenet::graph::ops::printf::{self, Arg};
use shadenet::graph::opt::{self, Specialization};
use shadenet::lang::Dialect;
use shadenet::runtime::Backend;
use shadenet::runtime::messages::{Message, Messages};
use shadenet::shade::{BatchMode, grid_env, grid_fragment};

/// Prints from straight-line code, a varying `if`, a constant loop, a varying loop, a
/// closure `if` (lowered flat: both arms run, each print under its arm's condition) and an
/// inlined function that returns early; constants (the string parameter, a folded number)
/// are spliced into the format at compile time.
const SHADER: &str = r#"
    float half_up(float x) {
        if (x > 0.5) {
            warning("x = %.2f is high", x);
            return 1;
        }
        return 0;
    }
    surface s(string name = "pt", float k = 2) {
        printf("%s %d: u=%.3f k=%g P=%g\n", name, 3 * 4, u, k, P);
        float h = half_up(u);
        for (int i = 0; i < 2; i++)
            printf(" i%d", i);
        int j = 0;
        while (j < 3 * v) {
            printf(" j%d", j);
            j++;
        }
        if (v > 0.5) {
            Ci = diffuse(N);
            printf(" top %s\n", "(closure)");
        } else {
            Ci = h * diffuse(N);
            printf(" bottom %5.1f%%\n", 100 * v);
        }
        if (u < 0.2 && v < 0.2)
            error("corner %d %d", 1, 2);
        printf("end\n");
        printf("end\n");
    }"#;

fn m(severity: Severity, text: String) -> Message {
    Message { severity, text }
}

/// What `SHADER` prints for the fragments of a `w × h` grid, pixel after pixel, computed
/// here from the fragments (with Rust's formatting where it is C's).
fn expected(w: u32, h: u32) -> Vec<Message> {
    use Severity::*;
    let mut out = Vec::new();
    for y in 0..h {
        for x in 0..w {
            let f = grid_fragment(x, y, w, h);
            let [u, v] = f.uv;
            // `%g` as C writes it (the formatter is checked against glibc in its own tests).
            let p =
                f.p.map(|c| printf::format("%g", &[Arg::Float(c.into())]).unwrap());
            out.push(m(
                Printf,
                format!("pt 12: u={u:.3} k=2 P={} {} {}\n", p[0], p[1], p[2]),
            ));
            if u > 0.5 {
                out.push(m(Warning, format!("x = {u:.2} is high")));
            }
            out.push(m(Printf, " i0".into()));
            out.push(m(Printf, " i1".into()));
            let mut j = 0;
            while (j as f32) < 3.0 * v {
                out.push(m(Printf, format!(" j{j}")));
                j += 1;
            }
            if v > 0.5 {
                out.push(m(Printf, " top (closure)\n".into()));
            } else {
                out.push(m(Printf, format!(" bottom {:5.1}%\n", 100.0 * v)));
            }
            if u < 0.2 && v < 0.2 {
                out.push(m(Error, "corner 1 2".into()));
            }
            out.push(m(Printf, "end\n".into()));
            out.push(m(Printf, "end\n".into()));
        }
    }
    out
}

fn program() -> Program {
    compile_shader(SHADER, Dialect::Osl).unwrap()
}

/// Every CPU back end writes the same messages, in fragment order, as the shader defines
/// them: the interpreter (f32, f64) after optimization, the JIT's scalar entry, its batch
/// entry over rows of 5 (a padding lane in every second packet) and over runs of
/// fragments in parallel; nothing is left in the thread's log.
#[test]
fn every_cpu_back_end_prints_in_fragment_order() {
    let (w, h) = (5, 6);
    let want = expected(w, h);
    assert!(want.len() > 100, "{}", want.len());
    let env = grid_env(&[]);
    let spec = Specialization::default();
    let (p, _) = opt::run(&program(), &spec);
    let prints = {
        let mut n = 0;
        p.walk(&p.body, &mut |v| {
            n += matches!(p.op(v), Op::Print { .. }) as usize
        });
        n
    };
    assert_eq!(
        prints, 10,
        "the optimizer keeps every print, the two equal ones too\n{p}"
    );
    let check = |got: &Messages, what: &str| {
        assert_eq!(got.dropped, 0, "{what}");
        for (k, (g, w)) in got.list.iter().zip(&want).enumerate() {
            assert_eq!(g, w, "{what}: message {k}");
        }
        assert_eq!(got.list.len(), want.len(), "{what}");
    };
    let g = shadenet::shade::shade_grid::<f32>(&p, &env, w, h, spec.components).unwrap();
    check(&g.messages, "interp f32");
    let g = shadenet::shade::shade_grid::<f64>(&p, &env, w, h, spec.components).unwrap();
    check(&g.messages, "interp f64");
    let jit = shadenet_jit::JitBackend::new();
    let material = jit.compile(&program(), &spec).unwrap();
    assert!(material.info().fallback.is_none());
    for batch in [false, true] {
        let g = shadenet::shade::shade_grid_with(&*material, &env, w, h, spec.components, batch);
        check(&g.messages, &format!("jit, batch {batch}"));
    }
    let frags: Vec<_> = (0..h)
        .flat_map(|y| (0..w).map(move |x| grid_fragment(x, y, w, h)))
        .collect();
    for mode in [BatchMode::Single, BatchMode::Batches, BatchMode::All] {
        let g = shadenet::shade::shade_fragments(&*material, &env, &frags, spec.components, mode);
        check(&g.messages, &format!("jit, {mode:?}"));
    }
    assert!(shadenet::runtime::messages::take().is_empty());
}

/// `shade --res 1x1` prints exactly what the shader prints, on every CPU back end: printf
/// output on stdout (alone with `-q`), warnings and errors on stderr as OSL's error
/// handler writes them; the summary counts them.
#[test]
fn shade_prints_exactly_what_the_shader_prints() {
    let file = tmp("print", "s.osl");
    std::fs::write(&file, SHADER).unwrap();
    let out = tmp("print", "s.exr");
    let want: String = expected(1, 1)
        .into_iter()
        .filter(|m| m.severity == Severity::Printf)
        .map(|m| m.text)
        .collect();
    assert!(
        want.starts_with("pt 12: u=0.500 k=2 P=0 0 0\n i0 i1 j0 j1 bottom  50.0%\n"),
        "{want}"
    );
    for backend in [
        &["--backend", "interp"][..],
        &["--backend", "jit"],
        &["--backend", "jit-batch"],
        &["--precision", "f64"],
    ] {
        let mut args = vec!["shade", file.to_str().unwrap(), "--res", "1x1", "-q"];
        args.extend(["-o", out.to_str().unwrap()]);
        args.extend(backend);
        let (code, stdout, stderr) = shadenet(&args);
        assert_eq!(code, 0, "{backend:?}: {stderr}");
        assert_eq!(stdout, want, "{backend:?}");
        assert!(!stderr.contains("WARNING"), "{stderr}");
    }
    // A corner pixel warns and errs; the summary counts the messages.
    let (code, stdout, stderr) = shadenet(&[
        "shade",
        file.to_str().unwrap(),
        "--res",
        "6x6",
        "-o",
        out.to_str().unwrap(),
    ]);
    assert_eq!(code, 0, "{stderr}");
    assert!(stderr.contains("WARNING: x = 0.58 is high\n"), "{stderr}");
    assert!(stderr.contains("ERROR: corner 1 2\n"), "{stderr}");
    let all = expected(6, 6);
    let count = |s: Severity| all.iter().filter(|m| m.severity == s).count();
    let line = format!(
        "shader messages: {} printf, {} warnings, {} errors",
        count(Severity::Printf),
        count(Severity::Warning),
        count(Severity::Error)
    );
    assert!(stdout.contains(&line), "{line}\n{stdout}");
}

/// The GPU path does not print: a material that prints is refused with the reason (the
/// renderer's and `shade`'s fallback then shade it on the CPU), planned without a device.
#[test]
fn the_gpu_path_refuses_a_material_that_prints() {
    let file = tmp("print", "g.osl");
    std::fs::write(&file, SHADER).unwrap();
    let (code, _, err) = shadenet_env(
        &["compile", file.to_str().unwrap(), "--emit", "wgsl"],
        &[("SHADENET_GPU_ADAPTER", "none")],
    );
    assert_ne!(code, 0);
    assert!(
        err.contains(
            "printf is not supported by the gpu back end: the GPU path does not write messages"
        ),
        "{err}"
    );
}

/// Bad calls: the error names the call and what is wrong.
#[test]
fn bad_prints_are_errors_that_say_why() {
    let cases = [
        ("printf(1.5);", "`printf` takes a format string first"),
        (
            "printf(\"%d\", 1.5);",
            "`printf`: conversion 1 (`%d`) takes an int",
        ),
        (
            "printf(\"%d\", u);",
            "`printf`: conversion 1 (`%d`) takes an int",
        ),
        (
            "printf(\"%g %g\", u);",
            "conversion 2 (`%g`) has no argument",
        ),
        ("printf(\"%g\", u, v);", "2 arguments but 1 conversions"),
        ("printf(\"%q\", u);", "unknown conversion `%q`"),
        (
            "float a[2] = {1, 2}; printf(\"%g\", a);",
            "`printf`'s argument 2 cannot be printed",
        ),
        (
            "printf(\"%g\", diffuse(N));",
            "`printf`'s argument 2 cannot be printed",
        ),
        ("warning(\"%s\", P);", "conversion 1 (`%s`) takes a string"),
    ];
    for (body, want) in cases {
        let src = format!("surface s() {{ {body} }}");
        let err = compile_shader(&src, Dialect::Osl).unwrap_err();
        assert!(err.contains(want), "{body}\n→ {err}");
        assert!(err.contains("t.osl:1:"), "the place: {err}");
    }
    // RSL has printf, not OSL's warning.
    let ok = compile_shader("surface s() { printf(\"%f\\n\", s); }", Dialect::Rsl);
    assert!(ok.is_ok(), "{ok:?}");
    let err = compile_shader("surface s() { warning(\"x\"); }", Dialect::Rsl).unwrap_err();
    assert!(err.contains("warning"), "{err}");
}
