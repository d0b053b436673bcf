//! No import loop between the files of a crate. Every `.rs` file under the
//! `src/` of the workspace's crates is read, its paths into its own crate (`use crate::…`,
//! `super::…`, `self::…`, grouped `use` trees, and paths written inline such as
//! `crate::program::n_word(…)`) are resolved to the file that defines the module they name, and
//! the resulting file graph must have no cycle (a file that imports another which, directly or
//! through others, imports it back). Doc comments and other comments do not count.
//!
//! Known cycles may be listed in [`ALLOWED`] edge by edge (none are left); an edge listed there
//! that no longer exists fails the test too, so the list only shrinks.
//!
//! Between the core's top-level modules the arrows run one way: [`MACHINE_LAYERS`] orders them
//! bottom up, and no file may import a module of a layer above its own.

use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};

/// The crates checked (paths from the workspace root).
const CRATES: &[&str] = &[
    "machine",
    "shared-proto",
    "emulator",
    "host-sender",
    "settings-store",
    "tests",
];

/// Edges (importing file → imported file, from the workspace root) that close a known cycle and
/// are left for now, each with the issue that names it. Removing such an edge from the code means
/// removing it here.
const ALLOWED: &[(&str, &str, &str)] = &[];

/// The core's (`machine/src/`) top-level modules in layers, the bottom layer first. A file may
/// import its own layer and the layers below, never one above: the device drives the board, the
/// board drives the interpreter and the motion, and nothing below looks back up. Every top-level
/// module is in exactly one layer (a new module must be placed here).
///
/// Each layer is one module: the step interrupt and the kernel it drives know nothing of
/// G-code; the interpreter knows no setup; the setup (`setup.rs`) names the interpreter's
/// dialects and tools and the step timing; motion reads the setup (`MotionConfig::from_setup`);
/// the cross-target vectors run the interpreter and the motion core.
const MACHINE_LAYERS: &[&[&str]] = &[
    &["arith", "units"],
    &["canon"],
    &["step"],
    &["gcode"],
    &["setup"],
    &["motion"],
    &["vectors"],
    &["board"],
    &["device"],
];

