//! The name rules: what a node name may be, how a connection string splits into node,
//! output and component, and the "did you mean" suggestion for a misspelt node type.
//!
//! It owns only string rules; it must not look at a network or resolve anything.

use crate::nodes::NodeLibrary;

/// Why a node name cannot be used, if it cannot: it is empty, contains `.` or `/`, or
/// starts with `$`.
pub(super) fn bad_name(name: &str) -> Option<String> {
    if name.is_empty() {
        Some("it is empty".into())
    } else if name.contains(['.', '/']) || name.starts_with('$') {
        Some("it must not contain `.` or `/` or start with `$`".into())
    } else {
        None
    }
}

/// A library node type whose name is close to `ty` (case-insensitive match or edit
/// distance ≤ 2).
pub(super) fn suggest<'a>(ty: &str, lib: &'a NodeLibrary) -> Option<&'a str> {
    let lower = ty.to_lowercase();
    lib.defs()
        .iter()
        .map(|d| d.name)
        .map(|n| (edit_distance(&lower, &n.to_lowercase()), n))
        .filter(|(d, _)| *d <= 2)
        .min()
        .map(|(_, n)| n)
}

/// Levenshtein distance between two names (for "did you mean" suggestions).
pub fn edit_distance(a: &str, b: &str) -> usize {
    let b: Vec<char> = b.chars().collect();
    let mut prev: Vec<usize> = (0..=b.len()).collect();
    for (i, ca) in a.chars().enumerate() {
        let mut cur = vec![i + 1];
        for (j, cb) in b.iter().enumerate() {
            let sub = prev[j] + usize::from(ca != *cb);
            cur.push(sub.min(prev[j + 1] + 1).min(cur[j] + 1));
        }
        prev = cur;
    }
    prev[b.len()]
}

/// A parsed connection: node, output, optional component name.
pub(super) fn split_ref(s: &str) -> Option<(&str, &str, Option<&str>)> {
    let mut it = s.split('.');
    let node = it.next()?;
    let out = it.next()?;
    let comp = it.next();
    if it.next().is_some() || node.is_empty() || out.is_empty() {
        return None;
    }
    Some((node, out, comp))
}
