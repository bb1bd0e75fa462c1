//! The house rules that keep the code readable, checked on the sources themselves: no
//! import circle between the files of a crate, no function over 150 lines in `gpu/`,
//! `tracer/`, `src/` and the linker (`graph/src/link/`) (tests excepted), and a `src/main.rs`
//! that only parses and dispatches (under 200 lines).

use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};

fn root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

/// The `.rs` files under `dir`, recursively, sorted.
fn rust_files(dir: &Path) -> Vec<PathBuf> {
    let mut out = Vec::new();
    let mut stack = vec![dir.to_path_buf()];
    while let Some(d) = stack.pop() {
        for e in std::fs::read_dir(&d).unwrap() {
            let p = e.unwrap().path();
            if p.is_dir() {
                stack.push(p);
            } else if p.extension().is_some_and(|e| e == "rs") {
                out.push(p);
            }
        }
    }
    out.sort();
    out
}

/// The source with comments, string, char and raw-string literals blanked (newlines kept),
/// so braces and paths can be counted.
fn code_only(src: &str) -> String {
    let b = src.as_bytes();
    let mut out = Vec::with_capacity(b.len());
    let mut i = 0;
    let blank = |out: &mut Vec<u8>, c: u8| out.push(if c == b'\n' { b'\n' } else { b' ' });
    while i < b.len() {
        let c = b[i];
        if c == b'/' && b.get(i + 1) == Some(&b'/') {
            while i < b.len() && b[i] != b'\n' {
                out.push(b' ');
                i += 1;
            }
        } else if c == b'/' && b.get(i + 1) == Some(&b'*') {
            let mut depth = 0;
            while i < b.len() {
                if b[i] == b'/' && b.get(i + 1) == Some(&b'*') {
                    depth += 1;
                    out.extend_from_slice(b"  ");
                    i += 2;
                } else if b[i] == b'*' && b.get(i + 1) == Some(&b'/') {
                    depth -= 1;
                    out.extend_from_slice(b"  ");
                    i += 2;
                    if depth == 0 {
                        break;
                    }
                } else {
                    blank(&mut out, b[i]);
                    i += 1;
                }
            }
        } else if c == b'r'
            && (b.get(i + 1) == Some(&b'"') || b.get(i + 1) == Some(&b'#'))
            && (i == 0 || !(b[i - 1].is_ascii_alphanumeric() || b[i - 1] == b'_'))
        {
            let mut j = i + 1;
            let mut hashes = 0;
            while b.get(j) == Some(&b'#') {
                hashes += 1;
                j += 1;
            }
            if b.get(j) != Some(&b'"') {
                out.push(c);
                i += 1;
                continue;
            }
            out.resize(out.len() + (j + 1 - i), b' ');
            i = j + 1;
            while i < b.len() {
                if b[i] == b'"' && (0..hashes).all(|k| b.get(i + 1 + k) == Some(&b'#')) {
                    out.resize(out.len() + 1 + hashes, b' ');
                    i += 1 + hashes;
                    break;
                }
                blank(&mut out, b[i]);
                i += 1;
            }
        } else if c == b'"' {
            out.push(b' ');
            i += 1;
            while i < b.len() && b[i] != b'"' {
                if b[i] == b'\\' {
                    blank(&mut out, b[i]);
                    i += 1;
                }
                if i < b.len() {
                    blank(&mut out, b[i]);
                    i += 1;
                }
            }
            out.push(b' ');
            i += 1;
        } else if c == b'\'' {
            // A char literal ('x', '\n', '\u{..}') or a lifetime ('a).
            let close = if b.get(i + 1) == Some(&b'\\') {
                (i + 2..b.len().min(i + 12)).find(|&k| b[k] == b'\'')
            } else if b.get(i + 2) == Some(&b'\'') {
                Some(i + 2)
            } else {
                None
            };
            match close {
                Some(k) => {
                    out.resize(out.len() + (k + 1 - i), b' ');
                    i = k + 1;
                }
                None => {
                    out.push(c);
                    i += 1;
                }
            }
        } else {
            out.push(c);
            i += 1;
        }
    }
    String::from_utf8_lossy(&out).into_owned()
}

/// The index of the brace matching the `{` at `open`.
fn matching(code: &[u8], open: usize) -> usize {
    let mut depth = 0;
    for (k, &c) in code.iter().enumerate().skip(open) {
        match c {
            b'{' => depth += 1,
            b'}' => {
                depth -= 1;
                if depth == 0 {
                    return k;
                }
            }
            _ => {}
        }
    }
    code.len() - 1
}

fn line_of(code: &[u8], at: usize) -> usize {
    1 + code[..at].iter().filter(|&&c| c == b'\n').count()
}

