//! The lowerings of the MaterialX matrix atoms (`matrix33`, `matrix44`): arithmetic,
//! products, transpose, determinant, inverse, `creatematrix`, `extract` of a row and
//! `transformmatrix`, each written element by element with `extract`/`construct` and scalar
//! IR arithmetic, so every back end runs them as it runs floats (constant, uniform or per
//! fragment) and partial evaluation folds or hoists them like any arithmetic. The product,
//! transpose, determinant and inverse are [`crate::ir::matrix`]'s (the OSL front end uses
//! the same copy).
//!
//! Convention: a MaterialX matrix value is row-major with row vectors (`p·M`); ours are
//! column vectors (`M·p`), so [`super::value::literal`] stores the transpose `Mᵀ`. Every
//! formula here is MaterialX's (its OSL implementation) rewritten for the transposes:
//! `in1·in2` becomes `in2ᵀ·in1ᵀ`, a MaterialX row is one of our columns. This module owns
//! those formulas; it must not decide which nodedef uses which lowering (the table in
//! [`super::atoms`] does).

use crate::ir::matrix::{Mat, determinant as det, inverse, product};
use crate::ir::{BinOp, Builder, Value};
use crate::nodes::{LowVal, NodeInputs};
use crate::types::Type;

type Out = Result<Vec<LowVal>, String>;

fn one(v: Value) -> Out {
    Ok(vec![LowVal::plain(v)])
}

/// Whether input `port` of a node is a matrix (the node's matrix variant).
pub fn on_matrix(b: &Builder, inp: &NodeInputs, port: &str) -> bool {
    b.ty(inp.get(port)).is_matrix()
}

/// `in1 op in2` element by element; a float `in2` applies to every element (`mx_add`,
/// `mx_subtract` of a matrix and a float).
pub fn elementwise(b: &mut Builder, inp: &NodeInputs, op: BinOp) -> Out {
    let x = Mat::of(b, inp.get("in1"))?;
    let y = inp.get("in2");
    let ys = if b.ty(y) == Type::Float {
        vec![y; x.e.len()]
    } else {
        Mat::of(b, y)?.e
    };
    let mut k = 0;
    let r = x.map(|a| {
        k += 1;
        b.binary(op, *a, ys[k - 1])
    });
    one(r.build(b))
}

/// MaterialX `in1 * in2` (a matrix product): ours `in2ᵀ·in1ᵀ`.
pub fn multiply(b: &mut Builder, inp: &NodeInputs) -> Out {
    let (x, y) = (Mat::of(b, inp.get("in1"))?, Mat::of(b, inp.get("in2"))?);
    let r = product(b, &y, &x);
    one(r.build(b))
}

/// MaterialX `in1 / in2` = `in1 * inverse(in2)` (OSL's matrix division): ours
/// `inverse(in2ᵀ)·in1ᵀ`; a singular `in2` has the zero matrix as inverse (see [`inverse`]).
pub fn divide(b: &mut Builder, inp: &NodeInputs) -> Out {
    let (x, y) = (Mat::of(b, inp.get("in1"))?, Mat::of(b, inp.get("in2"))?);
    let yi = inverse(b, &y);
    let r = product(b, &yi, &x);
    one(r.build(b))
}

/// The transpose.
pub fn transpose(b: &mut Builder, inp: &NodeInputs) -> Out {
    let x = Mat::of(b, inp.get("in"))?;
    one(crate::ir::matrix::transpose(&x).build(b))
}

/// The determinant (cofactor expansion along the first row); the same for `Mᵀ`.
pub fn determinant(b: &mut Builder, inp: &NodeInputs) -> Out {
    let x = Mat::of(b, inp.get("in"))?;
    one(det(b, &x))
}

/// The inverse (`adj / det`; the zero matrix where the determinant is 0). Transposing
/// commutes with inversion, so ours is MaterialX's.
pub fn invertmatrix(b: &mut Builder, inp: &NodeInputs) -> Out {
    let x = Mat::of(b, inp.get("in"))?;
    let r = inverse(b, &x);
    one(r.build(b))
}

/// A matrix whose MaterialX rows are `in1`, `in2`, `in3` (, `in4`): our columns. vector3
/// rows of a matrix44 get w = 0, and 1 for `in4` (`mx_creatematrix_vector3_matrix44`).
pub fn creatematrix(b: &mut Builder, inp: &NodeInputs) -> Out {
    let ty = inp.def.outputs[0].ty.unwrap_or(Type::Matrix44);
    let n = ty.matrix_size();
    if n == 0 {
        return Err("creatematrix makes a matrix33 or matrix44".into());
    }
    let ports = ["in1", "in2", "in3", "in4"];
    let zero = b.float(0.0);
    let unit = b.float(1.0);
    let mut cols: Vec<Vec<Value>> = Vec::new();
    for (k, port) in ports.iter().enumerate().take(n) {
        let v = inp.get(port);
        let w = b.ty(v).width();
        let mut col: Vec<Value> = (0..w.min(n)).map(|i| b.extract(v, i)).collect();
        while col.len() < n {
            col.push(if k == 3 { unit } else { zero });
        }
        cols.push(col);
    }
    let e: Vec<Value> = (0..n * n).map(|i| cols[i % n][i / n]).collect();
    one(b.construct(ty, &e))
}

/// Row `index` of the MaterialX matrix (our column `index`) as a vector3 or vector4; an
/// index other than 0, 1 (, 2) gives the last row, as `mx_extract_matrix33/44` does.
pub fn extract(b: &mut Builder, inp: &NodeInputs) -> Out {
    let x = Mat::of(b, inp.get("in"))?;
    let i = inp.get("index");
    let n = x.n;
    let vty = Type::float_vec(n).expect("3 or 4");
    let cols: Vec<Value> = (0..n)
        .map(|c| {
            let e: Vec<Value> = (0..n).map(|r| x.at(r, c)).collect();
            b.construct(vty, &e)
        })
        .collect();
    let mut r = cols[n - 1];
    for c in (0..n - 1).rev() {
        let k = b.int(c as i32);
        let is = b.binary(BinOp::Eq, i, k);
        r = b.select(is, cols[c], r);
    }
    one(r)
}

/// `M·v` of our matrix (MaterialX `v·M`): a vector2 as the point `(x, y, 1)` of a matrix33
/// (`.xy` of the result), a vector3 by a matrix33, a vector4 by a matrix44, and a vector3
/// by a matrix44 as the point `(x, y, z, 1)` (`.xyz`, no division by w).
pub fn transformmatrix(b: &mut Builder, inp: &NodeInputs) -> Out {
    let (v, m) = (inp.get("in"), inp.get("mat"));
    let (vt, mt) = (b.ty(v), b.ty(m));
    if vt == Type::Vec3 && mt == Type::Matrix44 {
        return one(b.binary(BinOp::MulPoint, m, v));
    }
    let x = Mat::of(b, m)?;
    let n = x.n;
    let w = vt.width();
    if !vt.is_vector() || !(w == n || (w == 2 && n == 3)) {
        return Err(format!(
            "transformmatrix of a {vt} by a {mt} is not defined"
        ));
    }
    let mut xs: Vec<Value> = (0..w).map(|i| b.extract(v, i)).collect();
    if w < n {
        xs.push(b.float(1.0));
    }
    let out: Vec<Value> = (0..w)
        .map(|r| {
            let mut s = b.mul(x.at(r, 0), xs[0]);
            for (k, xk) in xs.iter().enumerate().skip(1) {
                let p = b.mul(x.at(r, k), *xk);
                s = b.add(s, p);
            }
            s
        })
        .collect();
    one(b.construct(vt, &out))
}
