//! The docs describe what is: README.md and docs/*.md checked against the
//! repository they describe. Each rule is precise enough to hold on honest
//! docs without a list of exceptions:
//!
//! - a relative link `[..](path#anchor)` names a file that exists, and its
//!   anchor a heading of that file (GitHub's slugs);
//! - a section cited in prose as `docs/NAME.md, "Title"` is a heading or a
//!   paragraph's lead (`**Title**`, or a line that starts with it) there;
//! - a backticked path (or one in a code block) whose first folder is one
//!   of the repository's source folders exists, unless it holds a glob
//!   (`*`, `[_masks]`, `{a,b}`, `${p}`, `…`) or an upper-case placeholder
//!   (`NAME`, `OUT`): those name many files, or files made at run time;
//! - a test cited by name (a backticked snake_case name of three words or
//!   more, on a line that speaks of tests or names a `.rs` file, or in a
//!   table with a test column) is a `fn` in src/, tests/ or examples/, or,
//!   where the name is a field or a library's item, an identifier the code
//!   uses;
//! - a path of names whose first is a module of the crate
//!   (`swarmshot::gap::run_report`, `text::for_terminal`) names an item its
//!   module declares or re-exports; one whose first is only a module of the
//!   suite (`scale::a_test`) a `fn` of tests/suite/scale.rs;
//! - a command `swarmshot SUBCOMMAND --flag …` (in a code block, or opening
//!   a backticked span) uses a subcommand and flags that the test build's
//!   `swarmshot SUBCOMMAND --help` lists;
//! - a `cargo test --test NAME FILTER` names a test target that exists, and
//!   for the suite a filter that is part of a test's `module::fn` path;
//! - an example run as `--example NAME` or `target/release/examples/NAME`
//!   is examples/NAME.rs.
//!
//! Every failure names the doc, its line and what is missing.

use std::collections::{BTreeMap, BTreeSet};
use std::fs;
use std::path::{Component, Path, PathBuf};
use std::process::Command;

use super::architecture::strip;
use crate::common::cli::BIN;

/// The repository's own top-level folders: a backticked path that starts
/// with one of them names a file of this repository.
const REPO_FOLDERS: [&str; 8] = [
    "src", "tests", "presets", "examples", "scripts", "shaders", "docs", "assets",
];

/// Where the code whose names the docs cite lives.
const CODE_FOLDERS: [&str; 3] = ["src", "tests", "examples"];

/// The keywords that declare an item; `as` renames one in a re-export.
const ITEM_KEYWORDS: [&str; 9] = [
    "fn", "struct", "enum", "mod", "const", "static", "type", "trait", "as",
];

/// Code-block languages whose every line may hold `swarmshot` commands
/// (a `text` block: its `$ ` lines).
const SHELL_BLOCKS: [&str; 5] = ["", "sh", "bash", "console", "yaml"];

// ------------------------------------------------------------ the docs

/// One doc: its path from the repository root and its lines.
struct Doc {
    path: PathBuf,
    lines: Vec<Line>,
}

/// A line of a doc outside the fences: its 1-based number, its text and,
/// inside a code block, the block's language (`""` when none is given).
struct Line {
    number: usize,
    text: String,
    block: Option<String>,
}

impl Doc {
    fn read(root: &Path, path: &Path) -> Doc {
        let text = fs::read_to_string(root.join(path))
            .unwrap_or_else(|e| panic!("read {}: {e}", path.display()));
        Doc {
            path: path.to_path_buf(),
            lines: lines(&text),
        }
    }

    /// `doc:line: what`, the form of every failure.
    fn at(&self, line: &Line, what: String) -> String {
        format!("{}:{}: {what}", self.path.display(), line.number)
    }

    /// The folder the doc's relative links start from.
    fn folder(&self) -> &Path {
        self.path.parent().unwrap_or(Path::new(""))
    }

    fn prose(&self) -> impl Iterator<Item = &Line> {
        self.lines.iter().filter(|l| l.block.is_none())
    }
}

/// The lines with their code-block language; the fence lines themselves are left out.
fn lines(text: &str) -> Vec<Line> {
    let mut out = Vec::new();
    let mut block: Option<String> = None;
    for (i, text) in text.lines().enumerate() {
        if let Some(lang) = text.trim_start().strip_prefix("```") {
            block = match block {
                Some(_) => None,
                None => Some(lang.trim().to_string()),
            };
            continue;
        }
        out.push(Line {
            number: i + 1,
            text: text.to_string(),
            block: block.clone(),
        });
    }
    out
}

