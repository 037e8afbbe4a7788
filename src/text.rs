//! Text a user typed, made safe to print and checked for limits: control
//! characters escaped, long numbers shortened, names bounded, and class
//! names that differ only by case, spaces or look-alike letters found; and
//! counts printed with their noun in its number.
//! Beneath every module that prints a user's text (the preset's field
//! errors, the model loader's URIs, the command line); imports nothing of
//! the project.

use std::fmt::Write as _;

/// `n` and the noun in its number: "1 frame", "2 frames".
pub fn plural(n: u64, one: &str, many: &str) -> String {
    format!("{n} {}", if n == 1 { one } else { many })
}

/// The longest class or preset name, in characters.
pub const MAX_NAME_CHARS: usize = 64;

/// `s` with every control character (and Unicode bidi override) written as
/// an escape such as `\u{1b}`, so no raw escape byte reaches a terminal.
pub fn printable(s: &str) -> String {
    let mut out = String::with_capacity(s.len());
    for c in s.chars() {
        if is_unprintable(c) {
            let _ = write!(out, "\\u{{{:x}}}", u32::from(c));
        } else {
            out.push(c);
        }
    }
    out
}

/// A message for the terminal: control characters escaped (new lines
/// kept) and runs of more than 15 digits shortened.
pub fn for_terminal(message: &str) -> String {
    let lines: Vec<String> = message.split('\n').map(printable).collect();
    shorten_digit_runs(&lines.join("\n"))
}

/// Control characters and the invisible format characters that reorder or
/// hide text (bidi overrides and isolates, zero-width joiners, BOM).
pub fn is_unprintable(c: char) -> bool {
    c.is_control()
        || matches!(c, '\u{200b}'..='\u{200f}' | '\u{202a}'..='\u{202e}' | '\u{2066}'..='\u{2069}' | '\u{feff}')
}

/// A number for a message: integers up to 12 digits as they are, larger or
/// fractional magnitudes in 4 significant digits (`1.000e300`), never 300 digits.
pub fn short_number(x: f64) -> String {
    if !x.is_finite() {
        return x.to_string();
    }
    let a = x.abs();
    if x.fract() == 0.0 && a < 1e12 {
        return format!("{x:.0}");
    }
    if (1e-4..1e12).contains(&a) {
        // Up to 6 significant digits, trailing zeros cut.
        let digits = 5_i32.saturating_sub(a.log10().floor() as i32).clamp(0, 9);
        let s = format!("{x:.prec$}", prec = digits as usize);
        let s = if s.contains('.') {
            s.trim_end_matches('0').trim_end_matches('.').to_string()
        } else {
            s
        };
        return s;
    }
    format!("{x:.3e}")
}

/// Shorten any run of more than 15 digits in `message` that stands as a
/// number (a number echoed from the input) to its first digits and its
/// length. A run inside a name (after or before a letter, `/` or `_`: a
/// path such as `runs/run20241204123456789012/x`) is kept whole, or the
/// message would name a file that is not there.
pub fn shorten_digit_runs(message: &str) -> String {
    const MAX_DIGITS: usize = 15;
    let in_name = |c: Option<char>| c.is_some_and(|c| c.is_alphabetic() || c == '/' || c == '_');
    let mut out = String::with_capacity(message.len().min(4096));
    let mut run = String::new();
    let mut before = None;
    let flush = |run: &mut String, out: &mut String, around: [Option<char>; 2]| {
        if run.len() > MAX_DIGITS && !around.into_iter().any(in_name) {
            let _ = write!(out, "{}…({} digits)", &run[..6], run.len());
        } else {
            out.push_str(run);
        }
        run.clear();
    };
    for c in message.chars() {
        if c.is_ascii_digit() {
            run.push(c);
            continue;
        }
        if !run.is_empty() {
            flush(&mut run, &mut out, [before, Some(c)]);
        }
        before = Some(c);
        out.push(c);
    }
    flush(&mut run, &mut out, [before, None]);
    out
}

