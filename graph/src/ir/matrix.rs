//! Matrix formulas written element by element on the [`Builder`]: a matrix's elements are
//! `extract`ed, combined with scalar IR arithmetic and `construct`ed again, so every back
//! end runs them as it runs floats (constant, uniform or per fragment) and partial
//! evaluation folds or hoists them like any arithmetic. The IR's matrices are column-vector
//! matrices stored row-major (`M·p`, DESIGN §3); a front end whose language uses row
//! vectors (MaterialX, OSL) stores the transpose and rewrites its formulas for it (see
//! `crate::mtlx::atoms_matrix` and the OSL front end). This module owns the formulas
//! (product, transpose, determinant, inverse); it must not know any language's convention.

use super::{Builder, UnOp, Value};
use crate::types::Type;

/// A matrix's elements (IR values, floats), row-major, with its size (3 or 4).
#[derive(Clone, Debug)]
pub struct Mat {
    /// Rows (= columns).
    pub n: usize,
    /// The `n·n` elements, row-major.
    pub e: Vec<Value>,
}

impl Mat {
    /// The elements of matrix value `m`, or an error naming what `m` is.
    pub fn of(b: &mut Builder, m: Value) -> Result<Mat, String> {
        let n = b.ty(m).matrix_size();
        if n == 0 {
            return Err(format!("expected a matrix, found a {}", b.ty(m)));
        }
        let e = (0..n * n).map(|i| b.extract(m, i)).collect();
        Ok(Mat { n, e })
    }

    /// Element (`r`, `c`).
    pub fn at(&self, r: usize, c: usize) -> Value {
        self.e[r * self.n + c]
    }

    /// The matrix value of these elements.
    pub fn build(&self, b: &mut Builder) -> Value {
        let ty = Type::matrix(self.n).expect("size 3 or 4");
        b.construct(ty, &self.e)
    }

    /// Each element mapped by `f`.
    pub fn map(&self, f: impl FnMut(&Value) -> Value) -> Mat {
        Mat {
            n: self.n,
            e: self.e.iter().map(f).collect(),
        }
    }
}

/// `x·y`, sums in index order (`((x0·y0 + x1·y1) + x2·y2) + …`).
pub fn product(b: &mut Builder, x: &Mat, y: &Mat) -> Mat {
    let n = x.n;
    let mut e = Vec::with_capacity(n * n);
    for r in 0..n {
        for c in 0..n {
            let mut s = b.mul(x.at(r, 0), y.at(0, c));
            for k in 1..n {
                let p = b.mul(x.at(r, k), y.at(k, c));
                s = b.add(s, p);
            }
            e.push(s);
        }
    }
    Mat { n, e }
}

/// The transpose.
pub fn transpose(x: &Mat) -> Mat {
    let n = x.n;
    let e = (0..n * n).map(|i| x.at(i % n, i / n)).collect();
    Mat { n, e }
}

/// The determinant of the rows/columns `rows` × `cols` of `x` (cofactor expansion along the
/// first listed row, alternating signs; a 2×2 as `a·d − b·c`).
pub fn minor(b: &mut Builder, x: &Mat, rows: &[usize], cols: &[usize]) -> Value {
    if rows.len() == 1 {
        return x.at(rows[0], cols[0]);
    }
    if rows.len() == 2 {
        let ad = b.mul(x.at(rows[0], cols[0]), x.at(rows[1], cols[1]));
        let bc = b.mul(x.at(rows[0], cols[1]), x.at(rows[1], cols[0]));
        return b.sub(ad, bc);
    }
    let mut sum: Option<Value> = None;
    for (j, &c) in cols.iter().enumerate() {
        let rest: Vec<usize> = cols.iter().copied().filter(|k| *k != c).collect();
        let m = minor(b, x, &rows[1..], &rest);
        let t = b.mul(x.at(rows[0], c), m);
        sum = Some(match sum {
            None => t,
            Some(s) if j % 2 == 1 => b.sub(s, t),
            Some(s) => b.add(s, t),
        });
    }
    sum.expect("at least one column")
}

/// The determinant (cofactor expansion along the first row); the same for the transpose.
pub fn determinant(b: &mut Builder, x: &Mat) -> Value {
    let idx: Vec<usize> = (0..x.n).collect();
    minor(b, x, &idx, &idx)
}

/// `adj(x) / det(x)` (each cofactor divided by the determinant): with the IR's total
/// division a singular matrix (determinant exactly 0) has the zero matrix as inverse.
/// Transposing commutes with inverting, so it serves either convention.
pub fn inverse(b: &mut Builder, x: &Mat) -> Mat {
    let n = x.n;
    let d = determinant(b, x);
    let mut e = Vec::with_capacity(n * n);
    for r in 0..n {
        for c in 0..n {
            // inverse[r][c] = (−1)^(r+c) · minor(c, r) / det
            let rows: Vec<usize> = (0..n).filter(|k| *k != c).collect();
            let cols: Vec<usize> = (0..n).filter(|k| *k != r).collect();
            let m = minor(b, x, &rows, &cols);
            let m = if (r + c) % 2 == 1 {
                b.unary(UnOp::Neg, m)
            } else {
                m
            };
            e.push(b.div(m, d));
        }
    }
    Mat { n, e }
}
