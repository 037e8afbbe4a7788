//! Saving a preset into the text it was opened from: comments, field order and
//! layout stay as they are; only the values that changed are rewritten.
//!
//! Three texts are compared: the file's own (`base`, with its comments), the
//! preset it held written out fresh (`old`), and the edited preset written out
//! fresh (`new`). A field whose fresh text is the same in `old` and `new` keeps
//! the file's text; a changed struct is walked field by field; any other changed
//! value is replaced by its fresh text, indented as the file's; fields that
//! appeared are added at the end of their struct, fields that went are removed.
//! The result is read back and must give the edited preset exactly, or the
//! preset is written fresh under the file's leading comments.

use std::ops::Range;

use crate::preset::Preset;

/// The first line of a preset written without a file to follow.
const FRESH_HEADER: &str = "// swarmshot preset (RON), written by the swarmshot app\n";

/// The text to save `new` as; `base` is the text of the file it came from, if any.
pub fn save_text(base: Option<&str>, new: &Preset) -> String {
    let Some(base) = base else {
        return format!("{FRESH_HEADER}{}\n", new.to_ron());
    };
    let Ok(old) = Preset::from_ron(base) else {
        return fresh_under_header(base, new);
    };
    if &old == new {
        return base.to_owned();
    }
    match edited_text(base, &old, new) {
        Some(text) if Preset::from_ron(&text).ok().as_ref() == Some(new) => text,
        _ => fresh_under_header(base, new),
    }
}

/// `new` written fresh, under the comment lines `base` starts with.
fn fresh_under_header(base: &str, new: &Preset) -> String {
    let header: String = base
        .lines()
        .take_while(|l| l.trim().is_empty() || l.trim_start().starts_with("//"))
        .filter(|l| !l.trim().is_empty())
        .map(|l| format!("{l}\n"))
        .collect();
    let header = if header.is_empty() {
        FRESH_HEADER.to_owned()
    } else {
        header
    };
    format!("{header}{}\n", new.to_ron())
}

/// `base` with the edits that turn `old` into `new`; None when a text cannot be read.
fn edited_text(base: &str, old: &Preset, new: &Preset) -> Option<String> {
    let (old_text, new_text) = (old.to_ron(), new.to_ron());
    let o = Parser::root(base)?;
    let a = Parser::root(&old_text)?;
    let b = Parser::root(&new_text)?;
    let mut merge = Merge {
        base,
        old: &old_text,
        new: &new_text,
        edits: Vec::new(),
    };
    merge.node(&o, Some(&a), &b);
    let mut edits = merge.edits;
    edits.sort_by_key(|e| (e.range.start, e.range.end));
    // Later edits first, so earlier positions stay valid; overlapping edits give up.
    let mut text = base.to_owned();
    let mut limit = usize::MAX;
    for edit in edits.iter().rev() {
        if edit.range.end > limit {
            return None;
        }
        text.replace_range(edit.range.clone(), &edit.text);
        limit = edit.range.start;
    }
    Some(text)
}

struct Edit {
    range: Range<usize>,
    text: String,
}

struct Merge<'a> {
    base: &'a str,
    old: &'a str,
    new: &'a str,
    edits: Vec<Edit>,
}

