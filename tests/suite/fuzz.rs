//! Fuzz targets, driven by proptest so they run on every `cargo test` in
//! bounded time (a few hundred cases each), and for as long as one likes with
//! `PROPTEST_CASES` (docs/reliability.md, section 9):
//!
//! - the preset parser + validator: random RON-like text and mutated valid
//!   presets (`tests/fuzz_corpus/presets/`) never panic; each is `Ok` or a
//!   named error, a valid one survives the checks every command runs and its
//!   RON round-trips;
//! - the glTF loader: mutated bytes and mutated JSON of small GLBs
//!   (`tests/fuzz_corpus/gltf/`, three tiny files from `tests/data/gltf/`)
//!   never panic through it and never hang.
//!
//! Every corpus file also runs as is. An input that once failed becomes a file
//! in the corpus and a named test at the end of this file.

use crate::common;

use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

use proptest::prelude::*;
use swarmshot::model::{self, ModelError};
use swarmshot::preset::{DeviceLimits, Placement, Preset};

/// Cases per target: 256 by default (about 10 s all told in a debug build),
/// `PROPTEST_CASES` for long runs.
fn config() -> ProptestConfig {
    let cases = std::env::var("PROPTEST_CASES")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(256);
    ProptestConfig {
        cases,
        failure_persistence: None,
        ..ProptestConfig::default()
    }
}

fn corpus(dir: &str, ext: &str) -> Vec<PathBuf> {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("tests/fuzz_corpus")
        .join(dir);
    let mut files: Vec<PathBuf> = std::fs::read_dir(&dir)
        .unwrap_or_else(|e| panic!("{}: {e}", dir.display()))
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| p.extension().is_some_and(|e| e == ext))
        .collect();
    files.sort();
    assert!(!files.is_empty(), "no .{ext} seeds in {}", dir.display());
    files
}

fn preset_seeds() -> Vec<String> {
    corpus("presets", "ron")
        .iter()
        .map(|p| std::fs::read_to_string(p).expect("corpus preset"))
        .collect()
}

fn glb_seeds() -> Vec<Vec<u8>> {
    let mut seeds: Vec<Vec<u8>> = corpus("gltf", "glb")
        .iter()
        .map(|p| std::fs::read(p).expect("corpus glb"))
        .collect();
    for rel in [
        "gltf/Box/glTF-Binary/Box.glb",
        "gltf/BoxTextured/glTF-Binary/BoxTextured.glb",
        "gltf/SimpleInstancing/glTF-Binary/SimpleInstancing.glb",
    ] {
        seeds.push(std::fs::read(common::testdata(rel)).expect("tests/data glb"));
    }
    seeds
}

/// Everything the commands do with a preset's text before touching a file or
/// the GPU: parse, validate, and for a valid preset the frame count, warnings,
/// limits, memory estimate, RON round trip and (small scenes) frame 0's scene.
fn exercise_preset(text: &str) -> Result<(), TestCaseError> {
    let preset = match Preset::from_ron(text) {
        Ok(p) => p,
        Err(message) => {
            prop_assert!(!message.reason.is_empty());
            return Ok(());
        }
    };
    if let Err(errors) = preset.validate() {
        prop_assert!(!errors.is_empty());
        for e in &errors {
            prop_assert!(!e.field.is_empty() && !e.message.is_empty(), "{e:?}");
        }
        return Ok(());
    }
    let _ = preset.frame_count();
    let _ = preset.warnings();
    let _ = preset.frame_memory_bytes();
    let _ = preset.check_limits(&DeviceLimits {
        max_texture_side: 8192,
        max_buffer_bytes: 1 << 28,
        memory_bytes: Some(1 << 32),
    });
    let back = Preset::from_ron(&preset.to_ron());
    prop_assert!(
        back.is_ok(),
        "a valid preset's RON does not parse: {back:?}"
    );
    let small = match &preset.placement {
        Placement::Randomized { count, .. } => count.1 <= 64,
        Placement::Structured {
            x_count,
            y_count,
            z_count,
            ..
        } => u64::from(*x_count) * u64::from(*y_count) * u64::from(*z_count) <= 64,
        Placement::Formation(f) => f.count <= 64,
    };
    if small && preset.frame_count() > 0 {
        let _ = swarmshot::scene::build_frame(&preset, 0);
        let _ = swarmshot::scene::build_frame(&preset, preset.frame_count() - 1);
    }
    Ok(())
}

