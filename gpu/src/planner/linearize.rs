//! Linearization: the program's top-level block as one sequence of [`Item`]s and host steps.
//!
//! Owns: walking the body once, in order; an `If` becomes its arms' items under a [`Guard`]
//! and a merge, an `Illuminance` one atomic item (plus a host step for its light samples when
//! they are seen from a point other than the stream `P`), a `Loop` one atomic item (refused
//! when it holds a host step or a light loop), `trace` and `occlusion` host steps; the light
//! sets. Must not touch: how the sequence is cut into passes
//! ([`super::partition`]) or which values cross a step ([`super::liveness`]).

use crate::plan::{Guard, HostKind, Item, ItemKind, LightSet, is_remat, value_name};
use shadenet_graph::ir::{Block, Op, Program, Stream, Value};
use shadenet_runtime::BackendError;
use std::collections::HashMap;

/// One entry of the linear sequence before partitioning.
pub(super) enum Entry {
    /// An item of a pass.
    Item(Item),
    /// A host step under its guard.
    Host(HostKind, Guard),
}

/// The state of one linearization.
struct Linearizer<'a> {
    p: &'a Program,
    prelude: &'a HashMap<usize, usize>,
    names: &'a [Option<u32>],
    entries: Vec<Entry>,
    sets: Vec<LightSet>,
    /// The set of light loops at the stream `P`, once one exists.
    set_p: Option<usize>,
}

fn unsupported(p: &Program, names: &[Option<u32>], v: Value, reason: String) -> BackendError {
    BackendError::Unsupported {
        backend: "gpu",
        material: p.name.clone(),
        op: format!("{} = {}", value_name(names, v), p.op(v).short_name()),
        reason,
    }
}

impl Linearizer<'_> {
    /// Appends the entries of `block`, run under `guard`.
    fn block(&mut self, block: &Block, guard: &Guard) -> Result<(), BackendError> {
        let p = self.p;
        for &v in &block.body {
            if is_remat(p, self.prelude, v) {
                continue;
            }
            match p.op(v) {
                Op::Proj(..) => {}
                Op::If { cond, then_, else_ } => {
                    let mut g = guard.clone();
                    g.push((*cond, true));
                    self.block(then_, &g)?;
                    g.pop();
                    g.push((*cond, false));
                    self.block(else_, &g)?;
                    let cost = then_.yields.len().max(1);
                    self.entries.push(Entry::Item(Item {
                        kind: ItemKind::Merge(v),
                        guard: guard.clone(),
                        cost,
                    }));
                }
                Op::Illuminance { p: point, body } => {
                    let cost = self.region_cost(v, "light loop")?;
                    let reads_visible = {
                        let mut r = false;
                        p.walk(body, &mut |b| r |= *p.op(b) == Op::LightVisible);
                        r
                    };
                    let set = if *p.op(*point) == Op::Stream(Stream::P) {
                        match self.set_p {
                            Some(s) => {
                                self.sets[s].visible |= reads_visible;
                                s
                            }
                            None => {
                                self.sets.push(LightSet {
                                    point: None,
                                    visible: reads_visible,
                                });
                                self.set_p = Some(self.sets.len() - 1);
                                self.sets.len() - 1
                            }
                        }
                    } else {
                        self.sets.push(LightSet {
                            point: Some(*point),
                            visible: reads_visible,
                        });
                        let s = self.sets.len() - 1;
                        self.entries.push(Entry::Host(
                            HostKind::LightSamples { region: v, set: s },
                            guard.clone(),
                        ));
                        s
                    };
                    self.entries.push(Entry::Item(Item {
                        kind: ItemKind::Illuminance { region: v, set },
                        guard: guard.clone(),
                        cost,
                    }));
                }
                Op::Loop { .. } => {
                    let cost = self.region_cost(v, "loop")?;
                    self.entries.push(Entry::Item(Item {
                        kind: ItemKind::Loop { region: v },
                        guard: guard.clone(),
                        cost,
                    }));
                }
                Op::LoopVar(_) => {
                    let why = "`loop.var` outside a loop".to_string();
                    return Err(unsupported(p, self.names, v, why));
                }
                Op::Trace { .. } => self
                    .entries
                    .push(Entry::Host(HostKind::Trace(v), guard.clone())),
                Op::Occlusion { .. } => self
                    .entries
                    .push(Entry::Host(HostKind::Occlusion(v), guard.clone())),
                _ => self.entries.push(Entry::Item(Item {
                    kind: ItemKind::Value(v),
                    guard: guard.clone(),
                    cost: 1,
                })),
            }
        }
        Ok(())
    }
}

