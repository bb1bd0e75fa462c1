//! The message helpers: what compiled code calls for an [`Op::Print`] (OSL's `printf`,
//! `warning`, `error`).
//!
//! A material keeps one [`PrintTable`]: each print op's severity, format and argument types,
//! numbered in the order of the program's arena (the lowering numbers them the same way).
//! Compiled code stores the op's argument components in a stack slot — one 32-bit word each
//! (floats as f32 bits, ints as i32, bools as 0 or not), four lanes per word in the batch
//! entry, after a lane mask — and calls [`sn_print`] or [`sn_print_x4`], which format the
//! message through `shadenet_runtime::messages`, as the interpreter does. The batch helper
//! skips lanes off the active mask and padding lanes, and tags each message with its
//! fragment, so that the batch's messages come out in fragment order.
//! It owns the words' layout; it must not format (the runtime's `messages` does).
//!
//! [`Op::Print`]: shadenet_graph::ir::Op::Print

use super::CallCtx;
use shadenet_graph::ir::{Op, Program, Severity};
use shadenet_graph::ops::printf::Arg;
use shadenet_graph::types::Type;
use shadenet_runtime::{LANES, messages};

/// One print op: what it writes and the types of the values it formats.
#[derive(Clone, Debug)]
struct PrintDesc {
    severity: Severity,
    format: String,
    tys: Vec<Type>,
}

/// The print ops of a program, in arena order: index `k` is the `k`-th print op.
#[derive(Clone, Debug, Default)]
pub struct PrintTable(Vec<PrintDesc>);

impl PrintTable {
    /// The table of `program`'s print ops.
    pub fn new(program: &Program) -> PrintTable {
        let descs = print_ops(program).filter_map(|(_, op)| match op {
            Op::Print {
                severity,
                format,
                args,
            } => Some(PrintDesc {
                severity: *severity,
                format: format.clone(),
                tys: args.iter().map(|a| program.ty(*a)).collect(),
            }),
            _ => None,
        });
        PrintTable(descs.collect())
    }

    /// The number of each of `program`'s print ops in its table, by arena index: what the
    /// compiled code passes the message helpers.
    pub fn numbers(program: &Program) -> std::collections::HashMap<usize, u32> {
        print_ops(program)
            .enumerate()
            .map(|(k, (at, _))| (at, k as u32))
            .collect()
    }

    /// Whether the program has no print op.
    pub fn is_empty(&self) -> bool {
        self.0.is_empty()
    }

    /// The words print op `index` stores: one per argument component.
    fn words(&self, index: u32) -> usize {
        self.0
            .get(index as usize)
            .map_or(0, |d| d.tys.iter().map(|t| t.width()).sum())
    }

    /// Writes print op `index`'s message with component `k`'s word `word(k)`: for fragment
    /// `at` of a batch, or straight to the log.
    fn write(&self, index: u32, at: Option<u32>, word: impl Fn(usize) -> u32) {
        let Some(d) = self.0.get(index as usize) else {
            return;
        };
        let mut k = 0;
        let args: Vec<Arg> = d
            .tys
            .iter()
            .map(|t| {
                let n = t.width();
                let first = k;
                k += n;
                match t {
                    Type::Int => Arg::Int(i64::from(word(first) as i32)),
                    Type::Bool => Arg::Int(i64::from(word(first) != 0)),
                    Type::Float => messages::float_arg(f64::from(f32::from_bits(word(first)))),
                    _ => messages::floats_arg(
                        (first..first + n).map(|i| f64::from(f32::from_bits(word(i)))),
                    ),
                }
            })
            .collect();
        match at {
            Some(f) => messages::write_at(f, d.severity, &d.format, &args),
            None => messages::write(d.severity, &d.format, &args),
        }
    }
}

/// A program's print ops in arena order with their arena indices: the table's numbering.
fn print_ops(program: &Program) -> impl Iterator<Item = (usize, &Op)> {
    program
        .exprs
        .iter()
        .enumerate()
        .filter(|(_, e)| matches!(e.op, Op::Print { .. }))
        .map(|(k, e)| (k, &e.op))
}

/// The print table of the context's material (empty for a null pointer).
fn table(ctx: &CallCtx) -> Option<&PrintTable> {
    // SAFETY: a non-null `prints` points at the material's table, which outlives its calls.
    unsafe { ctx.prints.as_ref() }
}

/// Scalar entry: writes print op `index` of the context's material with the words at
/// `words` (one per argument component).
///
/// # Safety
/// `ctx` is a live call context; `words` holds the op's words.
pub unsafe extern "C" fn sn_print(ctx: *const CallCtx, index: u32, words: *const u32) {
    // SAFETY: see above.
    let Some(t) = table(unsafe { &*ctx }) else {
        return;
    };
    // SAFETY: compiled code stored `t.words(index)` words there.
    let w = unsafe { std::slice::from_raw_parts(words, t.words(index)) };
    t.write(index, None, |k| w[k]);
}

/// Batch entry: `words` holds the active lane mask (four words, non-zero: active), then
/// four lanes per component; writes the message of each active lane that holds a fragment
/// (below the context's `lanes`) for its fragment in the batch (`first + lane`): the
/// material flushes the batch's messages in fragment order after the call
/// (`messages::flush_batch`), so they read as the scalar entry's.
///
/// # Safety
/// `ctx` is a live call context; `words` holds `4 × (1 + components)` words.
pub unsafe extern "C" fn sn_print_x4(ctx: *const CallCtx, index: u32, words: *const u32) {
    // SAFETY: see above.
    let ctx = unsafe { &*ctx };
    let Some(t) = table(ctx) else {
        return;
    };
    // SAFETY: compiled code stored the mask and `t.words(index)` components of four lanes.
    let w = unsafe { std::slice::from_raw_parts(words, LANES * (1 + t.words(index))) };
    for lane in 0..(ctx.lanes as usize).min(LANES) {
        if w[lane] != 0 {
            let at = ctx.first + lane as u32;
            t.write(index, Some(at), |k| w[(1 + k) * LANES + lane]);
        }
    }
}
