//! The prelude block: printed, parsed, validated and evaluated once per material instance.

use shadenet_graph::ir::{Op, Stream, parse, validate};
use shadenet_runtime::{Fragment, Interpreter, ShadeCtx, ShadeEnv};

const TEXT: &str = r#"program "pre" {
  param "k" float = 2.0
  prelude {
    %0 = param 0 : float
    %1 = const 3.0 : float
    %2 = mul %0, %1 : float
    %3 = splat %2 : vec3
  }
  %4 = stream P : vec3
  %5 = mul %4, %3 : vec3
  output out %5
}
"#;

#[test]
fn prelude_round_trips_and_runs() {
    let p = parse(TEXT).unwrap();
    validate(&p).unwrap();
    assert_eq!(p.to_string(), TEXT);
    assert_eq!(p.prelude.body.len(), 4);
    assert_eq!(p.op_count(), 6);
    let env = ShadeEnv::default();
    let frag = Fragment {
        p: [1.0, 2.0, -0.5],
        ..Fragment::default()
    };
    let out = Interpreter::<f32>::new(&p)
        .unwrap()
        .shade(&ShadeCtx::new(frag, &env));
    assert_eq!(out.values, vec![6.0, 12.0, -3.0]);
}

#[test]
fn prelude_rejects_varying_values() {
    let mut p = parse(TEXT).unwrap();
    // Move the stream into the prelude: it reads the fragment.
    let s = p.body.body.remove(0);
    assert!(matches!(p.op(s), Op::Stream(Stream::P)));
    p.prelude.body.push(s);
    let e = validate(&p).unwrap_err().to_string();
    assert!(
        e.contains("cannot be in the prelude") && e.contains("fragment"),
        "{e}"
    );
}

#[test]
fn prelude_cannot_read_body_values() {
    let src = TEXT
        .replace(
            "%3 = splat %2 : vec3",
            "%3 = splat %2 : vec3\n    %9 = add %2, %6 : float",
        )
        .replace(
            "%5 = mul %4, %3 : vec3",
            "%5 = mul %4, %3 : vec3\n  %6 = const 1.0 : float",
        );
    // The parser already rejects the forward reference.
    assert!(parse(&src).is_err());
}