impl Linearizer<'_> {
    /// The cost of the region `v` (a light loop or a loop: the ops inside it, run once), or
    /// the refusal of what it holds that one kernel cannot run: a host step (`trace`,
    /// `occlusion`) or a light loop. `kind` names the region in the message.
    fn region_cost(&self, v: Value, kind: &str) -> Result<usize, BackendError> {
        let p = self.p;
        let mut cost = 0;
        let mut bad = None;
        for inner in p.op(v).blocks() {
            p.walk(inner, &mut |b| {
                if matches!(
                    p.op(b),
                    Op::Trace { .. } | Op::Occlusion { .. } | Op::Illuminance { .. }
                ) {
                    bad.get_or_insert(b);
                }
                if !is_remat(p, self.prelude, b) && !matches!(p.op(b), Op::Proj(..)) {
                    cost += 1;
                }
            });
        }
        if let Some(b) = bad {
            return Err(unsupported(
                p,
                self.names,
                b,
                format!(
                    "inside the {kind} {}: the GPU back end runs a {kind} whole in one kernel \
                     and cannot stop it for a host step or a light loop",
                    value_name(self.names, v)
                ),
            ));
        }
        Ok(cost.max(1))
    }
}

/// Why the GPU path refuses the ops [`cpu_only`] finds, in the order they are reported.
const CPU_ONLY: [&str; 3] = [
    // Messages go to the calling thread's log in fragment order, which no kernel can do.
    "the GPU path does not write messages (printf, warning, error); the CPU shades a \
     material that prints, in fragment order",
    "probe rays (OSL's trace) ask the renderer's scene on the CPU; the GPU back end has no \
     host step for them",
    // Geometry attributes (primvars) live in the renderer's meshes, which no kernel reads.
    "geometry attributes (vertex colours, primvars) are read through the renderer's \
     services on the CPU; the GPU back end has no attribute buffers",
];

/// Which of [`CPU_ONLY`]'s reasons refuses `op`, if any.
fn cpu_only(op: &Op) -> Option<usize> {
    match op {
        Op::Print { .. } => Some(0),
        Op::Probe { .. } => Some(1),
        Op::Attribute { .. } | Op::AttributeFound { .. } => Some(2),
        _ => None,
    }
}

/// The items and host steps of `p`'s body in order, and the light sets its light loops read.
/// `prelude` holds the uniform slot of each prelude value; `names` the printer's numbering
/// (for the errors).
pub(super) fn linearize(
    p: &Program,
    prelude: &HashMap<usize, usize>,
    names: &[Option<u32>],
) -> Result<(Vec<Entry>, Vec<LightSet>), BackendError> {
    // Ops that need what no kernel has, in the order their refusals are reported: the
    // material falls back to a CPU back end.
    let mut found: [Option<Value>; 3] = [None; 3];
    p.walk(&p.body, &mut |v| {
        if let Some(k) = cpu_only(p.op(v)) {
            found[k].get_or_insert(v);
        }
    });
    if let Some((k, v)) = found.iter().enumerate().find_map(|(k, v)| Some((k, (*v)?))) {
        return Err(unsupported(p, names, v, CPU_ONLY[k].to_string()));
    }
    let mut lin = Linearizer {
        p,
        prelude,
        names,
        entries: Vec::new(),
        sets: Vec::new(),
        set_p: None,
    };
    lin.block(&p.body, &Vec::new())?;
    Ok((lin.entries, lin.sets))
}
