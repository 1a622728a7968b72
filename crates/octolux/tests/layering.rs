//! Dependencies point one way: no module circle in the library or the CLI.
//!
//! The rule (docs/architecture.md, "Layers"): within each folder, the modules below it
//! depend on one another without a circle. A reference from module `a` to module `b` counts
//! between the two children of their closest common ancestor that hold `a` and `b`; a module
//! may use what its ancestors declare, and an ancestor may use its descendants, so those
//! references do not count. References are the `crate::`, `super::` and `self::` paths of the
//! source, comments excluded, test modules included.

use std::collections::{BTreeMap, BTreeSet};
use std::path::Path;

/// One source file: its module path (`""` for the crate root, `"gi::lpv"`) and its text.
struct Source {
    module: String,
    file: String,
    text: String,
}

/// An edge between two sibling modules, with the place that makes it.
#[derive(Clone, Debug)]
struct Evidence {
    file: String,
    line: usize,
    path: String,
}

fn read_crate(src: &Path) -> Vec<Source> {
    let mut out = Vec::new();
    let mut stack = vec![src.to_path_buf()];
    while let Some(dir) = stack.pop() {
        for entry in std::fs::read_dir(&dir).expect("readable source folder") {
            let path = entry.expect("directory entry").path();
            if path.is_dir() {
                stack.push(path);
            } else if path.extension().is_some_and(|e| e == "rs") {
                let rel = path.strip_prefix(src).unwrap().with_extension("");
                let mut parts: Vec<String> = rel
                    .components()
                    .map(|c| c.as_os_str().to_string_lossy().into_owned())
                    .collect();
                if matches!(
                    parts.last().map(String::as_str),
                    Some("mod" | "lib" | "main")
                ) {
                    parts.pop();
                }
                out.push(Source {
                    module: parts.join("::"),
                    file: path.display().to_string(),
                    text: std::fs::read_to_string(&path).expect("readable source file"),
                });
            }
        }
    }
    out
}

/// The text with comments blanked (line structure kept) and string literals emptied.
fn strip(text: &str) -> String {
    let b = text.as_bytes();
    let mut out = String::with_capacity(text.len());
    let mut i = 0;
    while i < b.len() {
        if b[i..].starts_with(b"//") {
            while i < b.len() && b[i] != b'\n' {
                i += 1;
            }
        } else if b[i..].starts_with(b"/*") {
            let mut depth = 0;
            while i < b.len() {
                if b[i..].starts_with(b"/*") {
                    depth += 1;
                    i += 2;
                } else if b[i..].starts_with(b"*/") {
                    depth -= 1;
                    i += 2;
                    if depth == 0 {
                        break;
                    }
                } else {
                    if b[i] == b'\n' {
                        out.push('\n');
                    }
                    i += 1;
                }
            }
        } else if b[i] == b'"' {
            // A string literal (raw strings in this code base hold no quotes that matter).
            i += 1;
            while i < b.len() && b[i] != b'"' {
                if b[i] == b'\\' {
                    i += 1;
                } else if b[i] == b'\n' {
                    out.push('\n');
                }
                i += 1;
            }
            i += 1;
            out.push_str("\"\"");
        } else if b[i] == b'\'' && i + 2 < b.len() && (b[i + 2] == b'\'' || b[i + 1] == b'\\') {
            // A character literal such as '"' or '\n' (not a lifetime).
            let end = text[i + 1..].find('\'').map_or(b.len(), |k| i + 2 + k);
            out.push_str("' '");
            i = end;
        } else {
            let ch = text[i..].chars().next().unwrap();
            out.push(ch);
            i += ch.len_utf8();
        }
    }
    out
}

fn is_ident(c: char) -> bool {
    c.is_ascii_alphanumeric() || c == '_'
}

/// Every path that starts with `crate`, `super` or `self` in `text`, with the line it is on;
/// `use` groups (`a::{b, c::d}`) are expanded.
fn paths(text: &str) -> Vec<(usize, String)> {
    let mut out = Vec::new();
    let chars: Vec<char> = text.chars().collect();
    let mut line = 1;
    let mut i = 0;
    while i < chars.len() {
        if chars[i] == '\n' {
            line += 1;
        }
        let starts = ["crate::", "super::", "self::"]
            .iter()
            .find(|p| chars[i..].iter().take(p.len()).copied().eq(p.chars()));
        if let Some(start) = starts {
            if i == 0 || !(is_ident(chars[i - 1]) || chars[i - 1] == ':') {
                let (mut found, end) = parse_tree(&chars, i, start.len() - 2);
                for p in found.drain(..) {
                    out.push((line, p));
                }
                i = end.max(i + 1);
                continue;
            }
        }
        i += 1;
    }
    out
}