/// README.md and every docs/*.md, in name order.
fn docs(root: &Path) -> Vec<Doc> {
    let mut paths = vec![PathBuf::from("README.md")];
    let mut in_docs: Vec<PathBuf> = fs::read_dir(root.join("docs"))
        .expect("read docs/")
        .filter_map(|e| e.ok())
        .map(|e| Path::new("docs").join(e.file_name()))
        .filter(|p| p.extension().is_some_and(|x| x == "md"))
        .collect();
    in_docs.sort();
    paths.extend(in_docs);
    paths.iter().map(|p| Doc::read(root, p)).collect()
}

/// The contents of the backticked code spans of a line (CommonMark: a run of
/// N backticks is closed by the next run of exactly N; one space each side
/// of a span that has text is dropped).
fn code_spans(text: &str) -> Vec<&str> {
    let mut spans = Vec::new();
    let mut rest = text;
    while let Some(open) = rest.find('`') {
        let ticks = rest[open..].chars().take_while(|&c| c == '`').count();
        let body = &rest[open + ticks..];
        let Some(close) = closing_run(body, ticks) else {
            break;
        };
        let span = &body[..close];
        let trimmed = span.strip_prefix(' ').and_then(|s| s.strip_suffix(' '));
        spans.push(trimmed.filter(|s| !s.trim().is_empty()).unwrap_or(span));
        rest = &body[close + ticks..];
    }
    spans
}

/// Where the next run of exactly `ticks` backticks starts in `text`.
fn closing_run(text: &str, ticks: usize) -> Option<usize> {
    let bytes = text.as_bytes();
    let mut i = 0;
    while i < bytes.len() {
        if bytes[i] != b'`' {
            i += 1;
            continue;
        }
        let run = bytes[i..].iter().take_while(|&&b| b == b'`').count();
        if run == ticks {
            return Some(i);
        }
        i += run;
    }
    None
}

/// The texts of a line that hold code: the whole line in a code block, the
/// backticked spans in prose.
fn code_texts(line: &Line) -> Vec<&str> {
    match line.block {
        Some(_) => vec![line.text.as_str()],
        None => code_spans(&line.text),
    }
}

// ------------------------------------------------------------ links and sections

/// The anchors GitHub gives a Markdown file's headings: lower case, spaces
/// to `-`, every other character but letters, digits, `-` and `_` dropped;
/// the second heading with a slug gets `-1`, the third `-2`.
fn anchors(doc: &Doc) -> BTreeSet<String> {
    let mut seen: BTreeMap<String, usize> = BTreeMap::new();
    let mut out = BTreeSet::new();
    for heading in doc.prose().filter_map(|l| heading(&l.text)) {
        let slug = slug(heading);
        let n = seen.entry(slug.clone()).or_insert(0);
        out.insert(if *n == 0 { slug } else { format!("{slug}-{n}") });
        *n += 1;
    }
    out
}

/// The text of an ATX heading (`## Text`), without its closing `#`s.
fn heading(line: &str) -> Option<&str> {
    let hashes = line.chars().take_while(|&c| c == '#').count();
    let text = line.get(hashes..)?;
    let heading = (1..=6).contains(&hashes) && text.starts_with(' ');
    heading.then(|| text.trim().trim_end_matches('#').trim())
}

fn slug(heading: &str) -> String {
    heading
        .trim()
        .to_lowercase()
        .chars()
        .filter_map(|c| match c {
            ' ' => Some('-'),
            c if c.is_alphanumeric() || c == '-' || c == '_' => Some(c),
            _ => None,
        })
        .collect()
}

/// The targets of the line's `[text](target)` links and images.
fn link_targets(text: &str) -> Vec<&str> {
    text.match_indices("](")
        .filter_map(|(i, _)| {
            let rest = &text[i + 2..];
            let end = rest.find(')')?;
            Some(rest[..end].trim())
        })
        .collect()
}

/// `a/b/../c` as `a/c`: a link's file from the repository root.
fn normalise(path: &Path) -> PathBuf {
    let mut out = PathBuf::new();
    for part in path.components() {
        match part {
            Component::ParentDir => {
                out.pop();
            }
            Component::CurDir => {}
            other => out.push(other),
        }
    }
    out
}

fn check_links(root: &Path, docs: &[Doc], doc: &Doc) -> Vec<String> {
    let mut failures = Vec::new();
    for line in doc.prose() {
        for target in link_targets(&line.text) {
            let external = target.contains("://") || target.starts_with("mailto:");
            if external || target.is_empty() {
                continue;
            }
            let (file, anchor) = target.split_once('#').unwrap_or((target, ""));
            let path = match file {
                "" => doc.path.clone(),
                f => normalise(&doc.folder().join(f)),
            };
            if !root.join(&path).exists() {
                failures.push(doc.at(line, format!("link `{target}`: no file {}", path.display())));
            } else if !anchor.is_empty() && !has_anchor(root, docs, &path, anchor) {
                failures.push(doc.at(
                    line,
                    format!(
                        "link `{target}`: {} has no heading #{anchor}",
                        path.display()
                    ),
                ));
            }
        }
    }
    failures
}

