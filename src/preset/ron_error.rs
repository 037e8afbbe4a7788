//! RON parse errors a user can act on: an unknown field or variant is named
//! with its path in the preset (`camera`, `output.label_formats[1]`) and the
//! nearest known name ("did you mean `fov_y_deg`?"). The path is the one the
//! deserializer followed, tracked by `serde_path_to_error`; the line and
//! column are RON's own span of the error.

use serde_path_to_error::{Path, Segment};

/// A preset's RON that does not parse: where (1-based line and column) and
/// what is wrong there.
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
#[error("{line}:{col}: {reason}")]
pub struct RonError {
    pub line: usize,
    pub col: usize,
    /// What is wrong, and for unknown names the field path and the nearest known name.
    pub reason: String,
}

/// Parse `text` as a `T` with `options` (as [`ron::Options::from_str`]
/// does), an error naming the field path the deserializer was in.
pub(super) fn from_str<'a, T: serde::Deserialize<'a>>(
    text: &'a str,
    options: &ron::Options,
) -> Result<T, RonError> {
    let mut de = ron::Deserializer::from_str_with_options(text, options)
        .map_err(|e| describe(text, &e, &[]))?;
    let value = serde_path_to_error::deserialize(&mut de).map_err(|e| {
        let path = e.path().clone();
        describe(text, &de.span_error(e.into_inner()), &fields(&path))
    })?;
    de.end()
        .map_err(|e| describe(text, &de.span_error(e), &[]))?;
    Ok(value)
}

/// The path's fields and list indices; an enum's variant is not a field of
/// the preset (`placement.count`, not `placement.Randomized.count`).
fn fields(path: &Path) -> Vec<&Segment> {
    path.iter()
        .filter(|s| !matches!(s, Segment::Enum { .. }))
        .collect()
}

/// `camera.fov_y_deg`, `output.label_formats[1]`.
fn dotted(path: &[&Segment]) -> String {
    let mut out = String::new();
    for segment in path {
        match segment {
            Segment::Seq { index } => out.push_str(&format!("[{index}]")),
            Segment::Map { key } => {
                if !out.is_empty() {
                    out.push('.');
                }
                out.push_str(key);
            }
            Segment::Enum { .. } | Segment::Unknown => {}
        }
    }
    out
}

/// The error for a RON parse error of `text` at field `path`: its position,
/// what is wrong, and for unknown names the field path and the nearest known name.
fn describe(text: &str, e: &ron::error::SpannedError, path: &[&Segment]) -> RonError {
    let at = &e.span.start;
    RonError {
        line: at.line,
        col: at.col,
        reason: reason(text, e, path),
    }
}

fn reason(text: &str, e: &ron::error::SpannedError, path: &[&Segment]) -> String {
    use ron::error::Error;
    let at = &e.span.start;
    match &e.code {
        Error::NoSuchStructField {
            expected, found, ..
        } => {
            // The path ends at the unknown key itself: name the struct it is in.
            let path = match path.split_last() {
                Some((Segment::Map { key }, parent)) if key == found => dotted(parent),
                _ => dotted(path),
            };
            let place = if path.is_empty() {
                "the preset".to_string()
            } else {
                format!("`{path}`")
            };
            format!(
                "unknown field `{found}` in {place}{}",
                suggestion(found, expected, "fields")
            )
        }
        Error::NoSuchEnumVariant {
            expected, found, ..
        } => {
            let path = dotted(path);
            let place = if path.is_empty() {
                String::new()
            } else {
                format!(" for `{path}`")
            };
            format!(
                "unknown variant `{found}`{place}{}",
                suggestion(found, expected, "variants")
            )
        }
        // `Custom(1920, 1080)` where the fields are named: RON asks for a raw identifier.
        Error::SuggestRawIdentifier(found) if !found.starts_with(char::is_alphabetic) => {
            let place = match dotted(path) {
                path if path.is_empty() => String::new(),
                path => format!(" in `{path}`"),
            };
            format!(
                "`{}`{place} where a field's name goes: this value's fields are written by name, `name: value` (e.g. `Custom(width: 1920, height: 1080)`)",
                crate::text::printable(found)
            )
        }
        Error::ExceededRecursionLimit => {
            // The path is as deep as the nesting: its first field is enough.
            let place = match path.first() {
                Some(Segment::Map { key }) => format!(" in `{key}`"),
                _ => String::new(),
            };
            let limit = ron::Options::default().recursion_limit.unwrap_or(128);
            format!(
                "the preset nests deeper than {limit} levels of brackets{place} (values inside values, e.g. a `Random` sky among a `Random` sky's choices); nest it less deeply"
            )
        }
        _ => match fraction_at(text, at.line, at.col) {
            // `1.5` where an integer goes: RON stops after `1` and asks for a comma.
            Some((start, number)) => {
                let path = value_path(path, &text[..start]);
                let place = if path.is_empty() {
                    String::new()
                } else {
                    format!(" in `{path}`")
                };
                format!(
                    "`{}`{place}: an integer (a whole number) was expected",
                    crate::text::printable(&number)
                )
            }
            None => {
                let what = crate::text::shorten_digit_runs(&e.code.to_string());
                match dotted(path) {
                    path if path.is_empty() => what,
                    path => format!("`{path}`: {what}"),
                }
            }
        },
    }
}