/// Tokens a mutation may splice in: field and variant names, numbers at the
/// edges of their types, brackets and separators.
const TOKENS: &[&str] = &[
    "(",
    ")",
    "[",
    "]",
    ",",
    ":",
    "\"",
    "0",
    "-0.0",
    "1",
    "-1",
    "1e308",
    "-1e308",
    "1e-320",
    "inf",
    "NaN",
    "4294967295",
    "4294967296",
    "18446744073709551615",
    "-9223372036854775808",
    "0.5",
    "Some(",
    "None",
    "true",
    "x_count",
    "count",
    "size_m",
    "min_separation_m",
    "per_m3",
    "start",
    "end",
    "step",
    "fov_y_deg",
    "msaa",
    "id_scale",
    "width",
    "height",
    "quality",
    "repeats",
    "choices",
    "Random(",
    "Structured(",
    "Randomized(",
    "Density(",
    "Box(",
    "Custom(",
    "Image(",
    "Equirect(",
    "Procedural(",
    "environment",
    "//",
    "/*",
];

#[derive(Clone, Debug)]
enum Edit {
    Delete { at: usize, len: usize },
    Insert { at: usize, token: usize },
    Replace { at: usize, len: usize, token: usize },
    Truncate { at: usize },
}

fn edit_strategy() -> impl Strategy<Value = Edit> {
    prop_oneof![
        (any::<usize>(), 1..16usize).prop_map(|(at, len)| Edit::Delete { at, len }),
        (any::<usize>(), any::<usize>()).prop_map(|(at, token)| Edit::Insert { at, token }),
        (any::<usize>(), 1..8usize, any::<usize>()).prop_map(|(at, len, token)| Edit::Replace {
            at,
            len,
            token
        }),
        any::<usize>().prop_map(|at| Edit::Truncate { at }),
    ]
}

/// Apply `edits` to `text` at character boundaries.
fn mutate_text(text: &str, edits: &[Edit]) -> String {
    let mut chars: Vec<char> = text.chars().collect();
    for edit in edits {
        let n = chars.len().max(1);
        match *edit {
            Edit::Delete { at, len } => {
                let at = at % n;
                let end = (at + len).min(chars.len());
                if at < end {
                    chars.drain(at..end);
                }
            }
            Edit::Insert { at, token } => {
                let at = at % (chars.len() + 1);
                let t = TOKENS[token % TOKENS.len()];
                chars.splice(at..at, t.chars());
            }
            Edit::Replace { at, len, token } => {
                let at = at % n;
                let end = (at + len).min(chars.len());
                let t = TOKENS[token % TOKENS.len()];
                if at <= end {
                    chars.splice(at..end, t.chars());
                }
            }
            Edit::Truncate { at } => chars.truncate(at % n),
        }
    }
    chars.into_iter().collect()
}

/// The binary's panic hook: quiet for panics the glTF loader catches (the
/// default hook would print, and with RUST_BACKTRACE symbolise, each one).
fn quiet_caught_panics() {
    static ONCE: std::sync::Once = std::sync::Once::new();
    ONCE.call_once(|| {
        let default_hook = std::panic::take_hook();
        std::panic::set_hook(Box::new(move |info| {
            if !model::in_guarded_load() {
                default_hook(info);
            }
        }));
    });
}

