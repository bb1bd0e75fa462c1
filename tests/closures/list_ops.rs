//! The closure list operations, checked exactly: `scaled`, `add`, `mix` and `layer` give the
//! lobe lists and weights they document, and the closure's eval is the weighted sum of its
//! lobes' evals. (The mixture's sampling is in the case table: chi-square and weight =
//! value/pdf of `mix(…)` and `layer(…)`.)

use super::harness::{Query, Rng, compile_with};
use shadenet_graph::closure::{Closure, Frame, Lobe, LobeKind};
use shadenet_graph::ir::{Builder, Program, Stream, UnOp, Value};
use shadenet_runtime::InterpBackend;

fn lambert(b: &mut Builder, frame: Frame, color: [f64; 3], rough: f64) -> Closure {
    let kind = LobeKind::OrenNayar {
        color: b.color(color),
        roughness: b.float(rough),
        energy_compensation: false,
    };
    let weight = b.color([1.0, 1.0, 1.0]);
    Closure::lobe(Lobe {
        kind,
        weight,
        frame,
        component: "diffuse",
        unbuilt: None,
    })
}

/// Outputs pairs `got_k`, `want_k` (colors) built by `f`; checks them on random queries.
/// Builds (got, want) pairs from the frame, `wo` and `wi`.
type Pairs = fn(&mut Builder, Frame, Value, Value) -> Vec<(Value, Value)>;

fn check(what: &str, f: Pairs) {
    let mut b = Builder::new(what);
    let i = b.stream(Stream::I);
    let wo = b.unary(UnOp::Neg, i);
    let wi = b.stream(Stream::P);
    let n = b.stream(Stream::N);
    let t = b.stream(Stream::DPdv);
    let frame = Frame::new(&mut b, n, t, wo);
    let pairs = f(&mut b, frame, wo, wi);
    for (k, (g, w)) in pairs.iter().enumerate() {
        b.output(&format!("got{k}"), None, *g);
        b.output(&format!("want{k}"), None, *w);
    }
    let p: Program = b.finish().unwrap();
    let c = compile_with(&InterpBackend, &p);
    let mut rng = Rng(5);
    let qs: Vec<Query> = (0..64)
        .map(|_| {
            let mut wo = rng.sphere();
            wo[2] = wo[2].abs();
            let mut wi = rng.sphere();
            wi[2] = wi[2].abs();
            Query::new(wo, wi, rng.u3())
        })
        .collect();
    let frags: Vec<_> = qs.iter().map(Query::fragment).collect();
    let (out, bad) = c.raw(&frags);
    assert_eq!(bad, 0, "{what}: non-finite");
    let layout = c.material.layout();
    let w = c.material.width();
    for (q, o) in qs.iter().zip(out.chunks(w)) {
        for k in 0..pairs.len() {
            let at = |name: String| {
                let s = layout.iter().find(|s| s.name == name).unwrap();
                &o[s.offset..s.offset + 3]
            };
            let (g, want) = (at(format!("got{k}")), at(format!("want{k}")));
            for ch in 0..3 {
                assert!(
                    (g[ch] - want[ch]).abs() <= 1e-6 * want[ch].abs().max(1e-3),
                    "{what} pair {k} at {q:?}: {g:?} vs {want:?}"
                );
            }
        }
    }
}

/// Σ w_k f_k |cos| by hand.
fn by_hand(b: &mut Builder, c: &Closure, wo: Value, wi: Value) -> Value {
    let mut sum = b.zero(shadenet_graph::types::Type::Color);
    for l in &c.lobes {
        let e = l.eval(b, wo, wi);
        let v = b.mul(l.weight, e.value);
        sum = b.add(sum, v);
    }
    sum
}

#[test]
fn scaled_add_and_mix_weights() {
    check("mix", |b, fr, wo, wi| {
        let x = lambert(b, fr, [0.9, 0.5, 0.2], 0.0);
        let y = lambert(b, fr, [0.1, 0.8, 0.4], 0.7);
        let t = b.float(0.3);
        let m = Closure::mix(b, &x, &y, t);
        assert_eq!(m.lobes.len(), 2);
        let ex = x.eval(b, wo, wi).value;
        let ey = y.eval(b, wo, wi).value;
        let (kt, ko) = (b.color([0.3; 3]), b.color([0.7; 3]));
        let want = {
            let a = b.mul(ex, ko);
            let c = b.mul(ey, kt);
            b.add(a, c)
        };
        let got = m.eval(b, wo, wi).value;
        let hand = by_hand(b, &m, wo, wi);
        // Weights: bg (1 − t), fg t.
        let w0 = m.lobes[0].weight;
        let w1 = m.lobes[1].weight;
        let k = b.color([2.0, 3.0, 0.5]);
        let s = x.scaled(b, k);
        let es = s.eval(b, wo, wi).value;
        let ws = b.mul(ex, k);
        let sum = Closure::add(b, &x, &y);
        assert_eq!(sum.lobes.len(), 2);
        let es2 = sum.eval(b, wo, wi).value;
        let ws2 = b.add(ex, ey);
        vec![
            (got, want),
            (hand, want),
            (w0, ko),
            (w1, kt),
            (es, ws),
            (es2, ws2),
        ]
    });
}

#[test]
fn layer_scales_the_base_by_one_minus_the_top_albedo() {
    check("layer", |b, fr, wo, wi| {
        let top = lambert(b, fr, [0.6, 0.3, 0.9], 0.4);
        let h = b.float(0.5);
        let top = top.scaled(b, h);
        let base = lambert(b, fr, [0.2, 0.9, 0.5], 1.0);
        let l = Closure::layer(b, &top, &base, wo);
        assert_eq!(l.lobes.len(), 2);
        let a = top.albedo(b, wo);
        let one = b.color([1.0; 3]);
        let through = b.sub(one, a);
        let et = top.eval(b, wo, wi).value;
        let eb = base.eval(b, wo, wi).value;
        let want = {
            let x = b.mul(eb, through);
            b.add(et, x)
        };
        let got = l.eval(b, wo, wi).value;
        vec![(got, want), (l.lobes[1].weight, through)]
    });
}

#[test]
fn emission_adds_and_scales() {
    let mut b = Builder::new("emission");
    let e1 = b.color([1.0, 2.0, 3.0]);
    let e2 = b.color([0.5, 0.5, 0.5]);
    let x = Closure::emitter(e1);
    let y = Closure::emitter(e2);
    let s = Closure::add(&mut b, &x, &y);
    assert!(s.lobes.is_empty() && s.emission.is_some());
    let t = b.float(0.25);
    let m = Closure::mix(&mut b, &x, &y, t);
    b.output("sum", None, s.emission.unwrap());
    b.output("mix", None, m.emission.unwrap());
    let p = b.finish().unwrap();
    let c = compile_with(&InterpBackend, &p);
    let (o, _) = c.raw(&[Query::new([0.0, 0.0, 1.0], [0.0, 0.0, 1.0], [0.0; 3]).fragment()]);
    let at = |n: &str| {
        let s = c.material.layout().iter().find(|s| s.name == n).unwrap();
        o[s.offset..s.offset + 3].to_vec()
    };
    assert_eq!(at("sum"), vec![1.5, 2.5, 3.5]);
    assert_eq!(at("mix"), vec![0.875, 1.625, 2.375]);
}