/// Whether a Markdown file has the anchor; anchors into other files (source,
/// data) are not checked.
fn has_anchor(root: &Path, docs: &[Doc], path: &Path, anchor: &str) -> bool {
    if path.extension().is_none_or(|x| x != "md") {
        return true;
    }
    match docs.iter().find(|d| d.path == path) {
        Some(target) => anchors(target).contains(anchor),
        None => anchors(&Doc::read(root, path)).contains(anchor),
    }
}

/// The sections the line cites in prose as `NAME.md, "Title"` (or `NAME.md
/// "Title"`, with straight or curly quotes): the doc's path and the title.
fn section_citations(doc: &Doc, text: &str) -> Vec<(PathBuf, String)> {
    let mut out = Vec::new();
    for (i, _) in text.match_indices(".md") {
        let after = text[i + 3..].trim_start_matches(',').trim_start();
        let Some(quoted) = after.strip_prefix(['"', '“']) else {
            continue;
        };
        let Some(end) = quoted.find(['"', '”']) else {
            continue;
        };
        let start = text[..i]
            .rfind(|c: char| !(c.is_alphanumeric() || "/_-.".contains(c)))
            .map_or(0, |s| s + 1);
        let name = &text[start..i + 3];
        let path = if name.contains('/') || name == "README.md" {
            PathBuf::from(name)
        } else {
            doc.folder().join(name)
        };
        out.push((path, quoted[..end].trim_end_matches(['.', ',']).to_string()));
    }
    out
}

/// A cited section is a heading holding the title, or a paragraph led by it
/// (`**Title**`, or a line that starts with the title).
fn has_section(target: &Doc, title: &str) -> bool {
    let title = title.to_lowercase();
    target.prose().any(|l| {
        let text = l.text.to_lowercase();
        match heading(&text) {
            Some(h) => h.contains(&title),
            None => text.starts_with(&title) || text.starts_with(&format!("**{title}")),
        }
    })
}

fn check_sections(docs: &[Doc], doc: &Doc) -> Vec<String> {
    let mut failures = Vec::new();
    // Code blocks too: a command's comment may cite a section.
    for line in &doc.lines {
        for (path, title) in section_citations(doc, &line.text) {
            let target = docs.iter().find(|d| d.path == path);
            let what = match target {
                None => format!(
                    "cites \"{title}\" in {}, which is not a doc",
                    path.display()
                ),
                Some(t) if !has_section(t, &title) => {
                    format!(
                        "cites section \"{title}\", which {} does not have",
                        path.display()
                    )
                }
                Some(_) => continue,
            };
            failures.push(doc.at(line, what));
        }
    }
    failures
}

// ------------------------------------------------------------ paths

/// Words of a code text that may be paths: split at white space, quotes,
/// brackets of calls and list separators.
fn words(text: &str) -> impl Iterator<Item = &str> {
    text.split(|c: char| c.is_whitespace() || "`'\"(),;=|".contains(c))
        .filter(|w| !w.is_empty())
}

/// The repository path a word names, if it starts with one of the
/// repository's folders: `./` dropped, a trailing `:line`, `:a-b` or
/// `::item` and sentence punctuation cut.
fn repo_path(word: &str) -> Option<&str> {
    let word = word.strip_prefix("./").unwrap_or(word);
    let (first, _) = word.split_once('/')?;
    if !REPO_FOLDERS.contains(&first) {
        return None;
    }
    let word = word.split("::").next().unwrap_or(word);
    let word = match word.split_once(':') {
        Some((path, _)) => path,
        None => word,
    };
    Some(word.trim_end_matches(['.', ',', ':']))
}

/// A path that names many files or one made at run time: a glob, a shell
/// variable, an ellipsis, or an upper-case placeholder segment (`NAME.glb`,
/// `rounds/NN/`); a real upper-case file (`README.md`) exists and so never
/// gets here.
fn is_pattern(path: &str) -> bool {
    let glob = path.contains(['*', '?', '[', ']', '{', '}', '<', '>', '$', '…']);
    let placeholder = path.split('/').any(|segment| {
        let stem = segment.split('.').next().unwrap_or(segment);
        !stem.is_empty()
            && stem.chars().any(|c| c.is_ascii_uppercase())
            && stem
                .chars()
                .all(|c| c.is_ascii_uppercase() || c.is_ascii_digit() || c == '_')
    });
    glob || placeholder
}

fn check_paths(root: &Path, doc: &Doc) -> Vec<String> {
    let mut failures = Vec::new();
    for line in &doc.lines {
        for text in code_texts(line) {
            for path in words(text).filter_map(repo_path) {
                if !root.join(path).exists() && !is_pattern(path) {
                    failures.push(doc.at(line, format!("`{path}` does not exist")));
                }
            }
        }
    }
    failures
}