/// The loader on `bytes`: no panic may escape and it must finish promptly.
fn exercise_glb(bytes: &[u8]) -> Result<(), TestCaseError> {
    quiet_caught_panics();
    let start = Instant::now();
    let result =
        std::panic::catch_unwind(|| model::load_bytes(bytes, None, Path::new("fuzz.glb"), "fuzz"));
    let elapsed = start.elapsed();
    prop_assert!(result.is_ok(), "a panic escaped the glTF loader");
    prop_assert!(
        elapsed < Duration::from_secs(10),
        "the loader took {elapsed:?}"
    );
    if let Ok(Err(e)) = result {
        let msg = e.to_string();
        prop_assert!(
            msg.contains("fuzz.glb"),
            "error does not name the file: {msg}"
        );
    }
    Ok(())
}

#[derive(Clone, Debug)]
enum ByteEdit {
    Flip { at: usize, bit: u8 },
    Set { at: usize, value: u8 },
    Delete { at: usize, len: usize },
    Truncate { at: usize },
}

fn byte_edit_strategy() -> impl Strategy<Value = ByteEdit> {
    prop_oneof![
        (any::<usize>(), 0..8u8).prop_map(|(at, bit)| ByteEdit::Flip { at, bit }),
        (any::<usize>(), any::<u8>()).prop_map(|(at, value)| ByteEdit::Set { at, value }),
        (any::<usize>(), 1..32usize).prop_map(|(at, len)| ByteEdit::Delete { at, len }),
        any::<usize>().prop_map(|at| ByteEdit::Truncate { at }),
    ]
}

fn mutate_bytes(bytes: &[u8], edits: &[ByteEdit]) -> Vec<u8> {
    let mut b = bytes.to_vec();
    for edit in edits {
        if b.is_empty() {
            break;
        }
        let n = b.len();
        match *edit {
            ByteEdit::Flip { at, bit } => b[at % n] ^= 1 << bit,
            ByteEdit::Set { at, value } => b[at % n] = value,
            ByteEdit::Delete { at, len } => {
                let at = at % n;
                b.drain(at..(at + len).min(n));
            }
            ByteEdit::Truncate { at } => b.truncate(at % n),
        }
    }
    b
}

/// The JSON chunk of a GLB and its BIN chunk (for seeds this file builds).
fn split_glb(bytes: &[u8]) -> Option<(serde_json::Value, Vec<u8>)> {
    let u32_at = |i: usize| {
        bytes
            .get(i..i + 4)
            .map(|b| u32::from_le_bytes([b[0], b[1], b[2], b[3]]) as usize)
    };
    let json_len = u32_at(12)?;
    let json: serde_json::Value = serde_json::from_slice(bytes.get(20..20 + json_len)?).ok()?;
    let bin_at = 20 + json_len;
    let bin_len = u32_at(bin_at)?;
    let bin = bytes.get(bin_at + 8..bin_at + 8 + bin_len)?.to_vec();
    Some((json, bin))
}

/// Numbers a JSON mutation may put in place of another.
const NUMBERS: &[i64] = &[
    -1,
    0,
    1,
    2,
    3,
    4,
    5,
    7,
    255,
    5120,
    5121,
    5123,
    5125,
    5126,
    65535,
    4_294_967_295,
    1 << 40,
    i64::MAX,
];

/// Replace the `pick`-th number in the document by `NUMBERS[value]`.
fn mutate_json(value: &mut serde_json::Value, pick: &mut usize, number: i64) -> bool {
    match value {
        serde_json::Value::Number(_) => {
            if *pick == 0 {
                *value = serde_json::json!(number);
                return true;
            }
            *pick -= 1;
            false
        }
        serde_json::Value::Array(items) => items.iter_mut().any(|v| mutate_json(v, pick, number)),
        serde_json::Value::Object(map) => map.values_mut().any(|v| mutate_json(v, pick, number)),
        _ => false,
    }
}