/// Byte ranges of `#[cfg(test)] mod … { … }` blocks.
fn test_modules(code: &str) -> Vec<(usize, usize)> {
    let mut out = Vec::new();
    let mut from = 0;
    while let Some(k) = code[from..].find("#[cfg(test)]") {
        let at = from + k;
        let rest = &code[at..];
        if let Some(m) = rest.find("mod ")
            && let Some(o) = rest.find('{')
            && m < o
            && !rest[..o].contains(';')
        {
            let open = at + o;
            out.push((at, matching(code.as_bytes(), open)));
        }
        from = at + 1;
    }
    out
}

/// Functions (name, first line, line count) with a body, outside test modules and not
/// `#[test]` functions.
fn functions(src: &str) -> Vec<(String, usize, usize)> {
    let code = code_only(src);
    let b = code.as_bytes();
    let tests = test_modules(&code);
    let mut out = Vec::new();
    let mut from = 0;
    while let Some(k) = code[from..].find("fn ") {
        let at = from + k;
        from = at + 3;
        if at > 0 && (b[at - 1].is_ascii_alphanumeric() || b[at - 1] == b'_') {
            continue;
        }
        if tests.iter().any(|&(s, e)| at > s && at < e) {
            continue;
        }
        let name: String = code[at + 3..]
            .chars()
            .take_while(|c| c.is_alphanumeric() || *c == '_')
            .collect();
        if name.is_empty() {
            continue;
        }
        // The body: the first `{` before any `;` (a declaration without a body has none).
        let Some(open) = code[at..].find(['{', ';']).map(|o| at + o) else {
            continue;
        };
        if b[open] == b';' {
            continue;
        }
        let before = &code[at.saturating_sub(200)..at];
        if before.trim_end().ends_with("#[test]") {
            continue;
        }
        let close = matching(b, open);
        let first = line_of(b, at);
        out.push((name, first, line_of(b, close) - first + 1));
    }
    out
}

#[test]
fn no_function_over_150_lines() {
    let mut long = Vec::new();
    for dir in [
        "gpu/src",
        "tracer/src",
        "src",
        "graph/src/link",
        "python/src",
        "lang/src",
    ] {
        for f in rust_files(&root().join(dir)) {
            let src = std::fs::read_to_string(&f).unwrap();
            for (name, line, len) in functions(&src) {
                if len > 150 {
                    long.push(format!(
                        "{}:{line}: fn {name} is {len} lines",
                        f.strip_prefix(root()).unwrap().display()
                    ));
                }
            }
        }
    }
    assert!(
        long.is_empty(),
        "split these by what each part does:\n{}",
        long.join("\n")
    );
}

#[test]
fn the_function_counter_counts() {
    let src = "fn a() {\n let s = \"}\";\n let c = '{';\n}\n#[test]\nfn t() {\n}\n\
               #[cfg(test)]\nmod tests {\n fn hidden() {\n }\n}\nfn b(x: u8) -> u8 {\n x\n}\n";
    assert_eq!(
        functions(src),
        vec![("a".to_string(), 1, 4), ("b".to_string(), 13, 3)]
    );
}

#[test]
fn main_only_parses_and_dispatches() {
    let lines = std::fs::read_to_string(root().join("src/main.rs"))
        .unwrap()
        .lines()
        .count();
    assert!(lines < 200, "src/main.rs is {lines} lines");
}

/// The file a `crate::a::b::c` path names: the longest prefix that is a file.
fn resolve(src_root: &Path, base: &Path, segments: &[&str]) -> Option<PathBuf> {
    let mut found = None;
    let mut dir = base.to_path_buf();
    for s in segments {
        let file = dir.join(format!("{s}.rs"));
        let module = dir.join(s).join("mod.rs");
        if file.is_file() {
            found = Some(file);
        } else if module.is_file() {
            found = Some(module);
        } else {
            break;
        }
        dir = dir.join(s);
    }
    let _ = src_root;
    found
}