impl Merge<'_> {
    /// Edits making `o` (in the file) say what `b` (in the new text) says; `a` is
    /// the same place in the old text, when it has one.
    fn node(&mut self, o: &Node, a: Option<&Node>, b: &Node) {
        if let Some(a) = a
            && self.old[a.span()] == self.new[b.span()]
        {
            return;
        }
        match (o, b) {
            (Node::Some(o_inner, _), Node::Some(b_inner, _)) => {
                let a = a.and_then(|a| match a {
                    Node::Some(inner, _) => Some(&**inner),
                    _ => None,
                });
                return self.node(o_inner, a, b_inner);
            }
            // The file leaves `Some` out (implicit_some): so does the edit.
            (o, Node::Some(b_inner, _)) if !matches!(o, Node::Some(..)) => {
                let a = a.map(|a| match a {
                    Node::Some(inner, _) => &**inner,
                    a => a,
                });
                return self.node(o, a, b_inner);
            }
            (Node::Struct(os), Node::Struct(bs))
                if os.name == bs.name || (bs.name.is_none() && os.name.is_some()) =>
            {
                let a = a.and_then(|a| match a {
                    Node::Struct(s) if s.name == bs.name => Some(s),
                    _ => None,
                });
                return self.fields(os, a, bs);
            }
            _ => {}
        }
        let text = reindent(self.new, b.span(), self.base, o.span().start);
        self.edits.push(Edit {
            range: o.span(),
            text,
        });
    }

    fn fields(&mut self, o: &Struct, a: Option<&Struct>, b: &Struct) {
        let mut last_kept = None;
        for field in &o.fields {
            let af = a.and_then(|a| a.field(&field.name));
            match b.field(&field.name) {
                Some(bf) => {
                    self.node(&field.value, af.map(|f| &f.value), &bf.value);
                    last_kept = Some(field);
                }
                // Written before and not now: it went (an option switched off).
                None if af.is_some() => self.remove(field),
                // Not written either time (the file spells out a default): kept.
                None => last_kept = Some(field),
            }
        }
        let added: Vec<&Field> = b
            .fields
            .iter()
            .filter(|f| o.field(&f.name).is_none())
            // Left out of the file and the same as before: still its default.
            .filter(|f| {
                let before = a.and_then(|a| a.field(&f.name));
                before.is_none_or(|af| self.old[af.value.span()] != self.new[f.value.span()])
            })
            .collect();
        if added.is_empty() {
            return;
        }
        let multi_line = self.base[o.open..o.close].contains('\n');
        let indent = match last_kept.or(o.fields.first()) {
            Some(f) => line_indent(self.base, f.start).to_owned(),
            None => format!("{}    ", line_indent(self.base, o.close)),
        };
        let mut text = String::new();
        for (i, f) in added.iter().enumerate() {
            let value = reindent_to(self.new, f.value.span(), &indent);
            let separator = match (multi_line, last_kept.is_some() || i > 0) {
                (true, true) => format!(",\n{indent}"),
                (true, false) => format!("\n{indent}"),
                (false, true) => ", ".to_owned(),
                (false, false) => String::new(),
            };
            text.push_str(&format!("{separator}{}: {value}", f.name));
        }
        let at = match last_kept {
            Some(f) => f.value.span().end,
            None => {
                if multi_line {
                    text.push(',');
                }
                o.open + 1
            }
        };
        self.edits.push(Edit {
            range: at..at,
            text,
        });
    }

    /// Remove a field, its comma and, when it has its line to itself, the line.
    fn remove(&mut self, field: &Field) {
        let base = self.base.as_bytes();
        let mut end = field.comma.map_or(field.value.span().end, |c| c + 1);
        let line_start = self.base[..field.start].rfind('\n').map_or(0, |i| i + 1);
        let own_line = self.base[line_start..field.start].trim().is_empty();
        let start = if own_line { line_start } else { field.start };
        if own_line {
            let rest_end = self.base[end..].find('\n').map_or(base.len(), |i| end + i);
            let rest = self.base[end..rest_end].trim();
            if rest.is_empty() || rest.starts_with("//") {
                end = (rest_end + 1).min(base.len());
            }
        }
        self.edits.push(Edit {
            range: start..end,
            text: String::new(),
        });
    }
}

/// The spaces before the text on the line holding `at`.
fn line_indent(text: &str, at: usize) -> &str {
    let line_start = text[..at].rfind('\n').map_or(0, |i| i + 1);
    let line = &text[line_start..];
    &line[..line.len() - line.trim_start().len()]
}

/// `src[span]` with its later lines moved from the indent of its own line in
/// `src` to that of the line holding `at` in `dst`.
fn reindent(src: &str, span: Range<usize>, dst: &str, at: usize) -> String {
    reindent_to(src, span, line_indent(dst, at))
}

