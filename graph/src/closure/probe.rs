//! Lobe probes: which lobes of a material survive specialization.
//!
//! The closure lowering emits every lobe a material's graph builds; a lobe whose weight
//! folds to 0 is then deleted by the partial evaluator (every lobe's work is guarded by
//! "weight ≠ 0"). To say which lobes are left, a probed lowering
//! ([`crate::lower::LowerOptions::closure_output`] = [`declare`]) outputs each lobe's
//! weight under a reserved name instead of shading; after optimization a probe whose value
//! is the constant 0 is a lobe specialization removed ([`read`]). Probed programs are for
//! reports and tests (`compile --stats`), never rendered.
//!
//! It owns the probe outputs' naming; it must not know lobe formulas or MaterialX nodes.

use super::{Closure, LobeKind, ScatterMode};
use crate::ir::{Builder, Op, Program};
use crate::types::ConstValue;

/// The separator between a material's output name and a probe's description. Output names
/// from networks never hold it (MaterialX names are XML names; JSON outputs are
/// identifiers).
const MARK: &str = "#lobe";

/// One lobe of a probed material after optimization.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct LobeStat {
    /// The material output the lobe belongs to.
    pub material: String,
    /// The lobe kind ([`LobeKind::name`]).
    pub kind: String,
    /// Its render component.
    pub component: String,
    /// Whether the lobe is left: its weight did not fold to the constant 0.
    pub live: bool,
}

impl LobeKind {
    /// The kind's short name: the pbrlib node without `_bsdf`, with the scatter mode of a
    /// specular interface (`dielectric(RT)`); `phong` and `blinn` for the Maya lobes.
    pub fn name(&self) -> String {
        let mode = |m: &ScatterMode| match m {
            ScatterMode::R => "R",
            ScatterMode::T => "T",
            ScatterMode::RT => "RT",
        };
        match self {
            LobeKind::OrenNayar { .. } => "oren_nayar_diffuse".into(),
            LobeKind::Burley { .. } => "burley_diffuse".into(),
            LobeKind::Translucent { .. } => "translucent".into(),
            LobeKind::Sheen { .. } => "sheen".into(),
            LobeKind::Subsurface { .. } => "subsurface".into(),
            LobeKind::Dielectric { scatter_mode, .. } => {
                format!("dielectric({})", mode(scatter_mode))
            }
            LobeKind::Conductor { .. } => "conductor".into(),
            LobeKind::GeneralizedSchlick { scatter_mode, .. } => {
                format!("generalized_schlick({})", mode(scatter_mode))
            }
            LobeKind::Phong { .. } => "phong".into(),
            LobeKind::Blinn { .. } => "blinn".into(),
        }
    }
}

/// Outputs each lobe weight of `closure` (material output `name`) as a probe (a
/// [`crate::lower::ClosureOutputFn`]).
pub fn declare(b: &mut Builder, name: &str, closure: &Closure) {
    for (i, l) in closure.lobes.iter().enumerate() {
        let probe = format!("{name}{MARK}{i}:{}:{}", l.kind.name(), l.component);
        b.output(&probe, None, l.weight);
    }
}

/// The probes of an (optimized) probed program, in lobe order per material.
pub fn read(p: &Program) -> Vec<LobeStat> {
    p.outputs
        .iter()
        .filter_map(|o| {
            let (material, rest) = o.name.split_once(MARK)?;
            let mut it = rest.splitn(3, ':');
            let (_, kind, component) = (it.next()?, it.next()?, it.next()?);
            let zero = matches!(
                p.op(o.value),
                Op::Const(ConstValue::Color(c)) if c.iter().all(|x| *x == 0.0)
            );
            Some(LobeStat {
                material: material.to_string(),
                kind: kind.to_string(),
                component: component.to_string(),
                live: !zero,
            })
        })
        .collect()
}