/// Why `name` (a class or preset name) is refused, if it is: empty, longer
/// than [`MAX_NAME_CHARS`], or holding a control character.
pub fn name_problem(name: &str) -> Option<String> {
    let chars = name.chars().count();
    if chars > MAX_NAME_CHARS {
        let head: String = name.chars().take(24).collect();
        return Some(format!(
            "\"{}…\" is {} characters long, more than the limit of {MAX_NAME_CHARS}",
            printable(&head),
            short_number(chars as f64)
        ));
    }
    if let Some(c) = name.chars().find(|&c| is_unprintable(c)) {
        return Some(format!(
            "\"{}\" holds the control character U+{:04X}; names must be printable text",
            printable(name),
            u32::from(c)
        ));
    }
    None
}

/// The form two class names are compared in to find near-duplicates:
/// trimmed, inner white space collapsed, lower case, and Cyrillic or Greek
/// letters that look like Latin ones mapped to those.
pub fn skeleton(name: &str) -> String {
    let mut out = String::new();
    let mut space = false;
    for c in name.trim().chars() {
        if c.is_whitespace() || c == '_' || c == '-' {
            space = true;
            continue;
        }
        if space && !out.is_empty() {
            out.push(' ');
        }
        space = false;
        for l in c.to_lowercase() {
            out.push(confusable(l));
        }
    }
    out
}

/// A Latin letter that a lower-case Cyrillic or Greek one is drawn like.
fn confusable(c: char) -> char {
    match c {
        'а' | 'α' => 'a',
        'в' | 'β' => 'b',
        'с' | 'ϲ' => 'c',
        'е' | 'ε' => 'e',
        'һ' => 'h',
        'і' | 'ι' => 'i',
        'ј' => 'j',
        'к' | 'κ' => 'k',
        'м' => 'm',
        'п' | 'η' => 'n',
        'о' | 'ο' => 'o',
        'р' | 'ρ' => 'p',
        'ѕ' => 's',
        'т' | 'τ' => 't',
        'у' | 'υ' | 'γ' => 'y',
        'ν' | 'ѵ' => 'v',
        'х' | 'χ' => 'x',
        'ԁ' => 'd',
        'ԛ' => 'q',
        'ԝ' | 'ω' => 'w',
        _ => c,
    }
}

/// An error and its causes on one line, `: ` between them, each cause left out when the
/// line already says it (an error whose message includes its source's), as the command
/// line and the app's windows print a failure.
pub fn one_line(e: &anyhow::Error) -> String {
    let mut line = String::new();
    for cause in e.chain() {
        let text = cause.to_string();
        if line.is_empty() {
            line = text;
        } else if !line.contains(&text) {
            line = format!("{line}: {text}");
        }
    }
    line
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn counts_take_the_noun_in_their_number() {
        assert_eq!(plural(1, "frame", "frames"), "1 frame");
        assert_eq!(plural(0, "frame", "frames"), "0 frames");
        assert_eq!(plural(2, "box", "boxes"), "2 boxes");
    }

    #[test]
    fn control_characters_are_escaped() {
        assert_eq!(printable("a\u{1b}[31mb"), "a\\u{1b}[31mb");
        assert_eq!(printable("uav"), "uav");
    }

    #[test]
    fn numbers_are_short() {
        assert_eq!(short_number(42.0), "42");
        assert_eq!(short_number(1e300), "1.000e300");
        assert_eq!(short_number(0.25), "0.25");
        assert_eq!(short_number(-1.5e-300), "-1.500e-300");
        let long = format!("value {} here", "9".repeat(300));
        let s = shorten_digit_runs(&long);
        assert!(s.len() < 40 && s.contains("300 digits"), "{s}");
        // A run in a name is kept: the message must name the real file.
        for path in [
            "S/run20241204123456789012 is not a dataset",
            "/tmp/x/12345678901234567890123/y: missing",
            "frame_00000000000000000001.png",
        ] {
            assert_eq!(shorten_digit_runs(path), path);
        }
        assert!(shorten_digit_runs("size_m: -1000000000000000000000.5").contains("(22 digits)"));
    }

    #[test]
    fn near_duplicates_share_a_skeleton() {
        let base = skeleton("uav");
        for v in ["uav ", "UAV", " Uav", "u\u{0430}v"] {
            assert_eq!(skeleton(v), base, "{v:?}");
        }
        assert_ne!(skeleton("uav2"), base);
        assert_eq!(skeleton("big  bird"), skeleton("Big_Bird"));
    }
}