/// The example programs a code text builds or runs: `--example NAME` and
/// `target/PROFILE/examples/NAME`.
fn example_names(text: &str) -> Vec<&str> {
    let words: Vec<&str> = words(text).collect();
    let mut out = Vec::new();
    for (i, word) in words.iter().enumerate() {
        let built = word.trim_start_matches("./").starts_with("target/");
        if *word == "--example" {
            out.extend(words.get(i + 1).copied());
        } else if let Some((_, name)) = word.split_once("/examples/").filter(|_| built) {
            out.push(name);
        }
    }
    out
}

fn check_examples(root: &Path, doc: &Doc) -> Vec<String> {
    let mut failures = Vec::new();
    for line in &doc.lines {
        for text in code_texts(line) {
            for name in example_names(text) {
                let source = Path::new("examples").join(name).with_extension("rs");
                if !root.join(&source).exists() {
                    failures
                        .push(doc.at(line, format!("example `{name}`: no {}", source.display())));
                }
            }
        }
    }
    failures
}

// ------------------------------------------------------------ code names

/// The code of src/, tests/ and examples/ (comments and string literals
/// blanked out): what each file declares, and every identifier it uses.
struct Code {
    declared: BTreeMap<PathBuf, BTreeSet<(String, String)>>,
    identifiers: BTreeSet<String>,
}

impl Code {
    fn read(root: &Path) -> Code {
        let mut files = BTreeMap::new();
        for folder in CODE_FOLDERS {
            read_rust_files(root, Path::new(folder), &mut files);
        }
        let identifiers = files
            .values()
            .flat_map(|code| identifiers(code))
            .map(str::to_string)
            .collect();
        let declared = files
            .iter()
            .map(|(path, code)| (path.clone(), declarations(code)))
            .collect();
        Code {
            declared,
            identifiers,
        }
    }

    fn has_file(&self, path: &Path) -> bool {
        self.declared.contains_key(path)
    }

    /// The files that define `fn name`.
    fn defining_fn(&self, name: &str) -> Vec<&Path> {
        let key = ("fn".to_string(), name.to_string());
        self.declared
            .iter()
            .filter(|(_, items)| items.contains(&key))
            .map(|(path, _)| path.as_path())
            .collect()
    }

    /// `module::name` of every fn of tests/suite/: the paths `cargo test
    /// --test suite FILTER` matches.
    fn suite_fns(&self) -> Vec<String> {
        let suite = Path::new("tests/suite");
        let mut out = Vec::new();
        for (path, items) in &self.declared {
            let Some(module) = path.strip_prefix(suite).ok().and_then(|p| p.file_stem()) else {
                continue;
            };
            let module = module.to_string_lossy();
            let fns = items.iter().filter(|(kw, _)| kw == "fn");
            out.extend(fns.map(|(_, name)| format!("{module}::{name}")));
        }
        out
    }

    /// Whether a module (its file, or for a folder module any file under it)
    /// declares `name` as an item.
    fn module_declares(&self, module: &Path, name: &str) -> bool {
        let file = module.with_extension("rs");
        self.declared
            .iter()
            .filter(|(path, _)| **path == file || path.starts_with(module))
            .any(|(_, items)| {
                items
                    .iter()
                    .any(|(kw, n)| n == name && ITEM_KEYWORDS.contains(&kw.as_str()))
            })
    }
}

fn read_rust_files(root: &Path, folder: &Path, out: &mut BTreeMap<PathBuf, String>) {
    let Ok(entries) = fs::read_dir(root.join(folder)) else {
        return;
    };
    for entry in entries.filter_map(|e| e.ok()) {
        let path = folder.join(entry.file_name());
        if entry.file_type().is_ok_and(|t| t.is_dir()) {
            read_rust_files(root, &path, out);
        } else if path.extension().is_some_and(|x| x == "rs") {
            let text = fs::read_to_string(root.join(&path)).unwrap_or_default();
            out.insert(path, strip(&text));
        }
    }
}

fn identifiers(code: &str) -> impl Iterator<Item = &str> {
    code.split(|c: char| !(c.is_alphanumeric() || c == '_'))
        .filter(|w| !w.is_empty())
}

/// Each item keyword with the name after it (`fn name`, `struct Name`, `as
/// name` of a re-export).
fn declarations(code: &str) -> BTreeSet<(String, String)> {
    let words: Vec<&str> = identifiers(code).collect();
    words
        .windows(2)
        .filter(|w| ITEM_KEYWORDS.contains(&w[0]))
        .map(|w| (w[0].to_string(), w[1].to_string()))
        .collect()
}

