//! The WGSL a kernel includes besides its own code: the declarations of the intrinsic library
//! ([`crate::emit::library`], `sn_texture`) that the kernel needs, directly or through each
//! other, and the transform helpers.
//!
//! Owns: splitting a WGSL library into its top-level declarations and keeping only those a
//! kernel names. Must not touch: the kernel's own code ([`super::writer`]) or the library's
//! text ([`crate::emit`]).

/// The transform helpers: `ops::transform` with matrices in `sn_uni` at slot `b`, each
/// component summed left to right exactly as the Rust code does.
pub(super) const TRANSFORM_HELPERS: &str = "
fn snk_xf_point(b: u32, v: vec3<f32>) -> vec3<f32> {
    return vec3<f32>(
        sn_uni[b] * v.x + sn_uni[b + 1u] * v.y + sn_uni[b + 2u] * v.z + sn_uni[b + 3u],
        sn_uni[b + 4u] * v.x + sn_uni[b + 5u] * v.y + sn_uni[b + 6u] * v.z + sn_uni[b + 7u],
        sn_uni[b + 8u] * v.x + sn_uni[b + 9u] * v.y + sn_uni[b + 10u] * v.z + sn_uni[b + 11u]);
}

fn snk_xf_vector(b: u32, v: vec3<f32>) -> vec3<f32> {
    return vec3<f32>(
        sn_uni[b] * v.x + sn_uni[b + 1u] * v.y + sn_uni[b + 2u] * v.z,
        sn_uni[b + 4u] * v.x + sn_uni[b + 5u] * v.y + sn_uni[b + 6u] * v.z,
        sn_uni[b + 8u] * v.x + sn_uni[b + 9u] * v.y + sn_uni[b + 10u] * v.z);
}

fn snk_xf_normal(b: u32, v: vec3<f32>) -> vec3<f32> {
    return vec3<f32>(
        sn_uni[b] * v.x + sn_uni[b + 4u] * v.y + sn_uni[b + 8u] * v.z,
        sn_uni[b + 1u] * v.x + sn_uni[b + 5u] * v.y + sn_uni[b + 9u] * v.z,
        sn_uni[b + 2u] * v.x + sn_uni[b + 6u] * v.y + sn_uni[b + 10u] * v.z);
}
";

/// One top-level declaration of a WGSL library text: its name and its text (with the comment
/// lines after it, up to the next declaration).
struct LibItem<'a> {
    name: &'a str,
    text: &'a str,
}

/// Splits a WGSL library into its top-level declarations (`fn`, `const`, `struct`, `alias`,
/// `var`, `override` at the start of a line); `None` if some code is outside them (then the
/// library is included whole).
fn library_items(lib: &str) -> Option<(&str, Vec<LibItem<'_>>)> {
    let mut starts = Vec::new();
    let mut at = 0;
    for line in lib.split_inclusive('\n') {
        let name = ["fn ", "const ", "struct ", "alias ", "override "]
            .iter()
            .find_map(|k| line.strip_prefix(k))
            .or_else(|| {
                line.strip_prefix("var")
                    .and_then(|r| r.split_once('>').map(|x| x.1).or(Some(r)))
            })
            .map(|r| {
                let r = r.trim_start();
                let end = r
                    .find(|c: char| !(c.is_ascii_alphanumeric() || c == '_'))
                    .unwrap_or(r.len());
                &r[..end]
            });
        if let Some(name) = name.filter(|n| !n.is_empty()) {
            starts.push((at, name));
        }
        at += line.len();
    }
    let head = &lib[..starts.first().map_or(lib.len(), |s| s.0)];
    // Only comments and blank lines may come before the first declaration.
    if head
        .lines()
        .any(|l| !l.trim().is_empty() && !l.trim_start().starts_with("//"))
    {
        return None;
    }
    let items = starts
        .iter()
        .enumerate()
        .map(|(k, &(a, name))| LibItem {
            name,
            text: &lib[a..starts.get(k + 1).map_or(lib.len(), |s| s.0)],
        })
        .collect();
    Some((head, items))
}

/// Calls `f` on every identifier of a WGSL text (comments included: harmless, they can only
/// add declarations).
fn identifiers(text: &str, mut f: impl FnMut(&str)) {
    let b = text.as_bytes();
    let mut i = 0;
    while i < b.len() {
        if b[i].is_ascii_alphabetic() || b[i] == b'_' {
            let start = i;
            while i < b.len() && (b[i].is_ascii_alphanumeric() || b[i] == b'_') {
                i += 1;
            }
            f(&text[start..i]);
        } else {
            i += 1;
        }
    }
}

/// The declarations of `lib` that `code` needs (directly or through each other), in the
/// library's order: a kernel compiles faster without the rest (Mesa and LLVM see only what
/// the pass calls). The whole library when it cannot be split.
pub(super) fn library_for(lib: &str, code: &str) -> String {
    let Some((head, items)) = library_items(lib) else {
        return lib.to_string();
    };
    let index: std::collections::HashMap<&str, usize> = items
        .iter()
        .enumerate()
        .map(|(k, it)| (it.name, k))
        .collect();
    let mut keep = vec![false; items.len()];
    let mut todo = Vec::new();
    let mark = |name: &str, keep: &mut Vec<bool>, todo: &mut Vec<usize>| {
        if let Some(&k) = index.get(name)
            && !keep[k]
        {
            keep[k] = true;
            todo.push(k);
        }
    };
    identifiers(code, |n| mark(n, &mut keep, &mut todo));
    while let Some(k) = todo.pop() {
        identifiers(items[k].text, |n| mark(n, &mut keep, &mut todo));
    }
    let mut out = String::from(head);
    for (it, k) in items.iter().zip(&keep) {
        if *k {
            out.push_str(it.text);
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::emit;

    #[test]
    fn the_library_splits_into_declarations() {
        let (_, items) = library_items(emit::library()).expect("lib.wgsl splits");
        assert!(items.iter().any(|i| i.name == "sn_sqrt"));
        let (_, tex) = library_items(emit::TEXTURE_LIBRARY).expect("texture.wgsl splits");
        assert!(tex.iter().any(|i| i.name == "sn_texture"));
    }

    #[test]
    fn only_the_declarations_a_kernel_needs_are_included() {
        let lib = "// head\nconst SN_T = array<f32, 2>(1.0f, 2.0f);\n\
                   fn sn_a(x: f32) -> f32 {\n    return x * SN_T[0];\n}\n\
                   fn sn_b(x: f32) -> f32 {\n    return sn_a(x);\n}\n\
                   // unused\nfn sn_c(x: f32) -> f32 {\n    return x;\n}\n";
        let out = library_for(lib, "fn main() { let y = sn_b(1.0f); }");
        assert!(out.contains("fn sn_a") && out.contains("fn sn_b") && out.contains("SN_T"));
        assert!(!out.contains("fn sn_c"), "{out}");
        // Code outside declarations: the whole library.
        assert_eq!(
            library_for("let x = 1;\nfn sn_a() {}\n", "sn_a"),
            "let x = 1;\nfn sn_a() {}\n"
        );
    }
}
