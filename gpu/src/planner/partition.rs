//! Partitioning: the linear sequence cut into passes between its host steps.
//!
//! Owns: the runs of items between host steps, how many passes each run gets
//! ([`PassMode::Count`]: in proportion to its cost), and the cut of each run (by op budget,
//! fused, or into equal-cost parts). Must not touch: what the items are
//! ([`super::linearize`]) or the values that cross the cuts ([`super::liveness`]).

use super::linearize::Entry;
use crate::options::{GpuOptions, PassMode};
use crate::plan::{Guard, HostKind, Item};

/// A step before its loads, stores and kernel are known.
pub(super) enum RawStep {
    /// The items of a pass.
    Pass(Vec<Item>),
    /// A host step under its guard.
    Host(HostKind, Guard),
}

/// Cuts the linear sequence into steps: each run of items between host steps split into
/// passes as `options` ask, the host steps between them.
pub(super) fn cut(entries: Vec<Entry>, options: &GpuOptions) -> Vec<RawStep> {
    // Runs of items between host steps.
    let mut runs: Vec<Vec<Item>> = vec![Vec::new()];
    let mut hosts: Vec<(HostKind, Guard)> = Vec::new();
    for e in entries {
        match e {
            Entry::Item(it) => runs.last_mut().expect("a run").push(it),
            Entry::Host(h, g) => {
                hosts.push((h, g));
                runs.push(Vec::new());
            }
        }
    }
    let parts = match options.passes {
        PassMode::Count(n) => {
            let costs: Vec<(usize, usize)> = runs
                .iter()
                .map(|r| (r.iter().map(|i| i.cost).sum(), r.len()))
                .collect();
            share_passes(&costs, n as usize)
        }
        _ => vec![1; runs.len()],
    };
    let mut raw: Vec<RawStep> = Vec::new();
    let mut hosts = hosts.into_iter();
    for (k, run) in runs.into_iter().enumerate() {
        for items in partition(run, options.passes, options.op_budget, parts[k]) {
            raw.push(RawStep::Pass(items));
        }
        if let Some((h, g)) = hosts.next() {
            raw.push(RawStep::Host(h, g));
        }
    }
    raw
}

/// Splits one run of items (between host steps) into passes.
fn partition(items: Vec<Item>, mode: PassMode, budget: usize, parts: usize) -> Vec<Vec<Item>> {
    if items.is_empty() {
        return Vec::new();
    }
    match mode {
        PassMode::Fused => vec![items],
        PassMode::Auto => {
            let budget = budget.max(1);
            let mut out: Vec<Vec<Item>> = Vec::new();
            let mut cur: Vec<Item> = Vec::new();
            let mut cost = 0;
            for it in items {
                if !cur.is_empty() && cost + it.cost > budget {
                    out.push(std::mem::take(&mut cur));
                    cost = 0;
                }
                cost += it.cost;
                cur.push(it);
            }
            out.push(cur);
            out
        }
        PassMode::Count(_) => {
            let parts = parts.clamp(1, items.len());
            let total: usize = items.iter().map(|i| i.cost).sum();
            let n = items.len();
            let mut out: Vec<Vec<Item>> = Vec::new();
            let mut cur: Vec<Item> = Vec::new();
            let mut cum = 0usize;
            for (k, it) in items.into_iter().enumerate() {
                cum += it.cost;
                cur.push(it);
                let done = out.len();
                let left_items = n - k - 1;
                let left_parts = parts - done - 1;
                if left_parts == 0 {
                    continue;
                }
                // Close this part when it reached its share, or when every remaining item
                // must start a part of its own.
                if cum * parts >= total * (done + 1) || left_items == left_parts {
                    out.push(std::mem::take(&mut cur));
                }
            }
            if !cur.is_empty() {
                out.push(cur);
            }
            out
        }
    }
}

/// How many of `n` passes each run of items gets: proportional to its cost, at least one
/// per non-empty run, at most one per item.
fn share_passes(costs: &[(usize, usize)], n: usize) -> Vec<usize> {
    let total: usize = costs.iter().map(|c| c.0).sum::<usize>().max(1);
    let mut k: Vec<usize> = costs
        .iter()
        .map(|&(c, items)| {
            if items == 0 {
                0
            } else {
                (c * n / total).clamp(1, items)
            }
        })
        .collect();
    // Too many (each run got at least one): take back from the runs with the least cost
    // per pass.
    while k.iter().sum::<usize>() > n {
        let cheapest = (0..costs.len())
            .filter(|&i| k[i] > 1)
            .min_by_key(|&i| (costs[i].0 * 1000) / k[i]);
        match cheapest {
            Some(i) => k[i] -= 1,
            None => break,
        }
    }
    // Hand out what is left to the runs with the most cost per pass.
    loop {
        let used: usize = k.iter().sum();
        if used >= n {
            break;
        }
        let best = (0..costs.len())
            .filter(|&i| k[i] < costs[i].1)
            .max_by_key(|&i| (costs[i].0 * 1000) / k[i].max(1));
        match best {
            Some(i) => k[i] += 1,
            None => break,
        }
    }
    k
}