/// A snake_case name of three words or more: how the docs cite a test.
fn is_test_like(name: &str) -> bool {
    let parts: Vec<&str> = name.split('_').collect();
    parts.len() >= 3
        && name.starts_with(|c: char| c.is_ascii_lowercase())
        && parts.iter().all(|p| {
            !p.is_empty()
                && p.chars()
                    .all(|c| c.is_ascii_lowercase() || c.is_ascii_digit())
        })
}

/// A table's header row that has a test column (`| … | test |`).
fn is_test_header(text: &str) -> bool {
    text.starts_with('|')
        && text.split('|').any(|cell| {
            let cell = cell.trim().to_lowercase();
            cell.starts_with("test") || cell.ends_with("test") || cell.ends_with("tests")
        })
}

/// For each prose line, whether it cites tests: it speaks of a test, names a
/// `.rs` file, or sits in a table with a test column.
fn test_lines(doc: &Doc) -> Vec<(&Line, bool)> {
    let mut in_test_table = false;
    let mut out = Vec::new();
    for line in doc.prose() {
        let text = &line.text;
        if !text.starts_with('|') {
            in_test_table = false;
        } else if !in_test_table {
            in_test_table = is_test_header(text);
        }
        let cites = in_test_table || text.to_lowercase().contains("test") || text.contains(".rs`");
        out.push((line, cites));
    }
    out
}

fn check_tests(code: &Code, doc: &Doc) -> Vec<String> {
    let mut failures = Vec::new();
    for (line, cites) in test_lines(doc) {
        if !cites {
            continue;
        }
        // `module::test_name` is a path: the item rule checks it.
        let names = code_spans(&line.text)
            .into_iter()
            .filter(|s| is_test_like(s));
        for name in names {
            let known = !code.defining_fn(name).is_empty() || code.identifiers.contains(name);
            if !known {
                let what = format!("test `{name}`: no `fn {name}` in src/, tests/ or examples/");
                failures.push(doc.at(line, what));
            }
        }
    }
    failures
}

/// Whether `module::name` is a test of tests/suite/module.rs.
fn is_suite_test(code: &Code, segments: &[&str]) -> bool {
    let [module, name] = segments else {
        return false;
    };
    let suite = Path::new("tests/suite").join(module).with_extension("rs");
    code.defining_fn(name).contains(&suite.as_path())
}

/// The module folder of a crate path's first segment (`src/gap`), if it is
/// one of the crate's top-level modules.
fn crate_module(code: &Code, first: &str) -> Option<PathBuf> {
    let folder = Path::new("src").join(first);
    let file = folder.with_extension("rs");
    let is_module = code.has_file(&file) || code.has_file(&folder.join("mod.rs"));
    (is_module && first != "main" && first != "lib").then_some(folder)
}

/// Why a crate path (`gap::report::run`) names nothing, if it does not: its
/// deepest module that is a file must declare the last segment (an item, or
/// a module that is a file under it).
fn missing_item(code: &Code, mut module: PathBuf, segments: &[&str]) -> Option<String> {
    let mut rest = &segments[1..];
    while let Some((next, tail)) = rest.split_first() {
        let deeper = module.join(next);
        let is_file =
            code.has_file(&deeper.with_extension("rs")) || code.has_file(&deeper.join("mod.rs"));
        if !is_file {
            break;
        }
        module = deeper;
        rest = tail;
    }
    let item = rest.last()?;
    let declared = code.module_declares(&module, item);
    let shown = match code.has_file(&module.with_extension("rs")) {
        true => module.with_extension("rs").display().to_string(),
        false => format!("{}/", module.display()),
    };
    (!declared).then(|| format!("`{}`: {shown} declares no `{item}`", segments.join("::")))
}

/// A backticked span that is a path of names (`a::b::c`, `f()` allowed):
/// whether it starts at the crate root (`swarmshot::`, `crate::`), and its
/// segments after that.
fn crate_path(span: &str) -> Option<(bool, Vec<&str>)> {
    let span = span.strip_suffix("()").unwrap_or(span);
    let rooted = span
        .strip_prefix("swarmshot::")
        .or_else(|| span.strip_prefix("crate::"));
    let segments: Vec<&str> = rooted.unwrap_or(span).split("::").collect();
    let names = segments
        .iter()
        .all(|s| !s.is_empty() && s.chars().all(|c| c.is_alphanumeric() || c == '_'));
    let long_enough = segments.len() >= 2 || rooted.is_some();
    (long_enough && names).then_some((rooted.is_some(), segments))
}

fn is_suite_module(code: &Code, name: &str) -> bool {
    code.has_file(&Path::new("tests/suite").join(name).with_extension("rs"))
}