fn reindent_to(src: &str, span: Range<usize>, indent: &str) -> String {
    let from = line_indent(src, span.start).len();
    let mut out = String::new();
    for (i, line) in src[span].split('\n').enumerate() {
        if i > 0 {
            out.push('\n');
            let spaces = line.len() - line.trim_start_matches(' ').len();
            out.push_str(indent);
            out.push_str(&line[spaces.min(from)..]);
        } else {
            out.push_str(line);
        }
    }
    out
}

/// A RON value found in a text, by its byte range.
#[derive(Debug)]
enum Node {
    /// `(name: value, …)` or `Name(name: value, …)`.
    Struct(Struct),
    /// `Some(value)`.
    Some(Box<Node>, Range<usize>),
    /// Anything else: a number, a string, a list, a tuple, a map.
    Other(Range<usize>),
}

impl Node {
    fn span(&self) -> Range<usize> {
        match self {
            Node::Struct(s) => s.span.clone(),
            Node::Some(_, span) | Node::Other(span) => span.clone(),
        }
    }
}

#[derive(Debug)]
struct Struct {
    span: Range<usize>,
    name: Option<String>,
    /// The byte offsets of `(` and `)`.
    open: usize,
    close: usize,
    fields: Vec<Field>,
}

impl Struct {
    fn field(&self, name: &str) -> Option<&Field> {
        self.fields.iter().find(|f| f.name == name)
    }
}

#[derive(Debug)]
struct Field {
    name: String,
    /// Where its name starts.
    start: usize,
    value: Node,
    /// The byte offset of the comma after it, if any.
    comma: Option<usize>,
}

/// A reader of RON's structure (not its values): enough to find fields and spans.
struct Parser<'a> {
    s: &'a [u8],
    pos: usize,
}

fn is_ident_start(c: u8) -> bool {
    c.is_ascii_alphabetic() || c == b'_'
}

fn is_ident(c: u8) -> bool {
    c.is_ascii_alphanumeric() || c == b'_'
}

impl<'a> Parser<'a> {
    /// The top-level value of a RON document (after any `#![…]` attributes).
    fn root(text: &'a str) -> Option<Node> {
        let text_start = text.len() - text.trim_start_matches('\u{feff}').len();
        let mut p = Parser {
            s: text.as_bytes(),
            pos: text_start,
        };
        loop {
            p.trivia();
            if p.peek() == Some(b'#') {
                p.pos += 1;
                if p.peek() == Some(b'!') {
                    p.pos += 1;
                }
                p.trivia();
                if p.peek() != Some(b'[') {
                    return None;
                }
                p.balanced()?;
            } else {
                break;
            }
        }
        p.value()
    }

    fn peek(&self) -> Option<u8> {
        self.s.get(self.pos).copied()
    }

    fn at(&self, i: usize) -> Option<u8> {
        self.s.get(self.pos + i).copied()
    }

    /// Skip white space and comments (`//` and nested `/* */`).
    fn trivia(&mut self) {
        loop {
            match (self.peek(), self.at(1)) {
                (Some(c), _) if c.is_ascii_whitespace() => self.pos += 1,
                (Some(b'/'), Some(b'/')) => {
                    while self.peek().is_some_and(|c| c != b'\n') {
                        self.pos += 1;
                    }
                }
                (Some(b'/'), Some(b'*')) => {
                    self.pos += 2;
                    let mut depth = 1;
                    while depth > 0 {
                        match (self.peek(), self.at(1)) {
                            (None, _) => return,
                            (Some(b'/'), Some(b'*')) => {
                                depth += 1;
                                self.pos += 2;
                            }
                            (Some(b'*'), Some(b'/')) => {
                                depth -= 1;
                                self.pos += 2;
                            }
                            _ => self.pos += 1,
                        }
                    }
                }
                _ => return,
            }
        }
    }

