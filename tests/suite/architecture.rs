//! The house's shape, checked from the source text: no import cycle between
//! source files or between top-level modules, and no module importing one
//! above it in the layer order that docs/architecture.md states (its
//! ```` ```layers ```` block, top to bottom). `src/lib.rs`'s module docs and
//! README.md's "Layout" must state the same order, in the one-line form
//! [`one_line`] gives.
//!
//! An import is a path that starts with `crate::`, `super::`, `self::` (or
//! `swarmshot::` in the binary) in code, `use` or not, outside comments,
//! string literals and `#[cfg(test)]` items; it points at the deepest module
//! of the path that is a file (or an inline module in one). Edges between a
//! module's file and the files of its own ancestors are not counted, either
//! way: a parent declares its children, and a folder's `mod.rs` is its face
//! (re-exports) and the home of the types its files share, so Rust makes
//! that pair mutual by design. Every other edge is counted: between
//! siblings, cousins and top-level modules. The binary (`src/main.rs`,
//! `src/cli/`) is the top-level module `cli`.

use std::collections::{BTreeMap, BTreeSet};
use std::fs;
use std::path::{Path, PathBuf};

const LIB: &str = "lib";
const BIN: &str = "bin";

/// A module: its crate and its path of names from the crate root.
type ModPath = (&'static str, Vec<String>);

/// One import: the file it is in, its line, the path as written, the file it reaches.
#[derive(Clone, Debug)]
struct Import {
    from: PathBuf,
    line: usize,
    path: String,
    to: PathBuf,
}

// ---------------------------------------------------------------- lexing

/// The source with comments, string and char literals turned into spaces
/// (new lines kept, so line numbers hold).
pub(super) fn strip(src: &str) -> String {
    let c: Vec<char> = src.chars().collect();
    let mut out = String::with_capacity(src.len());
    let mut i = 0;
    let blank = |out: &mut String, ch: char| out.push(if ch == '\n' { '\n' } else { ' ' });
    while i < c.len() {
        let at = |k: usize| c.get(i + k).copied().unwrap_or('\0');
        if at(0) == '/' && at(1) == '/' {
            while i < c.len() && c[i] != '\n' {
                i += 1;
                out.push(' ');
            }
        } else if at(0) == '/' && at(1) == '*' {
            let mut depth = 0;
            while i < c.len() {
                if c[i] == '/' && c.get(i + 1) == Some(&'*') {
                    depth += 1;
                    out.push_str("  ");
                    i += 2;
                } else if c[i] == '*' && c.get(i + 1) == Some(&'/') {
                    depth -= 1;
                    out.push_str("  ");
                    i += 2;
                    if depth == 0 {
                        break;
                    }
                } else {
                    blank(&mut out, c[i]);
                    i += 1;
                }
            }
        } else if (at(0) == 'r' || (at(0) == 'b' && at(1) == 'r'))
            && !ident_char(if i == 0 { ' ' } else { c[i - 1] })
            && {
                let s = if at(0) == 'b' { 2 } else { 1 };
                let mut k = s;
                while at(k) == '#' {
                    k += 1;
                }
                at(k) == '"'
            }
        {
            // A raw string: r#"…"#, as many hashes closing as opening.
            let start = if at(0) == 'b' { 2 } else { 1 };
            let mut hashes = 0;
            while at(start + hashes) == '#' {
                hashes += 1;
            }
            for _ in 0..start + hashes + 1 {
                out.push(' ');
            }
            i += start + hashes + 1;
            while i < c.len() {
                if c[i] == '"' && (1..=hashes).all(|h| c.get(i + h) == Some(&'#')) {
                    for _ in 0..=hashes {
                        out.push(' ');
                    }
                    i += hashes + 1;
                    break;
                }
                blank(&mut out, c[i]);
                i += 1;
            }
        } else if at(0) == '"' {
            out.push(' ');
            i += 1;
            while i < c.len() && c[i] != '"' {
                if c[i] == '\\' {
                    out.push(' ');
                    i += 1;
                }
                if i < c.len() {
                    blank(&mut out, c[i]);
                    i += 1;
                }
            }
            out.push(' ');
            i += 1;
        } else if at(0) == '\'' && (at(1) == '\\' || at(2) == '\'') {
            // A char literal ('x', '\n', '\u{1b}'); a lifetime ('a) has no closing quote.
            let escaped = at(1) == '\\';
            out.push(' ');
            i += 1;
            if escaped {
                out.push_str("  ");
                i += 2;
            }
            while i < c.len() && c[i] != '\'' {
                out.push(' ');
                i += 1;
            }
            out.push(' ');
            i += 1;
        } else {
            out.push(c[i]);
            i += 1;
        }
    }
    out
}

fn ident_char(ch: char) -> bool {
    ch.is_alphanumeric() || ch == '_'
}

/// Identifiers, `::` and single punctuation characters, with their lines.
fn tokens(code: &str) -> Vec<(String, usize)> {
    let c: Vec<char> = code.chars().collect();
    let (mut out, mut line, mut i) = (Vec::new(), 1, 0);
    while i < c.len() {
        let ch = c[i];
        if ch == '\n' {
            line += 1;
            i += 1;
        } else if ch.is_whitespace() {
            i += 1;
        } else if ident_char(ch) {
            let s = i;
            while i < c.len() && ident_char(c[i]) {
                i += 1;
            }
            out.push((c[s..i].iter().collect(), line));
        } else if ch == ':' && c.get(i + 1) == Some(&':') {
            out.push(("::".into(), line));
            i += 2;
        } else {
            out.push((ch.to_string(), line));
            i += 1;
        }
    }
    out
}

// ---------------------------------------------------------------- parsing

/// What a file declares and uses: child modules declared `mod x;`, inline
/// modules, and every path from `crate`, `super`, `self` or `swarmshot`.
#[derive(Default, Debug)]
struct FileItems {
    /// `mod x;`, as the inline-module path inside the file, then the name.
    children: Vec<(Vec<String>, String)>,
    /// Inline modules (`mod x { … }`), as their path inside the file.
    inline: Vec<Vec<String>>,
    /// (inline-module path inside the file, line, segments as written).
    paths: Vec<(Vec<String>, usize, Vec<String>)>,
}

fn parse(code: &str) -> FileItems {
    let t = tokens(code);
    let mut items = FileItems::default();
    // Inline modules open: (name, brace depth at which it closes).
    let mut inline: Vec<(String, usize)> = Vec::new();
    let (mut depth, mut i) = (0usize, 0);
    let word = |k: usize| t.get(k).map(|x| x.0.as_str()).unwrap_or("");
    while i < t.len() {
        match word(i) {
            "#" if word(i + 1) == "[" && word(i + 2) == "cfg" && is_cfg_test(&t, i + 3) => {
                i = skip_item(&t, i);
                continue;
            }
            "{" => depth += 1,
            "}" => {
                depth = depth.saturating_sub(1);
                if inline.last().is_some_and(|m| m.1 == depth) {
                    inline.pop();
                }
            }
            "mod" if t.get(i + 1).is_some_and(|x| x.0.chars().all(ident_char)) => {
                let here: Vec<String> = inline.iter().map(|m| m.0.clone()).collect();
                let name = word(i + 1).to_string();
                if word(i + 2) == ";" {
                    items.children.push((here, name));
                } else if word(i + 2) == "{" {
                    let mut path = here;
                    path.push(name.clone());
                    items.inline.push(path);
                    inline.push((name, depth));
                    depth += 1;
                    i += 3;
                    continue;
                }
            }
            w @ ("crate" | "super" | "self" | "swarmshot")
                if word(i + 1) == "::" && (i == 0 || word(i - 1) != "::") =>
            {
                let here: Vec<String> = inline.iter().map(|m| m.0.clone()).collect();
                let line = t[i].1;
                let mut prefix = vec![w.to_string()];
                let mut k = i + 1;
                while word(k) == "::"
                    && word(k + 1).chars().all(ident_char)
                    && !word(k + 1).is_empty()
                {
                    prefix.push(word(k + 1).to_string());
                    k += 2;
                }
                let mut found = Vec::new();
                if word(k) == "::" && word(k + 1) == "{" {
                    k = use_group(&t, k + 2, &prefix, &mut found);
                } else {
                    found.push(prefix);
                }
                for p in found {
                    items.paths.push((here.clone(), line, p));
                }
                i = k;
                continue;
            }
            _ => {}
        }
        i += 1;
    }
    items
}

/// Whether the tokens from `k` (after `#[cfg`) are `(test)]`.
fn is_cfg_test(t: &[(String, usize)], k: usize) -> bool {
    let w = |j: usize| t.get(k + j).map(|x| x.0.as_str()).unwrap_or("");
    w(0) == "(" && w(1) == "test" && w(2) == ")" && w(3) == "]"
}

/// The index after the item that starts at the attribute at `i`: further
/// attributes, then up to a `;` outside brackets or a balanced `{ … }`.
fn skip_item(t: &[(String, usize)], mut i: usize) -> usize {
    let (mut round, mut braces) = (0i32, 0i32);
    while i < t.len() {
        match t[i].0.as_str() {
            "(" | "[" => round += 1,
            ")" | "]" => round -= 1,
            ";" if round == 0 && braces == 0 => return i + 1,
            "{" if round == 0 => braces += 1,
            "}" if round == 0 => {
                braces -= 1;
                if braces == 0 {
                    return i + 1;
                }
            }
            _ => {}
        }
        i += 1;
    }
    i
}

/// The paths of a use group `{ a, b::c, d::{e, f}, * }` whose `{` is before
/// `k`; returns the index after its `}`.
fn use_group(
    t: &[(String, usize)],
    mut k: usize,
    prefix: &[String],
    out: &mut Vec<Vec<String>>,
) -> usize {
    let w = |j: usize| t.get(j).map(|x| x.0.as_str()).unwrap_or("");
    let mut path = prefix.to_vec();
    let mut pending = false;
    while k < t.len() {
        match w(k) {
            "}" => {
                if pending {
                    out.push(path.clone());
                }
                return k + 1;
            }
            "," => {
                if pending {
                    out.push(path.clone());
                }
                path = prefix.to_vec();
                pending = false;
            }
            "::" if w(k + 1) == "{" => {
                k = use_group(t, k + 2, &path, out);
                pending = false;
                continue;
            }
            "as" => k += 1, // the alias names nothing to follow
            "::" | "*" => {}
            "self" => pending = true, // the group's own module
            s if s.chars().all(ident_char) => {
                path.push(s.to_string());
                pending = true;
            }
            _ => {}
        }
        k += 1;
    }
    k
}

// ------------------------------------------------------------ the graph

/// Every source file of the library and the binary, by module, and every import.
struct House {
    /// Module → the file that holds it (inline modules: their file).
    modules: BTreeMap<ModPath, PathBuf>,
    /// File → its module (file modules only).
    file_module: BTreeMap<PathBuf, ModPath>,
    imports: Vec<Import>,
}

fn read_house(root: &Path) -> House {
    let mut house = House {
        modules: BTreeMap::new(),
        file_module: BTreeMap::new(),
        imports: Vec::new(),
    };
    let mut parsed: Vec<(PathBuf, ModPath, FileItems)> = Vec::new();
    let mut queue = vec![
        (root.join("src/lib.rs"), (LIB, Vec::new())),
        (root.join("src/main.rs"), (BIN, Vec::new())),
    ];
    while let Some((file, module)) = queue.pop() {
        let src = fs::read_to_string(&file).unwrap_or_else(|e| panic!("{}: {e}", file.display()));
        assert!(
            !src.contains("#[path"),
            "{}: a #[path] attribute; this test resolves modules by Rust's default layout",
            file.display()
        );
        let items = parse(&strip(&src));
        let rel = file
            .strip_prefix(root)
            .expect("inside the root")
            .to_path_buf();
        house.modules.insert(module.clone(), rel.clone());
        house.file_module.insert(rel.clone(), module.clone());
        for inner in &items.inline {
            let mut m = module.1.clone();
            m.extend(inner.iter().cloned());
            house.modules.insert((module.0, m), rel.clone());
        }
        for (inner, name) in &items.children {
            let mut m = module.1.clone();
            m.extend(inner.iter().cloned());
            m.push(name.clone());
            queue.push((child_file(root, &file, &module, inner, name), (module.0, m)));
        }
        parsed.push((rel, module, items));
    }
    for (rel, module, items) in parsed {
        for (inner, line, segments) in items.paths {
            let mut here = module.1.clone();
            here.extend(inner);
            if let Some(to) = resolve(&house.modules, module.0, &here, &segments) {
                house.imports.push(Import {
                    from: rel.clone(),
                    line,
                    path: segments.join("::"),
                    to,
                });
            }
        }
    }
    house
}

/// The file of `mod name;` declared in `file` (module `module`, inside the
/// inline modules `inner`): `dir/name.rs` or `dir/name/mod.rs`.
fn child_file(root: &Path, file: &Path, module: &ModPath, inner: &[String], name: &str) -> PathBuf {
    let stem = file.file_stem().and_then(|s| s.to_str()).unwrap_or("");
    let mut dir = file.parent().expect("a folder").to_path_buf();
    if !(module.1.is_empty() || stem == "mod") {
        dir.push(stem);
    }
    for m in inner {
        dir.push(m);
    }
    let flat = dir.join(format!("{name}.rs"));
    let nested = dir.join(name).join("mod.rs");
    if flat.exists() {
        flat
    } else {
        assert!(
            nested.exists(),
            "{}: `mod {name};` has no file under {}",
            file.display(),
            root.display()
        );
        nested
    }
}

/// The file of the deepest module a path reaches.
fn resolve(
    modules: &BTreeMap<ModPath, PathBuf>,
    krate: &'static str,
    here: &[String],
    segments: &[String],
) -> Option<PathBuf> {
    let (mut krate, mut at, mut rest) = (krate, here.to_vec(), segments);
    match segments.first().map(String::as_str) {
        Some("crate") => at.clear(),
        Some("swarmshot") if krate == BIN => {
            krate = LIB;
            at.clear();
        }
        Some("self") => {}
        Some("super") => {
            while rest.first().map(String::as_str) == Some("super") {
                at.pop()?;
                rest = &rest[1..];
            }
        }
        _ => return None,
    }
    if matches!(segments[0].as_str(), "crate" | "self" | "swarmshot") {
        rest = &rest[1..];
    }
    for s in rest {
        let mut next = at.clone();
        next.push(s.clone());
        if !modules.contains_key(&(krate, next.clone())) {
            break;
        }
        at = next;
    }
    modules.get(&(krate, at)).cloned()
}

impl House {
    /// The imports counted: between different files, neither the other's ancestor.
    fn edges(&self) -> Vec<&Import> {
        self.imports
            .iter()
            .filter(|i| i.from != i.to && !self.related(&i.from, &i.to))
            .collect()
    }

    fn related(&self, a: &Path, b: &Path) -> bool {
        let (Some(a), Some(b)) = (self.file_module.get(a), self.file_module.get(b)) else {
            return false;
        };
        a.0 == b.0 && (a.1.starts_with(&b.1) || b.1.starts_with(&a.1))
    }

    /// The top-level module of a file: the library's first name, or `cli` for the binary.
    fn top(&self, file: &Path) -> String {
        match self.file_module.get(file) {
            Some((BIN, _)) => "cli".into(),
            Some((_, m)) if !m.is_empty() => m[0].clone(),
            _ => "lib".into(),
        }
    }
}

/// The strongly connected components with more than one node (Tarjan).
fn cycles<N: Ord + Clone>(edges: &BTreeMap<N, BTreeSet<N>>) -> Vec<Vec<N>> {
    struct State<N> {
        index: BTreeMap<N, usize>,
        low: BTreeMap<N, usize>,
        stack: Vec<N>,
        on: BTreeSet<N>,
        out: Vec<Vec<N>>,
    }
    fn visit<N: Ord + Clone>(v: &N, e: &BTreeMap<N, BTreeSet<N>>, s: &mut State<N>) {
        let n = s.index.len();
        s.index.insert(v.clone(), n);
        s.low.insert(v.clone(), n);
        s.stack.push(v.clone());
        s.on.insert(v.clone());
        for w in e.get(v).into_iter().flatten() {
            if !s.index.contains_key(w) {
                visit(w, e, s);
                let l = s.low[w].min(s.low[v]);
                s.low.insert(v.clone(), l);
            } else if s.on.contains(w) {
                let l = s.index[w].min(s.low[v]);
                s.low.insert(v.clone(), l);
            }
        }
        if s.low[v] == s.index[v] {
            let mut scc = Vec::new();
            while let Some(w) = s.stack.pop() {
                s.on.remove(&w);
                let done = &w == v;
                scc.push(w);
                if done {
                    break;
                }
            }
            if scc.len() > 1 {
                scc.sort();
                s.out.push(scc);
            }
        }
    }
    let mut s = State {
        index: BTreeMap::new(),
        low: BTreeMap::new(),
        stack: Vec::new(),
        on: BTreeSet::new(),
        out: Vec::new(),
    };
    let nodes: BTreeSet<N> = edges
        .iter()
        .flat_map(|(a, bs)| std::iter::once(a.clone()).chain(bs.iter().cloned()))
        .collect();
    for v in &nodes {
        if !s.index.contains_key(v) {
            visit(v, edges, &mut s);
        }
    }
    s.out.sort();
    s.out
}

// ------------------------------------------------------------ the order

/// The layers of docs/architecture.md's ```` ```layers ```` block, top
/// first: each line the modules of one layer, separated by spaces.
fn layers(doc: &str) -> Vec<Vec<String>> {
    let block = doc
        .split("```layers\n")
        .nth(1)
        .expect("docs/architecture.md has a ```layers block");
    let block = block.split("```").next().unwrap_or("");
    block
        .lines()
        .map(|l| l.split_whitespace().map(String::from).collect::<Vec<_>>())
        .filter(|l| !l.is_empty())
        .collect()
}

/// The order in one line, bottom first: `input, seed, text → preset → …`.
fn one_line(layers: &[Vec<String>]) -> String {
    let parts: Vec<String> = layers.iter().rev().map(|l| l.join(", ")).collect();
    parts.join(" → ")
}

fn squash(s: &str) -> String {
    s.split_whitespace().collect::<Vec<_>>().join(" ")
}

fn root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

fn describe(e: &Import) -> String {
    format!(
        "{}:{} imports `{}` ({})",
        e.from.display(),
        e.line,
        e.path,
        e.to.display()
    )
}

// ------------------------------------------------------------ the tests

#[test]
fn no_import_cycle_between_source_files() {
    let house = read_house(&root());
    let edges = house.edges();
    let mut graph: BTreeMap<PathBuf, BTreeSet<PathBuf>> = BTreeMap::new();
    for e in &edges {
        graph
            .entry(e.from.clone())
            .or_default()
            .insert(e.to.clone());
    }
    let found = cycles(&graph);
    let report: Vec<String> = found
        .iter()
        .map(|scc| {
            let inside: Vec<String> = edges
                .iter()
                .filter(|e| scc.contains(&e.from) && scc.contains(&e.to))
                .map(|e| format!("    {}", describe(e)))
                .collect();
            format!("a cycle of {} files:\n{}", scc.len(), inside.join("\n"))
        })
        .collect();
    assert!(
        report.is_empty(),
        "import cycles between source files:\n{}",
        report.join("\n")
    );
}

#[test]
fn no_import_cycle_between_top_level_modules() {
    let house = read_house(&root());
    let mut graph: BTreeMap<String, BTreeSet<String>> = BTreeMap::new();
    let edges = house.edges();
    for e in &edges {
        let (a, b) = (house.top(&e.from), house.top(&e.to));
        if a != b {
            graph.entry(a).or_default().insert(b);
        }
    }
    let found = cycles(&graph);
    let report: Vec<String> = found
        .iter()
        .map(|scc| {
            let inside: Vec<String> = edges
                .iter()
                .filter(|e| {
                    let (a, b) = (house.top(&e.from), house.top(&e.to));
                    a != b && scc.contains(&a) && scc.contains(&b)
                })
                .map(|e| format!("    {}", describe(e)))
                .collect();
            format!(
                "a cycle of modules {}:\n{}",
                scc.join(", "),
                inside.join("\n")
            )
        })
        .collect();
    assert!(
        report.is_empty(),
        "import cycles between top-level modules:\n{}",
        report.join("\n")
    );
}

#[test]
fn no_module_imports_one_above_it_in_the_stated_order() {
    let root = root();
    let doc = fs::read_to_string(root.join("docs/architecture.md")).expect("docs/architecture.md");
    let layers = layers(&doc);
    let level: BTreeMap<&str, usize> = (layers.iter().rev().enumerate())
        .flat_map(|(n, l)| l.iter().map(move |m| (m.as_str(), n)))
        .collect();
    let house = read_house(&root);
    let tops: BTreeSet<String> = house
        .file_module
        .keys()
        .map(|f| house.top(f))
        .filter(|t| t != "lib")
        .collect();
    let stated: BTreeSet<String> = level.keys().map(|s| s.to_string()).collect();
    assert_eq!(
        tops, stated,
        "docs/architecture.md's layers block must name every top-level module once (src/*.rs, src/*/, and cli for the binary)"
    );
    let wrong: Vec<String> = (house.edges().into_iter())
        .filter_map(|e| {
            let (a, b) = (house.top(&e.from), house.top(&e.to));
            let (la, lb) = (level.get(a.as_str())?, level.get(b.as_str())?);
            (a != b && la <= lb).then(|| {
                let why = if la == lb {
                    "on its own layer"
                } else {
                    "above it"
                };
                format!("    {}: `{a}` may not import `{b}`, {why}", describe(e))
            })
        })
        .collect();
    assert!(
        wrong.is_empty(),
        "imports against the order of docs/architecture.md ({}):\n{}",
        one_line(&layers),
        wrong.join("\n")
    );
}

#[test]
fn lib_rs_and_the_readme_state_the_documented_order() {
    let root = root();
    let doc = fs::read_to_string(root.join("docs/architecture.md")).expect("docs/architecture.md");
    let order = one_line(&layers(&doc));
    let lib = fs::read_to_string(root.join("src/lib.rs")).expect("src/lib.rs");
    let lib_docs: String = (lib.lines())
        .filter_map(|l| l.trim_start().strip_prefix("//!"))
        .collect::<Vec<_>>()
        .join(" ");
    assert!(
        squash(&lib_docs).contains(&order),
        "src/lib.rs's module docs must state the order of docs/architecture.md: {order}"
    );
    let readme = fs::read_to_string(root.join("README.md")).expect("README.md");
    let layout = readme
        .split("## Layout")
        .nth(1)
        .expect("README.md has a Layout section");
    let layout = layout.split("\n## ").next().unwrap_or("");
    assert!(
        squash(layout).contains(&order),
        "README.md's Layout must state the order of docs/architecture.md: {order}"
    );
}

#[test]
fn the_cycle_finder_finds_a_cycle_and_only_that() {
    let mut g: BTreeMap<&str, BTreeSet<&str>> = BTreeMap::new();
    for (a, b) in [
        ("a", "b"),
        ("b", "c"),
        ("c", "a"),
        ("c", "d"),
        ("d", "e"),
        ("f", "f"),
    ] {
        g.entry(a).or_default().insert(b);
    }
    assert_eq!(cycles(&g), vec![vec!["a", "b", "c"]]);
    g.get_mut("c").expect("c").remove("a");
    assert!(cycles(&g).is_empty());
}

#[test]
fn the_reader_sees_paths_in_code_only() {
    let src = r#"
        use super::{a::B, c::{d, e::F as G}, h};
        // crate::in_comment::x
        /* crate::in_block::y */
        const S: &str = "crate::in_string::z";
        const C: char = '"';
        fn f<'a>(x: &'a str) { crate::called::now(x); }
        #[cfg(test)]
        mod tests { use crate::only_tests::T; }
        mod inner { use super::sibling::K; }
        mod child;
    "#;
    let items = parse(&strip(src));
    let paths: Vec<String> = items.paths.iter().map(|p| p.2.join("::")).collect();
    assert_eq!(
        paths,
        [
            "super::a::B",
            "super::c::d",
            "super::c::e::F",
            "super::h",
            "crate::called::now",
            "super::sibling::K"
        ]
    );
    assert_eq!(items.paths[5].0, vec!["inner".to_string()]);
    assert_eq!(items.children, vec![(Vec::new(), "child".to_string())]);
    assert_eq!(items.inline, vec![vec!["inner".to_string()]]);
}