fn check_items(code: &Code, doc: &Doc) -> Vec<String> {
    let mut failures = Vec::new();
    for line in doc.prose() {
        for span in code_spans(&line.text) {
            let Some((rooted, segments)) = crate_path(span) else {
                continue;
            };
            if !rooted && is_suite_test(code, &segments) {
                continue;
            }
            let what = match crate_module(code, segments[0]) {
                Some(module) => missing_item(code, module, &segments),
                None if rooted => Some(format!(
                    "`{span}`: the crate has no module `{}`",
                    segments[0]
                )),
                None if is_suite_module(code, segments[0]) => Some(format!(
                    "test `{span}`: no `fn {}` in tests/suite/{}.rs",
                    segments[1..].join("::"),
                    segments[0]
                )),
                // A path from inside a module (`plates::view_crop`) or of a type.
                None => None,
            };
            failures.extend(what.map(|w| doc.at(line, w)));
        }
    }
    failures
}

// ------------------------------------------------------------ commands

/// The flags each subcommand (`batch`, `bench accuracy`) has, read from the
/// test build's `--help`, asked once each.
struct Cli {
    subcommands: BTreeSet<String>,
    flags: BTreeMap<String, Option<Help>>,
}

/// What a `--help` lists: the options, and the subcommands when it has some.
struct Help {
    flags: BTreeSet<String>,
    subcommands: BTreeSet<String>,
}

impl Cli {
    fn new() -> Cli {
        let top = help(&[]).expect("`swarmshot --help` runs");
        Cli {
            subcommands: top.subcommands,
            flags: BTreeMap::new(),
        }
    }

    fn help(&mut self, command: &str) -> Option<&Help> {
        self.flags
            .entry(command.to_string())
            .or_insert_with(|| help(&command.split(' ').collect::<Vec<_>>()))
            .as_ref()
    }
}

fn help(command: &[&str]) -> Option<Help> {
    let out = Command::new(BIN)
        .args(command)
        .arg("--help")
        .output()
        .ok()?;
    if !out.status.success() {
        return None;
    }
    let text = String::from_utf8_lossy(&out.stdout);
    Some(Help {
        flags: help_flags(&text),
        subcommands: help_subcommands(&text),
    })
}

/// The long options of clap's help: lines that start (after indentation)
/// with `-x, --name` or `--name`.
fn help_flags(text: &str) -> BTreeSet<String> {
    text.lines()
        .map(str::trim_start)
        .filter(|l| l.starts_with('-'))
        .flat_map(|l| l.split([' ', ',']).take(3))
        .filter_map(|w| w.strip_prefix("--"))
        .map(str::to_string)
        .collect()
}

/// The names under clap's `Commands:` heading.
fn help_subcommands(text: &str) -> BTreeSet<String> {
    text.lines()
        .skip_while(|l| !l.starts_with("Commands:"))
        .skip(1)
        .take_while(|l| l.starts_with(' '))
        .filter_map(|l| l.split_whitespace().next())
        .map(str::to_string)
        .collect()
}

/// The `swarmshot` commands a code text runs: every `swarmshot` word (or
/// `target/release/swarmshot`, `'swarmshot` opening a quoted command) with
/// the words that follow it up to the command's end.
fn commands(text: &str) -> Vec<Vec<&str>> {
    let words: Vec<&str> = text.split_whitespace().collect();
    let mut out = Vec::new();
    for (i, word) in words.iter().enumerate() {
        if word.starts_with('#') {
            break;
        }
        let bare = word.trim_start_matches(['\'', '"', '(']);
        if bare == "swarmshot" || bare.ends_with("/swarmshot") {
            let quote = word.chars().next().filter(|c| ['\'', '"'].contains(c));
            out.push(command_words(&words[i + 1..], quote));
        }
    }
    out
}

/// A command's words up to its end: a `#` comment or a shell operator, or
/// the word that closes the quote the command opened in.
fn command_words<'a>(words: &[&'a str], quote: Option<char>) -> Vec<&'a str> {
    let mut out = Vec::new();
    for word in words {
        if word.starts_with('#') || ["&&", "||", ";", "|", ">", "2>&1", ":::"].contains(word) {
            break;
        }
        let closes = quote.is_some_and(|q| word.ends_with(q) && !word.starts_with(q));
        out.push(word.trim_end_matches(['\'', '"', ';']));
        if closes || word.ends_with(';') {
            break;
        }
    }
    out
}

