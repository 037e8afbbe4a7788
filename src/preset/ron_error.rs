//! RON parse errors a user can act on: an unknown field or variant is named
//! with its path in the preset (`camera`, `output.label_formats[1]`) and the
//! nearest known name ("did you mean `fov_y_deg`?").

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

/// The error for a RON parse error of `text`: its position, what is wrong,
/// and for unknown names the field path and the nearest known name.
pub(super) fn describe(text: &str, e: &ron::error::SpannedError) -> RonError {
    let at = &e.span.start;
    RonError {
        line: at.line,
        col: at.col,
        reason: reason(text, e),
    }
}

fn reason(text: &str, e: &ron::error::SpannedError) -> String {
    use ron::error::Error;
    let at = &e.span.start;
    match &e.code {
        Error::NoSuchStructField {
            expected, found, ..
        } => {
            let path = field_path(text, at.line, at.col, false);
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
            let path = field_path(text, at.line, at.col, true);
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
        _ => match fraction_at(text, at.line, at.col) {
            // `1.5` where an integer goes: RON stops after `1` and asks for a comma.
            Some(number) => {
                let path = field_path(text, at.line, at.col, true);
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
            None => crate::text::shorten_digit_runs(&e.code.to_string()),
        },
    }
}

/// The number with a fractional part or exponent whose `.`/`e` is at
/// (line, col), if that is where the parser stopped.
fn fraction_at(text: &str, line: usize, col: usize) -> Option<String> {
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
    Some(if number.chars().count() > MAX_CHARS {
        format!("{}…", number.chars().take(MAX_CHARS).collect::<String>())
    } else {
        number.to_string()
    })
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

/// One open bracket while scanning: the label it is reached by (`camera`,
/// `[2]`), its kind, the field key last seen in it and its element index.
struct Frame {
    label: String,
    list: bool,
    key: Option<String>,
    index: usize,
}

/// The dotted path of the value open at (line, col) (1-based, in characters).
/// With `with_key`, the field whose value starts there is included (an enum
/// variant is the value of its field); without it, only the enclosing struct.
fn field_path(text: &str, line: usize, col: usize, with_key: bool) -> String {
    let end = byte_offset(text, line, col);
    let src = &text[..end];
    let bytes = src.as_bytes();
    let mut stack = vec![Frame {
        label: String::new(),
        list: false,
        key: None,
        index: 0,
    }];
    let mut i = 0;
    while i < bytes.len() {
        let c = bytes[i];
        match c {
            b'/' if bytes.get(i + 1) == Some(&b'/') => {
                while i < bytes.len() && bytes[i] != b'\n' {
                    i += 1;
                }
            }
            b'/' if bytes.get(i + 1) == Some(&b'*') => {
                i += 2;
                while i + 1 < bytes.len() && !(bytes[i] == b'*' && bytes[i + 1] == b'/') {
                    i += 1;
                }
                i += 1;
            }
            b'"' => {
                i += 1;
                while i < bytes.len() && bytes[i] != b'"' {
                    if bytes[i] == b'\\' {
                        i += 1;
                    }
                    i += 1;
                }
            }
            b'(' | b'[' | b'{' => {
                let label = stack.last().map_or(String::new(), |top| {
                    if top.list {
                        format!("[{}]", top.index)
                    } else {
                        top.key.clone().unwrap_or_default()
                    }
                });
                stack.push(Frame {
                    label,
                    list: c == b'[',
                    key: None,
                    index: 0,
                });
            }
            b')' | b']' | b'}' if stack.len() > 1 => {
                stack.pop();
            }
            b',' => stack
                .last_mut()
                .into_iter()
                .filter(|top| top.list)
                .for_each(|top| top.index += 1),
            c if c.is_ascii_alphabetic() || c == b'_' => {
                let start = i;
                while i < bytes.len() && (bytes[i].is_ascii_alphanumeric() || bytes[i] == b'_') {
                    i += 1;
                }
                let ident = &src[start..i];
                let mut j = i;
                while j < bytes.len() && bytes[j].is_ascii_whitespace() {
                    j += 1;
                }
                if bytes.get(j) == Some(&b':')
                    && let Some(top) = stack.last_mut()
                {
                    top.key = Some(ident.to_string());
                }
                continue;
            }
            _ => {}
        }
        i += 1;
    }
    let mut path = String::new();
    let mut push = |label: &str| {
        if label.is_empty() {
            return;
        }
        if !path.is_empty() && !label.starts_with('[') {
            path.push('.');
        }
        path.push_str(label);
    };
    for frame in stack.iter().skip(1) {
        push(&frame.label);
    }
    if with_key && let Some(top) = stack.last() {
        if top.list {
            push(&format!("[{}]", top.index));
        } else if let Some(key) = &top.key {
            push(key);
        }
    }
    path
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
    fn paths_follow_brackets_keys_and_list_indices() {
        let text = "(\n  camera: (x: (start: 1.0), fovy_deg: 2.0),\n  output: (label_formats: [Yolo, Cocoa]),\n)";
        // `fovy_deg` on line 2.
        let col = text
            .lines()
            .nth(1)
            .and_then(|l| l.find("fovy"))
            .unwrap_or(0)
            + 1;
        assert_eq!(field_path(text, 2, col, false), "camera");
        let col = text
            .lines()
            .nth(2)
            .and_then(|l| l.find("Cocoa"))
            .unwrap_or(0)
            + 1;
        assert_eq!(field_path(text, 3, col, true), "output.label_formats[1]");
    }

    #[test]
    fn suggestion_names_the_nearest_field_only_when_close() {
        assert!(suggestion("fovy_deg", &["x", "fov_y_deg"], "fields").contains("`fov_y_deg`"));
        assert!(!suggestion("banana", &["x", "fov_y_deg"], "fields").contains("did you mean"));
    }
}
