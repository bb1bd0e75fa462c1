//! Dead code elimination: removes every value no output needs.
//!
//! Liveness flows backwards from the outputs: a live value makes its operands live; a live
//! region (one whose results some live `proj` reads) makes its condition or point and every
//! yield of its blocks live. A region none of whose results is read is removed whole, with
//! its blocks — unless it holds an effect ([`Op::Print`], at any depth): effects are live
//! from the start, and so is every region around one (so a loop that prints keeps all its
//! carried values). Prelude values stay only if the body still reads them.

use super::Specialization;
use crate::ir::{Block, Op, Program};

/// Removes dead values; returns how many were removed.
pub fn run(p: &mut Program, _spec: &Specialization) -> usize {
    let before = p.op_count();
    let mut live = vec![false; p.exprs.len()];
    for o in &p.outputs {
        live[o.value.index()] = true;
    }
    effects(p, &p.body, &mut live);
    mark(p, &p.body, &mut live);
    mark(p, &p.prelude, &mut live);
    for e in &mut p.exprs {
        for b in e.op.blocks_mut() {
            b.body.retain(|v| live[v.index()]);
        }
    }
    p.body.body.retain(|v| live[v.index()]);
    p.prelude.body.retain(|v| live[v.index()]);
    before - p.op_count()
}

/// Marks every effect of `block` (at any depth) and every region holding one live; returns
/// whether `block` holds one.
fn effects(p: &Program, block: &Block, live: &mut [bool]) -> bool {
    let mut any = false;
    for &v in &block.body {
        let op = p.op(v);
        let mut here = matches!(op, Op::Print { .. });
        for inner in op.blocks() {
            here |= effects(p, inner, live);
        }
        if here {
            live[v.index()] = true;
            any = true;
        }
    }
    any
}

fn mark(p: &Program, block: &Block, live: &mut [bool]) {
    for y in &block.yields {
        live[y.index()] = true;
    }
    for &v in block.body.iter().rev() {
        if !live[v.index()] {
            continue;
        }
        let op = p.op(v);
        op.for_each_operand(|a| live[a.index()] = true);
        for inner in op.blocks() {
            mark(p, inner, live);
        }
    }
}

#[cfg(test)]
mod tests {
    use crate::ir::{Op, Program, parse, validate};
    use crate::opt::{Specialization, run};

    fn prints(p: &Program) -> Vec<String> {
        let mut v = Vec::new();
        for b in [&p.prelude, &p.body] {
            p.walk(b, &mut |x| {
                if let Op::Print { format, .. } = p.op(x) {
                    v.push(format.clone());
                }
            });
        }
        v
    }

    /// Prints are kept by every pass: two equal ones are not merged, one of a parameter
    /// stays in the body (not hoisted), one of constants is not folded away, and the `if`
    /// and the loop around prints whose results no one reads stay with their prints.
    #[test]
    fn the_optimizer_keeps_every_print() {
        let src = r#"program "m" {
  param "k" float = 2.0
  %k = param 0 : float
  %two = const 2.0 : float
  %kk = mul %k, %two : float
  %a = printf "k = %g\n", %kk : int
  %b = printf "k = %g\n", %kk : int
  %c = printf "constant %g\n", %two : int
  %u = stream time : float
  %cond = gt %u, %two : bool
  %r = if %cond {
    %w = warning "late %g", %u : int
  } else {
  }
  %zero = const 0 : int
  %three = const 3 : int
  %l = loop %zero while {
    %i = loop.var 0 : int
    %go = lt %i, %three : bool
    yield %go
  } do {
    %j = loop.var 0 : int
    %e = error "iteration %d", %j : int
    %one = const 1 : int
    %next = add %j, %one : int
    yield %next
  }
  %out = const 1.0 : float
  output out %out
}
"#;
        let p = parse(src).unwrap();
        validate(&p).unwrap();
        let (o, _) = run(&p, &Specialization::default());
        validate(&o).unwrap();
        let mut got = prints(&o);
        got.sort();
        // The constant loop is unrolled, its print once per iteration with the counter
        // folded into the text; constants (the parameter's default too) are formatted in,
        // what varies stays an argument.
        let want = ["iteration 0", "iteration 1", "iteration 2"];
        assert_eq!(
            got.iter().filter(|f| want.contains(&f.as_str())).count(),
            3,
            "{o}"
        );
        assert_eq!(got.iter().filter(|f| *f == "k = 4\n").count(), 2, "{o}");
        assert!(got.iter().any(|f| f == "constant 2\n"), "{o}");
        assert!(got.iter().any(|f| f == "late %g"), "{o}");
        assert!(
            o.prelude
                .body
                .iter()
                .all(|v| !matches!(o.op(*v), Op::Print { .. }))
        );
    }

    /// A print in the prelude, an argument no message shows and a format that does not fit
    /// its arguments are invalid programs.
    #[test]
    fn bad_prints_are_invalid() {
        let bad = |body: &str| {
            let src = format!("program \"m\" {{\n  %x = const 1.0 : float\n  {body}\n}}\n");
            let p = parse(&src).unwrap();
            validate(&p).unwrap_err().to_string()
        };
        assert!(bad("%p = printf \"%d\", %x : int").contains("takes an int"));
        assert!(bad("%p = printf \"%g %g\", %x : int").contains("has no argument"));
        assert!(
            bad("%s = const \"a\" : string\n  %p = printf \"%s\", %s : int")
                .contains("cannot format")
        );
        let mut p = parse("program \"m\" {\n  %p = printf \"x\" : int\n}\n").unwrap();
        p.prelude.body = std::mem::take(&mut p.body.body);
        assert!(
            validate(&p)
                .unwrap_err()
                .to_string()
                .contains("writes a message")
        );
    }
}
