//! Fragments from Python: the table of fields `Material.shade` accepts, their defaults, the
//! checks on them (lengths, finite values), and `shadenet.grid` (the CLI `shade` grid as
//! fields).

use crate::boundary::{f32_bytes, value_error};
use pyo3::prelude::*;
use pyo3::types::{PyBytes, PyDict};
use shadenet::graph::ir::RAY_CAMERA;
use shadenet::runtime::Fragment;
use shadenet::shade::{EYE, grid_fragment};

/// How a field's values are stored.
#[derive(Clone, Copy, PartialEq, Eq)]
enum Kind {
    /// Little-endian `f32`.
    F32,
    /// Little-endian `u32`.
    U32,
}

/// Every field: its key, values per fragment and storage. `P` is required; the others have
/// defaults ([`fragments`]).
const FIELDS: &[(&str, usize, Kind)] = &[
    ("P", 3, Kind::F32),
    ("N", 3, Kind::F32),
    ("Ng", 3, Kind::F32),
    ("I", 3, Kind::F32),
    ("uv", 2, Kind::F32),
    ("dPdu", 3, Kind::F32),
    ("dPdv", 3, Kind::F32),
    ("dPdx", 3, Kind::F32),
    ("dPdy", 3, Kind::F32),
    ("time", 1, Kind::F32),
    ("seed", 1, Kind::U32),
];

/// The field table for the Python layer: `(key, values per fragment, "f32" | "u32")`.
pub(crate) fn field_table() -> Vec<(&'static str, usize, &'static str)> {
    FIELDS
        .iter()
        .map(|(k, n, kind)| {
            let dtype = match kind {
                Kind::F32 => "f32",
                Kind::U32 => "u32",
            };
            (*k, *n, dtype)
        })
        .collect()
}

/// One field's values, decoded: `n × width` numbers, row after row.
enum Column {
    /// Floats.
    F32(Vec<f32>),
    /// Seeds.
    U32(Vec<u32>),
}

impl Column {
    /// The `width` floats of row `i`.
    fn f32_row<const W: usize>(&self, i: usize) -> [f32; W] {
        match self {
            Column::F32(v) => std::array::from_fn(|k| v[i * W + k]),
            Column::U32(_) => [0.0; W],
        }
    }
}

/// Decodes one field's bytes, checking the length and (for floats) that every value is
/// finite; errors name the key and the row.
fn decode(key: &str, bytes: &[u8], n: usize, width: usize, kind: Kind) -> PyResult<Column> {
    if bytes.len() != n * width * 4 {
        return Err(value_error(format!(
            "fragments[\"{key}\"]: {} values, expected {n} rows of {width}",
            bytes.len() / 4
        )));
    }
    let words = bytes
        .chunks_exact(4)
        .map(|b| [b[0], b[1], b[2], b[3]])
        .collect::<Vec<_>>();
    Ok(match kind {
        Kind::U32 => Column::U32(words.into_iter().map(u32::from_le_bytes).collect()),
        Kind::F32 => {
            let v: Vec<f32> = words.into_iter().map(f32::from_le_bytes).collect();
            if let Some(at) = v.iter().position(|x| !x.is_finite()) {
                return Err(value_error(format!(
                    "fragments[\"{key}\"]: row {} holds {} (every value must be finite)",
                    at / width,
                    v[at]
                )));
            }
            Column::F32(v)
        }
    })
}