/// Why a documented command is not one the CLI has, if it is not.
fn check_command(cli: &mut Cli, words: &[&str]) -> Vec<String> {
    let Some(&first) = words.first() else {
        return Vec::new();
    };
    if first.starts_with('-') {
        // `swarmshot --help`, `--version`: top-level flags.
        return Vec::new();
    }
    if !cli.subcommands.contains(first) {
        return vec![format!("`swarmshot {first}`: no such subcommand")];
    }
    let mut command = first.to_string();
    let mut rest = &words[1..];
    let nested = cli
        .help(&command)
        .map(|h| h.subcommands.clone())
        .unwrap_or_default();
    if let Some((&second, tail)) = rest.split_first() {
        if nested.contains(second) {
            command = format!("{command} {second}");
            rest = tail;
        } else if !nested.is_empty() {
            return vec![format!(
                "`swarmshot {command} {second}`: no such subcommand"
            )];
        }
    }
    let Some(help) = cli.help(&command) else {
        return vec![format!("`swarmshot {command} --help` fails")];
    };
    let known = help.flags.clone();
    rest.iter()
        .filter_map(|w| w.strip_prefix("--"))
        .map(|f| f.split('=').next().unwrap_or(f))
        .filter(|f| !f.is_empty() && !known.contains(*f))
        .map(|f| format!("`swarmshot {command} --{f}`: no such flag"))
        .collect()
}

/// Whether a line's code may hold commands: every line of a shell code block
/// (and a `$ ` line of a text block); in prose, the backticked spans that
/// open with `swarmshot` are taken instead.
fn is_shell_line(line: &Line) -> bool {
    match line.block.as_deref() {
        Some("text") => line.text.starts_with("$ "),
        Some(lang) => SHELL_BLOCKS.contains(&lang),
        None => false,
    }
}

/// The texts that may hold commands, each with its first line: shell lines
/// joined across `\\` continuations, and the prose spans `holds` accepts.
fn command_texts(doc: &Doc, holds: fn(&str) -> bool) -> Vec<(&Line, String)> {
    let mut out: Vec<(&Line, String)> = Vec::new();
    let mut continued = false;
    for line in &doc.lines {
        if is_shell_line(line) {
            let text = line.text.trim_end();
            let body = text.strip_suffix('\\').unwrap_or(text).to_string();
            match out.last_mut() {
                Some((_, open)) if continued => open.push_str(&format!(" {body}")),
                _ => out.push((line, body)),
            }
            continued = text.ends_with('\\');
            continue;
        }
        continued = false;
        let spans = code_spans(&line.text).into_iter().filter(|s| holds(s));
        out.extend(spans.map(|s| (line, s.to_string())));
    }
    out
}

fn opens_with_swarmshot(span: &str) -> bool {
    let span = span.trim_start().trim_start_matches("$ ");
    let first = span.split_whitespace().next().unwrap_or("");
    first == "swarmshot" || first.ends_with("/swarmshot")
}

fn check_commands(cli: &mut Cli, doc: &Doc) -> Vec<String> {
    let mut failures = Vec::new();
    for (line, text) in command_texts(doc, opens_with_swarmshot) {
        for command in commands(&text) {
            for what in check_command(cli, &command) {
                failures.push(doc.at(line, what));
            }
        }
    }
    failures
}

// ------------------------------------------------------------ cargo test

/// `cargo test` options that take a value.
const CARGO_VALUE_FLAGS: [&str; 9] = [
    "--test",
    "--features",
    "-F",
    "-p",
    "--package",
    "--test-threads",
    "--skip",
    "-j",
    "--jobs",
];

fn has_cargo_test(span: &str) -> bool {
    span.contains("cargo test")
}

/// The words after each `cargo test` of a code text, up to the command's end.
fn cargo_tests(text: &str) -> Vec<Vec<&str>> {
    let words: Vec<&str> = text.split_whitespace().collect();
    (0..words.len().saturating_sub(1))
        .take_while(|&i| !words[i].starts_with('#'))
        .filter(|&i| words[i] == "cargo" && words[i + 1] == "test")
        .map(|i| command_words(&words[i + 2..], None))
        .collect()
}

/// The test target (`--test NAME`) and the name filters of a `cargo test`.
fn target_and_filters<'a>(words: &[&'a str]) -> (Option<&'a str>, Vec<&'a str>) {
    let (mut target, mut filters) = (None, Vec::new());
    let mut rest = words.iter();
    while let Some(&word) = rest.next() {
        if CARGO_VALUE_FLAGS.contains(&word) {
            let value = rest.next().copied();
            if word == "--test" {
                target = value;
            }
        } else if !word.starts_with('-') {
            filters.push(word);
        }
    }
    (target, filters)
}

/// Why a `cargo test` does not run what it names, if it does not: `--test
/// NAME` must be tests/NAME.rs or tests/NAME/main.rs, and a filter of the
/// suite part of a test's path (`gui::docs_screenshot` of
/// `gui::docs_screenshot_of_the_quickstart`).
fn check_cargo_test(root: &Path, code: &Code, words: &[&str]) -> Vec<String> {
    let (target, filters) = target_and_filters(words);
    let Some(target) = target else {
        return Vec::new();
    };
    let tests = Path::new("tests");
    let exists = root.join(tests.join(target).with_extension("rs")).exists()
        || root.join(tests.join(target).join("main.rs")).exists();
    if !exists {
        return vec![format!(
            "`cargo test --test {target}`: no tests/{target}.rs or tests/{target}/main.rs"
        )];
    }
    if target != "suite" {
        return Vec::new();
    }
    let paths = code.suite_fns();
    filters
        .into_iter()
        .filter(|f| !paths.iter().any(|p| p.contains(f)))
        .map(|f| {
            format!("`cargo test --test suite {f}`: no test of the suite has `{f}` in its path")
        })
        .collect()
}