    fn ident(&mut self) -> Option<&'a str> {
        let start = self.pos;
        if !self.peek().is_some_and(is_ident_start) {
            return None;
        }
        while self.peek().is_some_and(is_ident) {
            self.pos += 1;
        }
        std::str::from_utf8(&self.s[start..self.pos]).ok()
    }

    /// Skip a string, raw string or char literal starting here.
    fn literal(&mut self) -> Option<()> {
        match self.peek()? {
            b'"' => {
                self.pos += 1;
                loop {
                    match self.peek()? {
                        b'\\' => self.pos += 2,
                        b'"' => {
                            self.pos += 1;
                            return Some(());
                        }
                        _ => self.pos += 1,
                    }
                }
            }
            b'\'' => {
                self.pos += 1;
                loop {
                    match self.peek()? {
                        b'\\' => self.pos += 2,
                        b'\'' => {
                            self.pos += 1;
                            return Some(());
                        }
                        _ => self.pos += 1,
                    }
                }
            }
            b'r' => {
                self.pos += 1;
                let mut hashes = 0;
                while self.peek() == Some(b'#') {
                    hashes += 1;
                    self.pos += 1;
                }
                if self.peek() != Some(b'"') {
                    return None;
                }
                self.pos += 1;
                loop {
                    if self.peek()? == b'"' && (1..=hashes).all(|i| self.at(i) == Some(b'#')) {
                        self.pos += 1 + hashes;
                        return Some(());
                    }
                    self.pos += 1;
                }
            }
            _ => None,
        }
    }

    /// Skip a bracketed group starting here, brackets, strings and comments inside.
    fn balanced(&mut self) -> Option<()> {
        let mut depth = 0usize;
        loop {
            match (self.peek()?, self.at(1)) {
                (b'(' | b'[' | b'{', _) => {
                    depth += 1;
                    self.pos += 1;
                }
                (b')' | b']' | b'}', _) => {
                    depth = depth.checked_sub(1)?;
                    self.pos += 1;
                    if depth == 0 {
                        return Some(());
                    }
                }
                (b'"' | b'\'', _) => self.literal()?,
                (b'r', Some(b'"' | b'#')) if self.pos == 0 || !is_ident(self.s[self.pos - 1]) => {
                    self.literal()?
                }
                (b'/', Some(b'/' | b'*')) => self.trivia(),
                _ => self.pos += 1,
            }
        }
    }

    fn value(&mut self) -> Option<Node> {
        self.trivia();
        let start = self.pos;
        match (self.peek()?, self.at(1)) {
            (b'(', _) => self.paren(None, start),
            (b'[' | b'{', _) => {
                self.balanced()?;
                Some(Node::Other(start..self.pos))
            }
            (b'"' | b'\'', _) | (b'r', Some(b'"' | b'#')) => {
                self.literal()?;
                Some(Node::Other(start..self.pos))
            }
            (b'b', Some(b'"')) => {
                self.pos += 1;
                self.literal()?;
                Some(Node::Other(start..self.pos))
            }
            (c, _) if is_ident_start(c) => {
                let name = self.ident()?;
                let end = self.pos;
                self.trivia();
                if self.peek() != Some(b'(') {
                    self.pos = end;
                    return Some(Node::Other(start..end));
                }
                if name == "Some" {
                    self.pos += 1;
                    let inner = self.value()?;
                    self.trivia();
                    if self.peek() != Some(b')') {
                        return None;
                    }
                    self.pos += 1;
                    return Some(Node::Some(Box::new(inner), start..self.pos));
                }
                self.paren(Some(name.to_owned()), start)
            }
            (c, _) if c.is_ascii_digit() || matches!(c, b'-' | b'+' | b'.') => {
                while self
                    .peek()
                    .is_some_and(|c| is_ident(c) || matches!(c, b'.' | b'-' | b'+'))
                {
                    self.pos += 1;
                }
                Some(Node::Other(start..self.pos))
            }
            _ => None,
        }
    }

    /// `(` at the cursor: a struct's fields, or a tuple (kept whole).
    fn paren(&mut self, name: Option<String>, start: usize) -> Option<Node> {
        let open = self.pos;
        self.pos += 1;
        self.trivia();
        let is_struct = self.peek() == Some(b')') || {
            let here = self.pos;
            let named = self.ident().is_some() && {
                self.trivia();
                self.peek() == Some(b':')
            };
            self.pos = here;
            named
        };
        if !is_struct {
            self.pos = open;
            self.balanced()?;
            return Some(Node::Other(start..self.pos));
        }
        let mut fields = Vec::new();
        loop {
            self.trivia();
            if self.peek()? == b')' {
                let close = self.pos;
                self.pos += 1;
                return Some(Node::Struct(Struct {
                    span: start..self.pos,
                    name,
                    open,
                    close,
                    fields,
                }));
            }
            let field_start = self.pos;
            let field_name = self.ident()?.to_owned();
            self.trivia();
            if self.peek()? != b':' {
                return None;
            }
            self.pos += 1;
            let value = self.value()?;
            let after = self.pos;
            self.trivia();
            let comma = (self.peek() == Some(b',')).then(|| {
                self.pos += 1;
                self.pos - 1
            });
            if comma.is_none() {
                self.pos = after;
            }
            fields.push(Field {
                name: field_name,
                start: field_start,
                value,
                comma,
            });
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const BASE: &str = "// header one\n// header two\n(\n    name: \"grid\",\n    seed: 7, // the seed\n    // the camera\n    camera: (z: (start: 1.0, end: 1.0, step: 0.0)),\n)\n";

    fn base() -> Preset {
        Preset::from_ron(BASE).unwrap_or_else(|e| panic!("{e}"))
    }

    #[test]
    fn an_unchanged_preset_keeps_its_text() {
        assert_eq!(save_text(Some(BASE), &base()), BASE);
    }

    #[test]
    fn a_changed_value_is_rewritten_in_place() {
        let mut p = base();
        p.seed = 99;
        p.camera.z.start = 2.5;
        let text = save_text(Some(BASE), &p);
        assert!(
            text.starts_with("// header one\n// header two\n("),
            "{text}"
        );
        assert!(text.contains("seed: 99, // the seed"), "{text}");
        assert!(text.contains("    // the camera\n"), "{text}");
        assert!(text.contains("start: 2.5"), "{text}");
        assert_eq!(Preset::from_ron(&text).ok(), Some(p));
    }

    #[test]
    fn fields_come_and_go() {
        let mut p = base();
        p.atmosphere = Some(Default::default());
        let text = save_text(Some(BASE), &p);
        assert!(text.contains("// the seed"), "{text}");
        // Only the new field is written, not every default the file leaves out.
        assert!(!text.contains("attitude"), "{text}");
        assert_eq!(Preset::from_ron(&text).ok(), Some(p.clone()));
        p.atmosphere = None;
        let back = save_text(Some(&text), &p);
        assert!(!back.contains("atmosphere"), "{back}");
        assert!(back.contains("// the seed"), "{back}");
        assert_eq!(Preset::from_ron(&back).ok(), Some(p));
    }

    #[test]
    fn every_shipped_preset_keeps_its_comments_through_an_edit() {
        let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("presets");
        let Ok(entries) = std::fs::read_dir(&dir) else {
            return;
        };
        for path in entries.filter_map(|e| e.ok().map(|e| e.path())) {
            if path.extension().is_none_or(|x| x != "ron") {
                continue;
            }
            let Ok(text) = std::fs::read_to_string(&path) else {
                continue;
            };
            let Ok(mut p) = Preset::from_ron(&text) else {
                continue;
            };
            p.seed = p.seed.wrapping_add(1);
            p.name = format!("{} edited", p.name);
            let saved = save_text(Some(&text), &p);
            assert_eq!(Preset::from_ron(&saved).ok(), Some(p), "{}", path.display());
            let comments = |t: &str| t.lines().filter(|l| l.contains("//")).count();
            assert_eq!(comments(&saved), comments(&text), "{}", path.display());
        }
    }
}