/// The source with comments, string and character literals blanked out (newlines kept).
fn strip(src: &str) -> String {
    let b: Vec<char> = src.chars().collect();
    let mut out = String::with_capacity(src.len());
    let mut i = 0;
    while i < b.len() {
        let c = b[i];
        let next = b.get(i + 1).copied();
        if c == '/' && next == Some('/') {
            while i < b.len() && b[i] != '\n' {
                i += 1;
            }
        } else if c == '/' && next == Some('*') {
            let mut depth = 0;
            while i < b.len() {
                if b[i] == '/' && b.get(i + 1) == Some(&'*') {
                    depth += 1;
                    i += 2;
                } else if b[i] == '*' && b.get(i + 1) == Some(&'/') {
                    depth -= 1;
                    i += 2;
                    if depth == 0 {
                        break;
                    }
                } else {
                    if b[i] == '\n' {
                        out.push('\n');
                    }
                    i += 1;
                }
            }
        } else if c == 'r' && (next == Some('"') || next == Some('#')) && !ident_before(&b, i) {
            // Raw string r"…", r#"…"#.
            let mut j = i + 1;
            let mut hashes = 0;
            while b.get(j) == Some(&'#') {
                hashes += 1;
                j += 1;
            }
            if b.get(j) != Some(&'"') {
                out.push(c);
                i += 1;
                continue;
            }
            j += 1;
            loop {
                if j >= b.len() {
                    break;
                }
                if b[j] == '"' && (0..hashes).all(|k| b.get(j + 1 + k) == Some(&'#')) {
                    j += 1 + hashes;
                    break;
                }
                if b[j] == '\n' {
                    out.push('\n');
                }
                j += 1;
            }
            out.push_str("\"\"");
            i = j;
        } else if c == '"' {
            i += 1;
            while i < b.len() && b[i] != '"' {
                if b[i] == '\\' {
                    i += 1;
                }
                if i < b.len() && b[i] == '\n' {
                    out.push('\n');
                }
                i += 1;
            }
            i += 1;
            out.push_str("\"\"");
        } else if c == '\'' {
            // A character literal ('a', '\n', '\u{1b}') or a lifetime ('a).
            let close = if next == Some('\\') {
                (i + 2..b.len().min(i + 12)).find(|&k| b[k] == '\'')
            } else if b.get(i + 2) == Some(&'\'') {
                Some(i + 2)
            } else {
                None
            };
            match close {
                Some(k) => {
                    out.push_str("' '");
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
    out
}

fn ident_before(b: &[char], i: usize) -> bool {
    i > 0 && (b[i - 1].is_alphanumeric() || b[i - 1] == '_')
}

/// The module path of a source file (`src/preview/svg.rs` → `["preview", "svg"]`; `lib.rs`,
/// `main.rs` and `mod.rs` name their directory's module).
fn module_of(src: &Path, file: &Path) -> Vec<String> {
    let rel = file.strip_prefix(src).unwrap();
    let mut parts: Vec<String> = rel
        .iter()
        .map(|p| p.to_string_lossy().into_owned())
        .collect();
    let last = parts.pop().unwrap();
    let stem = last.trim_end_matches(".rs");
    if !(matches!(stem, "mod") || (parts.is_empty() && matches!(stem, "lib" | "main"))) {
        parts.push(stem.to_owned());
    }
    parts
}

/// The file that defines the longest prefix of module path `path` in `modules` (module path →
/// file); the crate root when none does.
fn file_of(modules: &BTreeMap<Vec<String>, PathBuf>, path: &[String]) -> Option<PathBuf> {
    (0..=path.len())
        .rev()
        .find_map(|n| modules.get(&path[..n]).cloned())
}

/// Expands a `use` tree (`crate::a::{b, c::{d, self}}`) into its paths.
fn expand(tree: &str) -> Vec<String> {
    // `x as y`: the renaming is dropped.
    let mut kept = String::new();
    let mut tokens = tree.split_whitespace();
    while let Some(t) = tokens.next() {
        if t == "as" {
            if let Some(n) = tokens.next() {
                kept.push_str(n.trim_start_matches(|c: char| c.is_alphanumeric() || c == '_'));
            }
        } else {
            kept.push_str(t);
        }
    }
    let tree = kept;
    let Some(open) = tree.find('{') else {
        return vec![tree];
    };
    let prefix = &tree[..open];
    let inner = &tree[open + 1..tree.rfind('}').unwrap_or(tree.len())];
    let mut parts = Vec::new();
    let mut depth = 0;
    let mut start = 0;
    for (i, c) in inner.char_indices() {
        match c {
            '{' => depth += 1,
            '}' => depth -= 1,
            ',' if depth == 0 => {
                parts.push(&inner[start..i]);
                start = i + 1;
            }
            _ => {}
        }
    }
    parts.push(&inner[start..]);
    parts
        .into_iter()
        .filter(|p| !p.is_empty())
        .flat_map(|p| {
            if p == "self" {
                vec![prefix.trim_end_matches("::").to_owned()]
            } else {
                expand(&format!("{prefix}{p}"))
            }
        })
        .collect()
}

/// The paths into the own crate a (stripped) source uses, each with the module it is written
/// in (inline `mod x { … }` blocks count for `super::`).
fn crate_paths(text: &str, file_module: &[String]) -> Vec<Vec<String>> {
    let chars: Vec<char> = text.chars().collect();
    let mut found = Vec::new();
    // Inline modules open at these brace depths.
    let mut inline: Vec<(String, usize)> = Vec::new();
    let mut depth = 0usize;
    let mut i = 0;
    let word_at = |i: usize| -> String {
        chars[i..]
            .iter()
            .take_while(|c| c.is_alphanumeric() || **c == '_')
            .collect()
    };
    while i < chars.len() {
        let c = chars[i];
        if c == '{' {
            depth += 1;
            i += 1;
            continue;
        }
        if c == '}' {
            depth = depth.saturating_sub(1);
            while inline.last().is_some_and(|(_, d)| *d > depth) {
                inline.pop();
            }
            i += 1;
            continue;
        }
        if !(c.is_alphabetic() || c == '_') || ident_before(&chars, i) {
            i += 1;
            continue;
        }
        let word = word_at(i);
        let here: Vec<String> = file_module
            .iter()
            .cloned()
            .chain(inline.iter().map(|(m, _)| m.clone()))
            .collect();
        if word == "mod" {
            let rest: String = chars[i + 3..].iter().take(200).collect();
            let rest = rest.trim_start();
            let name: String = rest
                .chars()
                .take_while(|c| c.is_alphanumeric() || *c == '_')
                .collect();
            let after = rest[name.len()..].trim_start();
            if !name.is_empty() && after.starts_with('{') {
                inline.push((name, depth + 1));
            }
            i += 3;
            continue;
        }
        if word == "use" {
            let end = (i..chars.len())
                .find(|&k| chars[k] == ';')
                .unwrap_or(chars.len());
            let tree: String = chars[i + 3..end].iter().collect();
            for p in expand(&tree) {
                if let Some(abs) = absolute(&p, &here) {
                    found.push(abs);
                }
            }
            i = end;
            continue;
        }
        if matches!(word.as_str(), "crate" | "super" | "self") {
            let path: String = chars[i..]
                .iter()
                .take_while(|c| c.is_alphanumeric() || **c == '_' || **c == ':')
                .collect();
            if path.contains("::") {
                if let Some(abs) = absolute(&path, &here) {
                    found.push(abs);
                }
            }
            i += path.len().max(1);
            continue;
        }
        i += word.len();
    }
    found
}

/// `crate::a::b`, `super::c`, `self::d` as a module path from the crate root; `None` for paths
/// into other crates.
fn absolute(path: &str, here: &[String]) -> Option<Vec<String>> {
    let mut segs: Vec<&str> = path.split("::").filter(|s| !s.is_empty()).collect();
    if segs.first() == Some(&"pub") || segs.first() == Some(&"pub(crate)") {
        segs.remove(0);
    }
    let mut out: Vec<String>;
    match segs.first().copied() {
        Some("crate") => {
            out = Vec::new();
            segs.remove(0);
        }
        Some("super") | Some("self") => {
            out = here.to_vec();
            while let Some(&s) = segs.first() {
                match s {
                    "super" => {
                        out.pop();
                    }
                    "self" => {}
                    _ => break,
                }
                segs.remove(0);
            }
        }
        _ => return None,
    }
    out.extend(segs.iter().filter(|s| **s != "*").map(|s| s.to_string()));
    Some(out)
}

fn rs_files(dir: &Path, into: &mut Vec<PathBuf>) {
    let Ok(entries) = std::fs::read_dir(dir) else {
        return;
    };
    for e in entries.flatten() {
        let p = e.path();
        if p.is_dir() {
            rs_files(&p, into);
        } else if p.extension().is_some_and(|x| x == "rs") {
            into.push(p);
        }
    }
}

/// The import graph of one crate's `src/`: file → files it imports (paths relative to `root`).
fn graph(root: &Path, krate: &str) -> BTreeMap<String, BTreeSet<String>> {
    let src = root.join(krate).join("src");
    let mut files = Vec::new();
    rs_files(&src, &mut files);
    files.sort();
    // Binaries under src/bin are crate roots of their own: checked alone.
    let rel = |p: &Path| p.strip_prefix(root).unwrap().to_string_lossy().into_owned();
    let mut modules: BTreeMap<Vec<String>, PathBuf> = BTreeMap::new();
    for f in &files {
        let m = module_of(&src, f);
        // main.rs and lib.rs are both roots; lib.rs is the one `crate::` names in the library.
        if f.file_name().unwrap() == "main.rs" && src.join("lib.rs").exists() {
            continue;
        }
        modules.insert(m, f.clone());
    }
    let mut g: BTreeMap<String, BTreeSet<String>> = BTreeMap::new();
    for f in &files {
        if f.file_name().unwrap() == "main.rs" && src.join("lib.rs").exists() {
            // The binary's root uses the library by its crate name, not `crate::`.
            continue;
        }
        let text = strip(&std::fs::read_to_string(f).unwrap());
        let me = rel(f);
        let module = module_of(&src, f);
        let entry = g.entry(me.clone()).or_default();
        for p in crate_paths(&text, &module) {
            if let Some(to) = file_of(&modules, &p) {
                let to = rel(&to);
                // A file naming an item of a module it declares itself (`mod x; … x::y`) or
                // its own items is no import of another file's; the crate root declaring its
                // modules is not either.
                if to != me {
                    entry.insert(to);
                }
            }
        }
    }
    g
}

/// The strongly connected components with more than one file (Tarjan).
fn cycles(g: &BTreeMap<String, BTreeSet<String>>) -> Vec<Vec<String>> {
    struct T<'a> {
        g: &'a BTreeMap<String, BTreeSet<String>>,
        index: BTreeMap<&'a str, usize>,
        low: BTreeMap<&'a str, usize>,
        stack: Vec<&'a str>,
        on: BTreeSet<&'a str>,
        next: usize,
        out: Vec<Vec<String>>,
    }
    fn visit<'a>(t: &mut T<'a>, v: &'a str) {
        t.index.insert(v, t.next);
        t.low.insert(v, t.next);
        t.next += 1;
        t.stack.push(v);
        t.on.insert(v);
        let g = t.g;
        for w in g.get(v).into_iter().flatten() {
            let w = w.as_str();
            if !t.index.contains_key(w) {
                visit(t, w);
                let lw = t.low[w];
                let lv = t.low[v];
                t.low.insert(v, lv.min(lw));
            } else if t.on.contains(w) {
                let iw = t.index[w];
                let lv = t.low[v];
                t.low.insert(v, lv.min(iw));
            }
        }
        if t.low[v] == t.index[v] {
            let mut comp = Vec::new();
            loop {
                let w = t.stack.pop().unwrap();
                t.on.remove(w);
                comp.push(w.to_owned());
                if w == v {
                    break;
                }
            }
            if comp.len() > 1 {
                comp.sort();
                t.out.push(comp);
            }
        }
    }
    let mut t = T {
        g,
        index: BTreeMap::new(),
        low: BTreeMap::new(),
        stack: Vec::new(),
        on: BTreeSet::new(),
        next: 0,
        out: Vec::new(),
    };
    for v in g.keys() {
        if !t.index.contains_key(v.as_str()) {
            visit(&mut t, v);
        }
    }
    t.out
}

fn workspace_root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .parent()
        .unwrap()
        .to_owned()
}

#[test]
fn no_file_of_a_crate_imports_itself_back_through_others() {
    let root = workspace_root();
    let mut report = String::new();
    let mut allowed_unused: BTreeSet<(&str, &str)> =
        ALLOWED.iter().map(|(a, b, _)| (*a, *b)).collect();
    for krate in CRATES {
        let mut g = graph(&root, krate);
        for (from, to, _) in ALLOWED {
            if let Some(e) = g.get_mut(*from) {
                if e.remove(*to) {
                    allowed_unused.remove(&(*from, *to));
                }
            }
        }
        for comp in cycles(&g) {
            report.push_str(&format!("import cycle in {krate}:\n"));
            for f in &comp {
                let into: Vec<&String> = g[f].iter().filter(|t| comp.contains(t)).collect();
                report.push_str(&format!("    {f} -> {into:?}\n"));
            }
        }
    }
    assert!(
        allowed_unused.is_empty(),
        "allowed edges that no longer exist (remove them from ALLOWED): {allowed_unused:?}"
    );
    assert!(report.is_empty(), "{report}");
}

/// The top-level module of a crate's file (`machine/src/board/jog/mod.rs` → `board`); `None`
/// for the crate root.
fn top_module(root: &Path, krate: &str, file: &str) -> Option<String> {
    let src = root.join(krate).join("src");
    module_of(&src, &root.join(file)).into_iter().next()
}

/// Imports from a lower layer of [`MACHINE_LAYERS`] into a higher one, and top-level modules in
/// no layer (or in two), in `g` (the machine crate's file graph), one line each.
fn layer_violations(root: &Path, g: &BTreeMap<String, BTreeSet<String>>) -> Vec<String> {
    let mut out = Vec::new();
    let mut layer_of: BTreeMap<&str, usize> = BTreeMap::new();
    for (i, layer) in MACHINE_LAYERS.iter().enumerate() {
        for m in *layer {
            if layer_of.insert(m, i).is_some() {
                out.push(format!("{m} is in two layers"));
            }
        }
    }
    let mut unplaced = BTreeSet::new();
    for (from, tos) in g {
        let Some(a) = top_module(root, "machine", from) else {
            continue;
        };
        let Some(&la) = layer_of.get(a.as_str()) else {
            unplaced.insert(a);
            continue;
        };
        for to in tos {
            let Some(b) = top_module(root, "machine", to) else {
                continue;
            };
            match layer_of.get(b.as_str()) {
                Some(&lb) if lb > la => out.push(format!(
                    "{from} ({a}, layer {la}) imports {to} ({b}, layer {lb})"
                )),
                Some(_) => {}
                None => {
                    unplaced.insert(b);
                }
            }
        }
    }
    for m in unplaced {
        out.push(format!(
            "top-level module {m} is in no layer of MACHINE_LAYERS"
        ));
    }
    out
}

#[test]
fn no_folder_of_the_core_imports_a_folder_above_it() {
    let root = workspace_root();
    let g = graph(&root, "machine");
    let violations = layer_violations(&root, &g);
    assert!(
        violations.is_empty(),
        "imports against the core's layering (MACHINE_LAYERS, bottom first: {MACHINE_LAYERS:?}):\n    {}",
        violations.join("\n    ")
    );
}

#[test]
fn the_layer_check_sees_an_import_from_below() {
    let root = workspace_root();
    let mut g = graph(&root, "machine");
    assert!(layer_violations(&root, &g).is_empty());
    // The board importing the main loop would be an arrow back up.
    g.entry("machine/src/board/torch.rs".to_owned())
        .or_default()
        .insert("machine/src/device/main_loop.rs".to_owned());
    assert_eq!(
        layer_violations(&root, &g),
        ["machine/src/board/torch.rs (board, layer 7) imports machine/src/device/main_loop.rs (device, layer 8)"]
    );
    // The step interrupt reaching into segment preparation would be one inside the old middle
    // layer (step, motion and setup were peers before the kernel moved to step/).
    let mut g = graph(&root, "machine");
    g.entry("machine/src/step/isr.rs".to_owned())
        .or_default()
        .insert("machine/src/motion/prep.rs".to_owned());
    assert_eq!(
        layer_violations(&root, &g),
        ["machine/src/step/isr.rs (step, layer 2) imports machine/src/motion/prep.rs (motion, layer 5)"]
    );
}

#[test]
fn the_checker_sees_use_trees_inline_paths_and_inline_modules() {
    let text = strip(
        "use crate::a::{b, c::{self, d as e}};\n// use crate::z;\nfn f() { crate::g::h(\"crate::y\"); }\nmod tests { use super::k; use super::*; }\n",
    );
    let paths = crate_paths(&text, &["m".to_owned()]);
    let shown: Vec<String> = paths.iter().map(|p| p.join("::")).collect();
    assert_eq!(shown, ["a::b", "a::c", "a::c::d", "g::h", "m::k", "m"]);
}