/// Parses a path (with `use` groups) at `i`; returns the expanded paths and where it ends.
fn parse_tree(chars: &[char], mut i: usize, _: usize) -> (Vec<String>, usize) {
    let mut prefix = String::new();
    loop {
        let start = i;
        while i < chars.len() && is_ident(chars[i]) {
            i += 1;
        }
        prefix.extend(&chars[start..i]);
        let mut j = i;
        while j < chars.len() && chars[j].is_whitespace() {
            j += 1;
        }
        if chars[j..].starts_with(&[':', ':']) {
            j += 2;
            while j < chars.len() && chars[j].is_whitespace() {
                j += 1;
            }
            if j < chars.len() && chars[j] == '{' {
                // A group: split at top-level commas.
                let mut out = Vec::new();
                j += 1;
                loop {
                    while j < chars.len() && (chars[j].is_whitespace() || chars[j] == ',') {
                        j += 1;
                    }
                    if j >= chars.len() || chars[j] == '}' {
                        return (out, j + 1);
                    }
                    let (inner, end) = parse_tree(chars, j, 0);
                    for p in inner {
                        if p == "self" {
                            out.push(prefix.clone());
                        } else {
                            out.push(format!("{prefix}::{p}"));
                        }
                    }
                    if end <= j {
                        return (out, j + 1);
                    }
                    j = end;
                    // Skip an `as name`.
                    while j < chars.len() && chars[j] != ',' && chars[j] != '}' {
                        j += 1;
                    }
                }
            }
            prefix.push_str("::");
            i = j;
        } else {
            return (vec![prefix], i);
        }
    }
}

/// The module a path names: the longest prefix that is a module of the crate.
fn resolve(modules: &BTreeSet<String>, from: &str, path: &str) -> Option<String> {
    let mut segs: Vec<&str> = Vec::new();
    let mut rest = path.split("::").peekable();
    let here: Vec<&str> = from.split("::").filter(|s| !s.is_empty()).collect();
    match rest.peek().copied() {
        Some("crate") => {
            rest.next();
        }
        Some("self") => {
            rest.next();
            segs.extend(&here);
        }
        Some("super") => {
            let mut base = here.clone();
            while rest.peek() == Some(&"super") {
                rest.next();
                base.pop()?;
            }
            segs.extend(base);
        }
        _ => return None,
    }
    segs.extend(rest);
    (0..=segs.len())
        .rev()
        .map(|n| segs[..n].join("::"))
        .find(|m| modules.contains(m))
}

fn split(m: &str) -> Vec<&str> {
    m.split("::").filter(|s| !s.is_empty()).collect()
}

/// Sibling edges: parent module -> (child a -> child b -> evidence).
type SiblingGraph = BTreeMap<String, BTreeMap<String, BTreeMap<String, Evidence>>>;

fn sibling_graph(sources: &[Source]) -> SiblingGraph {
    let modules: BTreeSet<String> = sources.iter().map(|s| s.module.clone()).collect();
    let mut graph = SiblingGraph::new();
    for source in sources {
        for (line, path) in paths(&strip(&source.text)) {
            let Some(target) = resolve(&modules, &source.module, &path) else {
                continue;
            };
            let (a, b) = (split(&source.module), split(&target));
            let common = a.iter().zip(&b).take_while(|(x, y)| x == y).count();
            if common == a.len() || common == b.len() {
                continue; // one is an ancestor of the other
            }
            let parent = a[..common].join("::");
            graph
                .entry(parent)
                .or_default()
                .entry(a[common].to_string())
                .or_default()
                .entry(b[common].to_string())
                .or_insert(Evidence {
                    file: source.file.clone(),
                    line,
                    path,
                });
        }
    }
    graph
}