/// The path of a value that parsed but was followed by what does not
/// belong there (`before`: the text up to it). A struct asks for its next
/// field only after the value, so the path ends in an unknown key
/// ([`Segment::Unknown`]): the value's field is the key written before it.
fn value_path(path: &[&Segment], before: &str) -> String {
    let Some((Segment::Unknown, parent)) = path.split_last() else {
        return dotted(path);
    };
    let key = before.trim_end().strip_suffix(':').map(|b| {
        let b = b.trim_end();
        let start = b
            .rfind(|c: char| !(c.is_ascii_alphanumeric() || c == '_'))
            .map_or(0, |i| i + 1);
        &b[start..]
    });
    let mut out = dotted(parent);
    if let Some(key) = key.filter(|k| !k.is_empty()) {
        if !out.is_empty() {
            out.push('.');
        }
        out.push_str(key);
    }
    out
}

/// The number with a fractional part or exponent whose `.`/`e` is at
/// (line, col), if that is where the parser stopped, and where it starts.
fn fraction_at(text: &str, line: usize, col: usize) -> Option<(usize, String)> {
    let at = byte_offset(text, line, col);
    let rest = text.get(at..)?;
    if !(rest.starts_with('.') || rest.starts_with('e') || rest.starts_with('E')) {
        return None;
    }
    let before = &text[..at];
    let start = before
        .char_indices()
        .rev()
        .find(|&(_, c)| !(c.is_ascii_digit() || c == '-' || c == '+'))
        .map_or(0, |(i, c)| i + c.len_utf8());
    if start == at || !before[start..].chars().any(|c| c.is_ascii_digit()) {
        return None;
    }
    let end = rest
        .find(|c: char| !(c.is_ascii_alphanumeric() || matches!(c, '.' | '-' | '+' | '_')))
        .map_or(text.len(), |i| at + i);
    let number = &text[start..end];
    const MAX_CHARS: usize = 24;
    let shown = if number.chars().count() > MAX_CHARS {
        format!("{}…", number.chars().take(MAX_CHARS).collect::<String>())
    } else {
        number.to_string()
    };
    Some((start, shown))
}

/// "; did you mean `x`? (known fields: a, b, c)", or only the known list.
fn suggestion(found: &str, expected: &[&str], what: &str) -> String {
    let nearest = expected
        .iter()
        .map(|name| {
            let d = strsim::levenshtein(&found.to_lowercase(), &name.to_lowercase());
            (d, *name)
        })
        .min_by_key(|(d, _)| *d)
        .filter(|(d, name)| *d <= 2.max(found.len().max(name.len()) / 3));
    let known = expected.join(", ");
    match nearest {
        Some((_, name)) => format!("; did you mean `{name}`? (known {what}: {known})"),
        None if expected.is_empty() => String::new(),
        None => format!(" (known {what}: {known})"),
    }
}

/// Byte offset of (line, col), both 1-based, col counted in characters.
fn byte_offset(text: &str, line: usize, col: usize) -> usize {
    let mut offset = 0;
    for (n, l) in text.split_inclusive('\n').enumerate() {
        if n + 1 == line {
            return offset
                + l.char_indices()
                    .nth(col.saturating_sub(1))
                    .map_or(l.len(), |(i, _)| i);
        }
        offset += l.len();
    }
    text.len()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_preset_nested_too_deeply_says_so_in_its_terms() {
        let depth = 100;
        let sky = "Random(choices: [".repeat(depth) + "Gradient" + &"])".repeat(depth);
        let e = crate::preset::Preset::from_ron(&format!("(sky: {sky})")).expect_err("too deep");
        assert!(
            e.reason
                .starts_with("the preset nests deeper than 128 levels of brackets in `sky`"),
            "{e}"
        );
        assert!(!e.reason.contains("recursion_limit"), "{e}");
    }

    #[test]
    fn paths_name_fields_and_list_indices_but_not_variants() {
        use crate::preset::Preset;
        let e = Preset::from_ron("(\n  camera: (x: (start: 1.0), fovy_deg: 2.0),\n)")
            .expect_err("unknown field");
        assert_eq!((e.line, e.col), (2, 29), "{e}");
        assert!(
            e.reason
                .starts_with("unknown field `fovy_deg` in `camera`;"),
            "{e}"
        );
        let e = Preset::from_ron("(output: (label_formats: [Yolo, Cocoa]))").expect_err("variant");
        assert!(e.reason.contains(" for `output.label_formats[1]`;"), "{e}");
        let e = Preset::from_ron("(placement: Randomized(count: (1, 3), spacing_m: 1.0))")
            .expect_err("field of a variant");
        assert!(e.reason.contains(" in `placement`"), "{e}");
        // A value of the wrong type names its field; a fraction after a field, that field.
        let e = Preset::from_ron("(camera: (fov_y_deg: \"wide\"))").expect_err("a string");
        assert_eq!(e.reason, "`camera.fov_y_deg`: Expected float");
        let e = Preset::from_ron("(render: (msaa: 2.5))").expect_err("a fraction");
        assert!(
            e.reason.starts_with("`2.5` in `render.msaa`: an integer"),
            "{e}"
        );
    }

    #[test]
    fn suggestion_names_the_nearest_field_only_when_close() {
        assert!(suggestion("fovy_deg", &["x", "fov_y_deg"], "fields").contains("`fov_y_deg`"));
        assert!(!suggestion("banana", &["x", "fov_y_deg"], "fields").contains("did you mean"));
    }
}