fn check_cargo_tests(root: &Path, code: &Code, doc: &Doc) -> Vec<String> {
    let mut failures = Vec::new();
    for (line, text) in command_texts(doc, has_cargo_test) {
        for command in cargo_tests(&text) {
            for what in check_cargo_test(root, code, &command) {
                failures.push(doc.at(line, what));
            }
        }
    }
    failures
}

// ------------------------------------------------------------ the test

fn root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

/// Every rule on one doc; its failures, one a line.
fn lies_in(root: &Path, docs: &[Doc], doc: &Doc, code: &Code, cli: &mut Cli) -> Vec<String> {
    let mut failures = check_links(root, docs, doc);
    failures.extend(check_sections(docs, doc));
    failures.extend(check_paths(root, doc));
    failures.extend(check_examples(root, doc));
    failures.extend(check_tests(code, doc));
    failures.extend(check_items(code, doc));
    failures.extend(check_commands(cli, doc));
    failures.extend(check_cargo_tests(root, code, doc));
    failures
}

#[test]
fn the_docs_name_only_what_exists() {
    let root = root();
    let (docs, code, mut cli) = (docs(&root), Code::read(&root), Cli::new());
    let failures: Vec<String> = docs
        .iter()
        .flat_map(|doc| lies_in(&root, &docs, doc, &code, &mut cli))
        .collect();
    assert!(
        failures.is_empty(),
        "the docs name {} thing(s) the repository does not have:\n{}",
        failures.len(),
        failures.join("\n")
    );
}

/// One lie of each kind, each on its own line, after one honest line of each
/// kind: the rules must catch every lie (by its line) and pass the truth.
const PLANTED: &str = r#"# Planted
[Conventions](conventions.md#camera), `src/cli/args.rs:12`, `presets/sim2real/*.ron`, `OUT/rounds/NN/`, docs/reliability.md, "Durability".
Test: `the_docs_name_only_what_exists`, `docs_truth::the_docs_name_only_what_exists`, `swarmshot::gap::run_report`.
`swarmshot batch presets/quickstart.ron --out DIR --limit 2`, `swarmshot bench accuracy --frames 2`, `cargo test --test suite docs_truth:: -- --nocapture`, `cargo run --release --example preview_bench`
[gone](no-such.md)
[moved](conventions.md#no-such-heading)
see docs/realism.md, "No such section"
`src/no_such_file.rs`
Test: `no_such_test_was_ever_written`.
`docs_truth::no_such_test_in_this_file`
`swarmshot::no_such_module::f`, `text::no_such_item`
`swarmshot batch presets/quickstart.ron --out DIR --no-such-flag`
```sh
swarmshot no-such-command x
swarmshot bench no-such-bench
cargo test --test suite no_such_module::
cargo test --test no_such_target
target/release/examples/no_such_bench presets/quickstart.ron
```
"#;

#[test]
fn a_planted_lie_of_each_kind_is_caught_by_its_line() {
    let root = root();
    let planted = Doc {
        path: PathBuf::from("docs/planted.md"),
        lines: lines(PLANTED),
    };
    let mut docs = docs(&root);
    docs.push(Doc {
        path: planted.path.clone(),
        lines: lines(PLANTED),
    });
    let failures = lies_in(&root, &docs, &planted, &Code::read(&root), &mut Cli::new());
    let expected = [
        (5, "no-such.md"),
        (6, "#no-such-heading"),
        (7, "\"No such section\""),
        (8, "src/no_such_file.rs"),
        (9, "no_such_test_was_ever_written"),
        (10, "no_such_test_in_this_file"),
        (11, "no module `no_such_module`"),
        (11, "no `no_such_item`"),
        (12, "--no-such-flag"),
        (14, "swarmshot no-such-command"),
        (15, "swarmshot bench no-such-bench"),
        (16, "no_such_module::"),
        (17, "--test no_such_target"),
        (18, "example `no_such_bench`"),
    ];
    for (line, what) in expected {
        let at = format!("docs/planted.md:{line}: ");
        assert!(
            failures
                .iter()
                .any(|f| f.starts_with(&at) && f.contains(what)),
            "line {line}'s lie ({what}) was not caught; caught:\n{}",
            failures.join("\n")
        );
    }
    assert_eq!(
        failures.len(),
        expected.len(),
        "the honest lines 1 to 4 must pass; caught:\n{}",
        failures.join("\n")
    );
}