/// Every circle among siblings, each as a readable list of its edges and their evidence.
fn circles(graph: &SiblingGraph) -> Vec<String> {
    let mut found = Vec::new();
    for (parent, edges) in graph {
        // Strongly connected components (Tarjan), reported when larger than one module.
        let nodes: BTreeSet<&String> = edges
            .iter()
            .flat_map(|(a, bs)| std::iter::once(a).chain(bs.keys()))
            .collect();
        let mut index = BTreeMap::new();
        let mut low = BTreeMap::new();
        let mut stack: Vec<&String> = Vec::new();
        let mut on_stack = BTreeSet::new();
        let mut next = 0;
        #[allow(clippy::too_many_arguments)]
        fn visit<'a>(
            v: &'a String,
            edges: &'a BTreeMap<String, BTreeMap<String, Evidence>>,
            index: &mut BTreeMap<&'a String, usize>,
            low: &mut BTreeMap<&'a String, usize>,
            stack: &mut Vec<&'a String>,
            on_stack: &mut BTreeSet<&'a String>,
            next: &mut usize,
            out: &mut Vec<Vec<&'a String>>,
        ) {
            index.insert(v, *next);
            low.insert(v, *next);
            *next += 1;
            stack.push(v);
            on_stack.insert(v);
            for w in edges.get(v).into_iter().flat_map(|m| m.keys()) {
                if !index.contains_key(w) {
                    visit(w, edges, index, low, stack, on_stack, next, out);
                    let lw = low[w];
                    let lv = low.get_mut(v).unwrap();
                    *lv = (*lv).min(lw);
                } else if on_stack.contains(w) {
                    let iw = index[w];
                    let lv = low.get_mut(v).unwrap();
                    *lv = (*lv).min(iw);
                }
            }
            if low[v] == index[v] {
                let mut component = Vec::new();
                while let Some(w) = stack.pop() {
                    on_stack.remove(w);
                    component.push(w);
                    if w == v {
                        break;
                    }
                }
                if component.len() > 1 {
                    out.push(component);
                }
            }
        }
        let mut components = Vec::new();
        for v in nodes {
            if !index.contains_key(v) {
                visit(
                    v,
                    edges,
                    &mut index,
                    &mut low,
                    &mut stack,
                    &mut on_stack,
                    &mut next,
                    &mut components,
                );
            }
        }
        for component in components {
            let members: BTreeSet<&String> = component.iter().copied().collect();
            let mut text = format!(
                "circle in `{}` between {:?}:",
                if parent.is_empty() { "crate" } else { parent },
                members
            );
            for a in &members {
                for (b, e) in &edges[*a] {
                    if members.contains(b) {
                        text +=
                            &format!("\n    {a} -> {b}: {} line {} ({})", e.file, e.line, e.path);
                    }
                }
            }
            found.push(text);
        }
    }
    found
}

fn check_crate(src: &Path) {
    let found = circles(&sibling_graph(&read_crate(src)));
    assert!(
        found.is_empty(),
        "module circles in {}:\n{}",
        src.display(),
        found.join("\n")
    );
}

#[test]
fn library_has_no_module_circle() {
    check_crate(&Path::new(env!("CARGO_MANIFEST_DIR")).join("src"));
}

#[test]
fn command_line_tool_has_no_module_circle() {
    check_crate(&Path::new(env!("CARGO_MANIFEST_DIR")).join("../octolux-cli/src"));
}

fn synthetic(files: &[(&str, &str)]) -> Vec<String> {
    let sources: Vec<Source> = files
        .iter()
        .map(|(module, text)| Source {
            module: module.to_string(),
            file: format!("{module}.rs"),
            text: text.to_string(),
        })
        .collect();
    circles(&sibling_graph(&sources))
}

#[test]
fn a_back_import_is_a_circle() {
    let layered = [
        ("", "pub mod gpu; pub mod frame; pub mod gi;"),
        ("gpu", "pub fn dispatch() {}"),
        ("frame", "use crate::gpu::dispatch;"),
        ("gi", "pub mod lpv; use crate::frame::{self, GBuffer};"),
        (
            "gi::lpv",
            "use super::GiFrame; use crate::{gpu::dispatch, frame::rsm::Rsm};",
        ),
    ];
    assert!(synthetic(&layered).is_empty(), "{:?}", synthetic(&layered));

    // The frame resources reaching back up into a technique, through a nested `use` group.
    let mut back = layered.to_vec();
    back[2] = ("frame", "use crate::{gpu::dispatch, gi::lpv::Helper};");
    let found = synthetic(&back);
    assert_eq!(found.len(), 1, "{found:?}");
    assert!(found[0].contains("frame -> gi") && found[0].contains("gi -> frame"));

    // Through `super::` between siblings one level down.
    let siblings = [
        ("gi", "mod a; mod b;"),
        ("gi::a", "fn f() { super::b::g() }"),
        ("gi::b", "use super::a::f;"),
    ];
    assert_eq!(synthetic(&siblings).len(), 1);

    // Comments, strings and ancestors do not count.
    let harmless = [
        ("gi", "mod a; mod b; use a::X;"),
        (
            "gi::a",
            "// crate::gi::b::g()\nconst S: &str = \"crate::gi::b\"; use super::Y;",
        ),
        ("gi::b", "use super::a::f;"),
    ];
    assert!(
        synthetic(&harmless).is_empty(),
        "{:?}",
        synthetic(&harmless)
    );
}