proptest! {
    #![proptest_config(config())]

    #[test]
    fn random_ron_text_never_panics(text in "[-()\\[\\]:,. \"a-zA-Z_0-9eE+]{0,300}") {
        exercise_preset(&text)?;
    }

    #[test]
    fn mutated_presets_never_panic(
        seed in any::<usize>(),
        edits in prop::collection::vec(edit_strategy(), 1..6),
    ) {
        let seeds = preset_seeds();
        let text = mutate_text(&seeds[seed % seeds.len()], &edits);
        exercise_preset(&text)?;
    }

    #[test]
    fn mutated_glb_bytes_never_panic_or_hang(
        seed in any::<usize>(),
        edits in prop::collection::vec(byte_edit_strategy(), 1..8),
    ) {
        let seeds = glb_seeds();
        exercise_glb(&mutate_bytes(&seeds[seed % seeds.len()], &edits))?;
    }

    #[test]
    fn mutated_glb_json_never_panics_or_hangs(
        seed in any::<usize>(),
        changes in prop::collection::vec((any::<usize>(), any::<usize>()), 1..5),
    ) {
        let seeds = glb_seeds();
        let Some((mut json, bin)) = split_glb(&seeds[seed % seeds.len()]) else {
            return Err(TestCaseError::fail("seed GLB does not split"));
        };
        for (pick, value) in changes {
            let mut pick = pick % 200;
            mutate_json(&mut json, &mut pick, NUMBERS[value % NUMBERS.len()]);
        }
        exercise_glb(&common::glb(&json, &bin))?;
    }
}

#[test]
fn every_corpus_file_runs_clean() {
    for text in preset_seeds() {
        exercise_preset(&text).expect("corpus preset");
        // The seeds themselves parse and validate.
        let p = Preset::from_ron(&text).expect("seed parses");
        p.validate().expect("seed validates");
    }
    for bytes in glb_seeds() {
        exercise_glb(&bytes).expect("corpus glb");
        model::load_bytes(&bytes, None, Path::new("seed.glb"), "seed").expect("seed loads");
    }
}

#[test]
fn a_panic_inside_the_gltf_reader_is_one_typed_error_without_its_text() {
    // Sanity of the guard every fuzz case relies on: whatever the reader does
    // with a hostile file, the caller sees a ModelError naming the file.
    let (mut json, bin) = common::triangle_gltf();
    json["accessors"][1]["count"] = serde_json::json!(4_294_967_295u64);
    match model::load_bytes(
        &common::glb(&json, &bin),
        None,
        Path::new("hostile.glb"),
        "h",
    ) {
        Err(
            e @ (ModelError::Primitive { .. }
            | ModelError::Malformed { .. }
            | ModelError::Parse { .. }),
        ) => {
            let msg = e.to_string();
            assert!(
                msg.contains("hostile.glb") && !msg.contains("panicked at"),
                "{msg}"
            );
        }
        other => panic!("{other:?}"),
    }
}

/// Found by `mutated_glb_json_never_panics_or_hangs`: SimpleInstancing.glb
/// with accessor 1 (NORMAL) made `UNSIGNED_BYTE`. The gltf crate asserted on
/// it (a caught panic, slow to report); it is now a named error.
#[test]
fn regression_normals_of_the_wrong_component_type_are_a_named_error() {
    let bytes = std::fs::read(common::testdata(
        "gltf/SimpleInstancing/glTF-Binary/SimpleInstancing.glb",
    ))
    .expect("tests/data glb");
    let (mut json, bin) = split_glb(&bytes).expect("splits");
    json["accessors"][1]["componentType"] = serde_json::json!(5121);
    let e = model::load_bytes(&common::glb(&json, &bin), None, Path::new("r.glb"), "r")
        .expect_err("u8 normals");
    let msg = e.to_string();
    assert!(
        msg.contains("accessor 1") && msg.contains("must be float VEC3"),
        "{msg}"
    );
}