/// Paths after `prefix` (`crate::`, `super::`) in the code, with `{a, b::c}` groups
/// expanded one level.
fn paths_after<'a>(code: &'a str, prefix: &str) -> Vec<Vec<&'a str>> {
    let mut out = Vec::new();
    let mut from = 0;
    while let Some(k) = code[from..].find(prefix) {
        let at = from + k + prefix.len();
        from = at;
        let before = code[..at - prefix.len()].chars().next_back();
        if before.is_some_and(|c| c.is_alphanumeric() || c == '_') {
            continue;
        }
        let rest = &code[at..];
        let path: String = rest
            .chars()
            .take_while(|c| c.is_alphanumeric() || *c == '_' || *c == ':')
            .collect();
        let segs: Vec<&str> = rest[..path.len()]
            .split("::")
            .filter(|s| !s.is_empty())
            .collect();
        if rest[path.len()..].starts_with('{') {
            let group_end = rest.find('}').unwrap_or(rest.len());
            for item in rest[path.len() + 1..group_end].split(',') {
                let item = item.trim();
                let mut v = segs.clone();
                let head = &rest[path.len() + 1..group_end];
                let off = item.as_ptr() as usize - head.as_ptr() as usize;
                let item_ref = &head[off..off + item.len()];
                v.extend(
                    item_ref
                        .split("::")
                        .map(str::trim)
                        .filter(|s| !s.is_empty()),
                );
                out.push(v);
            }
        } else {
            out.push(segs);
        }
    }
    out
}

/// Import edges between the files of one crate.
fn import_graph(src_root: &Path) -> BTreeMap<PathBuf, BTreeSet<PathBuf>> {
    let mut graph = BTreeMap::new();
    for f in rust_files(src_root) {
        let code = code_only(&std::fs::read_to_string(&f).unwrap());
        let mut to = BTreeSet::new();
        for segs in paths_after(&code, "crate::") {
            if let Some(t) = resolve(src_root, src_root, &segs) {
                to.insert(t);
            }
        }
        // `super::` from `a/b.rs` is `a/mod.rs`'s module; from `a/mod.rs` the crate root's.
        let module_dir = if f.file_name().is_some_and(|n| n == "mod.rs") {
            f.parent().and_then(Path::parent)
        } else {
            f.parent()
        };
        if let Some(parent_dir) = module_dir {
            for segs in paths_after(&code, "super::") {
                if let Some(t) = resolve(src_root, parent_dir, &segs) {
                    to.insert(t);
                }
            }
        }
        to.remove(&f);
        graph.insert(f, to);
    }
    graph
}

/// One cycle of the graph, if any.
fn find_cycle(graph: &BTreeMap<PathBuf, BTreeSet<PathBuf>>) -> Option<Vec<PathBuf>> {
    fn visit(
        n: &PathBuf,
        graph: &BTreeMap<PathBuf, BTreeSet<PathBuf>>,
        state: &mut BTreeMap<PathBuf, u8>,
        stack: &mut Vec<PathBuf>,
    ) -> Option<Vec<PathBuf>> {
        state.insert(n.clone(), 1);
        stack.push(n.clone());
        for m in graph.get(n).into_iter().flatten() {
            match state.get(m).copied().unwrap_or(0) {
                1 => {
                    let i = stack.iter().position(|x| x == m).unwrap();
                    return Some(stack[i..].to_vec());
                }
                0 => {
                    if let Some(c) = visit(m, graph, state, stack) {
                        return Some(c);
                    }
                }
                _ => {}
            }
        }
        stack.pop();
        state.insert(n.clone(), 2);
        None
    }
    let mut state = BTreeMap::new();
    for n in graph.keys() {
        if state.get(n).copied().unwrap_or(0) == 0
            && let Some(c) = visit(n, graph, &mut state, &mut Vec::new())
        {
            return Some(c);
        }
    }
    None
}

#[test]
fn no_import_circle_inside_a_crate() {
    let mut circles = Vec::new();
    for dir in [
        "graph/src",
        "runtime/src",
        "jit/src",
        "gpu/src",
        "tracer/src",
        "src",
        "python/src",
        "lang/src",
    ] {
        let graph = import_graph(&root().join(dir));
        if let Some(c) = find_cycle(&graph) {
            let names: Vec<String> = c
                .iter()
                .map(|p| p.strip_prefix(root()).unwrap().display().to_string())
                .collect();
            circles.push(format!("{} -> {}", names.join(" -> "), names[0]));
        }
    }
    assert!(
        circles.is_empty(),
        "import circles (move what they share into the lower file):\n{}",
        circles.join("\n")
    );
}

#[test]
fn the_circle_finder_finds_circles() {
    let p = |s: &str| PathBuf::from(s);
    let mut g = BTreeMap::new();
    g.insert(p("a.rs"), BTreeSet::from([p("b.rs")]));
    g.insert(p("b.rs"), BTreeSet::from([p("c.rs")]));
    g.insert(p("c.rs"), BTreeSet::from([p("a.rs")]));
    assert_eq!(find_cycle(&g), Some(vec![p("a.rs"), p("b.rs"), p("c.rs")]));
    g.insert(p("c.rs"), BTreeSet::new());
    assert_eq!(find_cycle(&g), None);
}