/// The fragments of `n` rows from a dict of field bytes (keys of [`FIELDS`]; `P` required).
/// Defaults: `N` = +z, `Ng` = `N`, `I` = `P` − the grid's eye (0, 0, 1.5), `dPdu` = +x,
/// `dPdv` = +y, `uv`, `dPdx`, `dPdy` and `time` 0, `seed` the row index; every fragment a
/// camera ray of depth 0 with the `rand` stream at 0.5, as the `shade` grid's.
pub(crate) fn fragments(n: usize, fields: &Bound<'_, PyDict>) -> PyResult<Vec<Fragment>> {
    let mut cols: Vec<Option<Column>> = (0..FIELDS.len()).map(|_| None).collect();
    for (k, v) in fields.iter() {
        let key: String = k.extract()?;
        let Some(at) = FIELDS.iter().position(|f| f.0 == key) else {
            let known: Vec<&str> = FIELDS.iter().map(|f| f.0).collect();
            return Err(value_error(format!(
                "fragments: unknown key \"{key}\" (known: {})",
                known.join(", ")
            )));
        };
        let bytes = v.cast::<PyBytes>()?;
        let (_, width, kind) = FIELDS[at];
        cols[at] = Some(decode(&key, bytes.as_bytes(), n, width, kind)?);
    }
    let col = |key: &str| {
        let at = FIELDS.iter().position(|f| f.0 == key).unwrap_or(0);
        cols[at].as_ref()
    };
    let Some(p) = col("P") else {
        return Err(value_error(
            "fragments: \"P\" is required (one row per fragment)",
        ));
    };
    let row3 = |key: &str, i: usize, default: [f32; 3]| col(key).map_or(default, |c| c.f32_row(i));
    let mut out = Vec::with_capacity(n);
    for i in 0..n {
        let pos: [f32; 3] = p.f32_row(i);
        let n_ = row3("N", i, [0.0, 0.0, 1.0]);
        let eye = EYE.map(|e| e as f32);
        out.push(Fragment {
            p: pos,
            n: n_,
            ng: row3("Ng", i, n_),
            i: row3("I", i, std::array::from_fn(|k| pos[k] - eye[k])),
            uv: col("uv").map_or([0.0; 2], |c| c.f32_row(i)),
            dpdu: row3("dPdu", i, [1.0, 0.0, 0.0]),
            dpdv: row3("dPdv", i, [0.0, 1.0, 0.0]),
            dpdx: row3("dPdx", i, [0.0; 3]),
            dpdy: row3("dPdy", i, [0.0; 3]),
            time: col("time").map_or(0.0, |c| c.f32_row::<1>(i)[0]),
            ray_type: RAY_CAMERA,
            ray_depth: 0,
            seed: match col("seed") {
                Some(Column::U32(s)) => s[i],
                _ => i as u32,
            },
            rand: [0.5; 4],
        });
    }
    Ok(out)
}

/// Fields crossing to Python: `(key, bytes, values per fragment, dtype)` each.
type Fields<'py> = Vec<(&'static str, Bound<'py, PyBytes>, usize, &'static str)>;

/// The fields of the `shadenet shade` grid of `width × height` fragments (rows top to
/// bottom): every key of the field table as `(key, bytes, values per fragment, dtype)`.
#[pyfunction]
pub(crate) fn grid<'py>(py: Python<'py>, width: u32, height: u32) -> PyResult<Fields<'py>> {
    let max = shadenet::tracer::scene::MAX_RESOLUTION;
    if width == 0 || height == 0 || width > max || height > max {
        return Err(value_error(format!(
            "grid {width}x{height}: the size must be between 1x1 and {max}x{max}"
        )));
    }
    let frags: Vec<Fragment> = (0..height)
        .flat_map(|y| (0..width).map(move |x| grid_fragment(x, y, width, height)))
        .collect();
    let floats =
        |f: &dyn Fn(&Fragment) -> Vec<f32>| -> Vec<f32> { frags.iter().flat_map(f).collect() };
    let mut out = Vec::new();
    for (key, w, kind) in FIELDS {
        let values = match *key {
            "P" => floats(&|f| f.p.to_vec()),
            "N" => floats(&|f| f.n.to_vec()),
            "Ng" => floats(&|f| f.ng.to_vec()),
            "I" => floats(&|f| f.i.to_vec()),
            "uv" => floats(&|f| f.uv.to_vec()),
            "dPdu" => floats(&|f| f.dpdu.to_vec()),
            "dPdv" => floats(&|f| f.dpdv.to_vec()),
            "dPdx" => floats(&|f| f.dpdx.to_vec()),
            "dPdy" => floats(&|f| f.dpdy.to_vec()),
            "time" => floats(&|f| vec![f.time]),
            _ => {
                let seeds: Vec<u8> = frags.iter().flat_map(|f| f.seed.to_le_bytes()).collect();
                out.push((*key, PyBytes::new(py, &seeds), *w, "u32"));
                continue;
            }
        };
        debug_assert!(*kind == Kind::F32);
        out.push((*key, f32_bytes(py, &values), *w, "f32"));
    }
    Ok(out)
}
