//! The layouts real labelled footage comes in, as `fit` and `gap` read them
//! (`fit::input::read_folder` shares `gap`'s folder rules): an Ultralytics dataset given
//! by any of its folders, linked frames and folders, hidden files, upper-case
//! extensions, image formats that are not read, and Ultralytics' label variants.

use std::path::Path;

use image::{Rgb, RgbImage};
use swarmshot::fit::input::{RealFrame, read_folder};

/// A 64 × 64 PNG frame, a dark drone-sized square on a grey sky.
fn frame(path: &Path) {
    std::fs::create_dir_all(path.parent().expect("parent")).expect("dir");
    let img = RgbImage::from_fn(64, 64, |x, y| {
        let inside = (28..36).contains(&x) && (28..36).contains(&y);
        Rgb(if inside {
            [40, 40, 40]
        } else {
            [170, 180, 200]
        })
    });
    img.save(path).expect("png");
}

/// A label file with `text`.
fn label(path: &Path, text: &str) {
    std::fs::create_dir_all(path.parent().expect("parent")).expect("dir");
    std::fs::write(path, text).expect("txt");
}

const ROW: &str = "0 0.5 0.5 0.125 0.125\n";

/// Every frame below `dir`, labels required.
fn read(dir: &Path) -> Result<Vec<RealFrame>, String> {
    read_folder(dir, 0, false, &Default::default()).map_err(|e| e.to_string())
}

fn names(frames: &[RealFrame]) -> Vec<&str> {
    frames.iter().map(|f| f.rel.as_str()).collect()
}

/// `images/{train,val}`, `labels/{train,val}` (with LabelImg's `classes.txt`) and
/// `data.yaml`: two frames in train, one in val.
fn ultralytics(root: &Path) {
    for (split, name) in [("train", "a"), ("train", "b"), ("val", "c")] {
        frame(&root.join(format!("images/{split}/{name}.png")));
        label(&root.join(format!("labels/{split}/{name}.txt")), ROW);
    }
    label(&root.join("labels/train/classes.txt"), "drone\n");
    label(
        &root.join("data.yaml"),
        "path: .\ntrain: images/train\nval: images/val\nnames:\n  0: drone\n",
    );
}

#[test]
fn an_ultralytics_dataset_is_read_labelled_from_its_root_its_images_or_one_split() {
    let dir = tempfile::tempdir().expect("temp dir");
    let root = dir.path();
    ultralytics(root);
    for (top, frames) in [
        ("", 3),
        ("images", 3),
        ("images/train", 2),
        ("images/val", 1),
    ] {
        let read = read(&root.join(top)).unwrap_or_else(|e| panic!("{top}: {e}"));
        assert_eq!(read.len(), frames, "{top}: {:?}", names(&read));
        assert!(
            read.iter().all(|f| f.labelled && f.boxes.len() == 1),
            "{top}"
        );
    }
}

/// `gap --real .` run inside one split: the labels are found from the real path.
#[test]
fn gap_run_inside_a_split_finds_its_labels() {
    let dir = tempfile::tempdir().expect("temp dir");
    let root = dir.path().join("set");
    ultralytics(&root);
    // A stand-in dataset: frames in images/, no preset lock (every class a drone).
    let synthetic = dir.path().join("synthetic");
    frame(&synthetic.join("images/s.png"));
    label(&synthetic.join("labels/s.txt"), ROW);
    let out = std::process::Command::new(env!("CARGO_BIN_EXE_swarmshot"))
        .args(["gap", "--real", ".", "--synthetic"])
        .arg(&synthetic)
        .current_dir(root.join("images/train"))
        .output()
        .expect("run");
    let text =
        String::from_utf8_lossy(&out.stdout).into_owned() + &String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{text}");
    assert!(
        text.contains("real: . (2 of 2 images, 2 labelled, 2 drones)"),
        "{text}"
    );
}

#[cfg(unix)]
#[test]
fn linked_frames_and_folders_are_read_once_and_a_link_to_nothing_is_named() {
    use std::os::unix::fs::symlink;
    let dir = tempfile::tempdir().expect("temp dir");
    let store = dir.path().join("store");
    ultralytics(&store);
    let set = dir.path().join("set");
    // A split linked in from elsewhere, a frame linked alone, and a link back up.
    std::fs::create_dir_all(set.join("images/own")).expect("dir");
    symlink(store.join("images/train"), set.join("images/train")).expect("link");
    symlink(store.join("labels"), set.join("labels")).expect("link");
    symlink(store.join("images/val/c.png"), set.join("images/own/c.png")).expect("link");
    label(&set.join("images/own/c.txt"), ROW);
    symlink(&set, set.join("images/own/loop")).expect("link");
    let read = read(&set).expect("read");
    assert_eq!(
        names(&read),
        [
            "images/own/c.png",
            "images/train/a.png",
            "images/train/b.png"
        ]
    );
    assert!(read.iter().all(|f| f.boxes.len() == 1));
    symlink(dir.path().join("gone.png"), set.join("images/own/d.png")).expect("link");
    let e = read_folder(&set, 0, false, &Default::default()).expect_err("link to nothing");
    let e = e.to_string();
    assert!(
        e.contains("images/own/d.png") && e.contains("a link to a file that does not exist"),
        "{e}"
    );
}

#[test]
fn hidden_files_are_skipped_and_upper_case_extensions_read() {
    let dir = tempfile::tempdir().expect("temp dir");
    let root = dir.path();
    frame(&root.join("A.PNG"));
    label(&root.join("A.txt"), ROW);
    // macOS's AppleDouble files and Finder's folder state.
    label(&root.join("._A.PNG"), "not an image");
    label(&root.join(".DS_Store"), "not an image");
    let read = read(root).expect("read");
    assert_eq!(names(&read), ["A.PNG"]);
}

/// A frame in a format not read (BMP, WebP, TIFF, …) is refused by name where it is
/// footage: beside the JPEG and PNG frames, labelled, or the only images there are.
#[test]
fn a_frame_in_a_format_not_read_is_named_not_skipped() {
    let refused = |root: &Path, name: &str| {
        let e = read(root).expect_err(name);
        assert!(
            e.contains(name) && e.contains("frames are read as JPEG or PNG"),
            "{name}: {e}"
        );
    };
    for name in ["b.webp", "b.BMP", "b.tif", "b.tiff"] {
        let dir = tempfile::tempdir().expect("temp dir");
        let root = dir.path();
        frame(&root.join("a.png"));
        label(&root.join("a.txt"), ROW);
        label(&root.join(name), "an image in another format");
        refused(root, name);
    }
    // Labelled, in a folder of its own.
    let dir = tempfile::tempdir().expect("temp dir");
    let root = dir.path();
    frame(&root.join("images/a/a.png"));
    label(&root.join("labels/a/a.txt"), ROW);
    label(&root.join("images/b/b.tif"), "a TIFF frame");
    label(&root.join("labels/b/b.txt"), ROW);
    refused(root, "images/b/b.tif");
    // The only images there are.
    let dir = tempfile::tempdir().expect("temp dir");
    label(&dir.path().join("seq/b.bmp"), "a BMP frame");
    refused(dir.path(), "seq/b.bmp");
}

/// A folder of videos (Drone-vs-Bird's layout) names one, and the way to give it.
#[test]
fn a_folder_of_videos_names_one_and_how_to_give_it() {
    let dir = tempfile::tempdir().expect("temp dir");
    label(&dir.path().join("clips/v1.MP4"), "a video");
    label(&dir.path().join("clips/v1.txt"), "0 2 10 10 5 5 drone");
    let e = read(dir.path()).expect_err("no frame");
    assert!(
        e.contains("clips/v1.MP4: a video in a folder without frames")
            && e.contains("give the video itself as --real"),
        "{e}"
    );
}

/// A picture in another format away from the frames (a dataset's `assets/demo.gif`)
/// is no frame: skipped.
#[test]
fn an_unlabelled_picture_away_from_the_frames_is_skipped() {
    let dir = tempfile::tempdir().expect("temp dir");
    let root = dir.path();
    ultralytics(root);
    label(&root.join("assets/demo.gif"), "a GIF");
    assert_eq!(read(root).expect("read").len(), 3);
}

/// Ultralytics' segmentation and oriented-box labels, a prediction file's confidence
/// column, a Windows editor's byte-order mark and CRLF: each frame's drone is found.
#[test]
fn ultralytics_label_variants_are_read_as_boxes() {
    let dir = tempfile::tempdir().expect("temp dir");
    let root = dir.path();
    let rows = [
        "0 0.4375 0.4375 0.5625 0.4375 0.5625 0.5625 0.4375 0.5625 0.44 0.5\n",
        "0 0.4375 0.4375 0.5625 0.4375 0.5625 0.5625 0.4375 0.5625\n",
        "0 0.5 0.5 0.125 0.125 0.93\n",
        "\u{feff}0 0.5 0.5 0.125 0.125\r\n\r\n",
    ];
    for (i, row) in rows.iter().enumerate() {
        frame(&root.join(format!("images/{i}.png")));
        label(&root.join(format!("labels/{i}.txt")), row);
    }
    for f in read(root).expect("read") {
        let b = f
            .boxes
            .first()
            .unwrap_or_else(|| panic!("{}: no box", f.rel));
        let got = [b.x0, b.y0, b.x1, b.y1];
        assert!(
            got.iter()
                .zip([28.0, 28.0, 36.0, 36.0])
                .all(|(g, w)| (g - w).abs() < 0.1),
            "{}: {got:?}",
            f.rel
        );
    }
}

/// `--real data.yaml`, as Ultralytics takes a dataset: named as a description, with
/// the folder to give instead, by `fit` (not tried as a video, not "unlabelled") and
/// `gap`; nothing written. `gap` given a video or a single frame says which.
#[test]
fn a_dataset_yaml_given_as_footage_names_the_folder_to_give() {
    let dir = tempfile::tempdir().expect("temp dir");
    let root = dir.path().join("set");
    ultralytics(&root);
    let yaml = root.join("data.yaml");
    let out = dir.path().join("out");
    let base = Path::new(env!("CARGO_MANIFEST_DIR")).join("presets/realistic.ron");
    let run = |args: &[&std::ffi::OsStr]| {
        let o = std::process::Command::new(env!("CARGO_BIN_EXE_swarmshot"))
            .args(args)
            .output()
            .expect("run");
        assert!(!o.status.success());
        String::from_utf8_lossy(&o.stderr).into_owned()
    };
    let fit = run(&[
        "fit".as_ref(),
        "--real".as_ref(),
        yaml.as_os_str(),
        "--out".as_ref(),
        out.as_os_str(),
        "--base".as_ref(),
        base.as_os_str(),
        "--rounds".as_ref(),
        "0".as_ref(),
    ]);
    let synthetic = dir.path().join("synthetic");
    frame(&synthetic.join("images/s.png"));
    let gap = run(&[
        "gap".as_ref(),
        "--real".as_ref(),
        yaml.as_os_str(),
        "--synthetic".as_ref(),
        synthetic.as_os_str(),
    ]);
    for e in [fit, gap] {
        assert!(
            e.contains("data.yaml: a dataset description") && e.contains("not footage"),
            "{e}"
        );
        assert!(
            e.contains(&format!("the dataset's root {}", root.display())),
            "{e}"
        );
    }
    assert!(!out.exists());
    // gap given a video or one frame says so.
    let video = dir.path().join("clip.MP4");
    std::fs::write(&video, "a video").expect("mp4");
    let one = root.join("images/train/a.png");
    for (real, says) in [(&video, "a video, not a folder"), (&one, "a single image")] {
        let e = run(&[
            "gap".as_ref(),
            "--real".as_ref(),
            real.as_os_str(),
            "--synthetic".as_ref(),
            synthetic.as_os_str(),
        ]);
        assert!(e.contains(says), "{e}");
    }
}

/// Frames many times wider than high (a panorama strip) would give plates past the
/// 150° a plate may span: refused before anything is written, where the fitted preset
/// used to be written and then fail to load.
#[test]
fn frames_too_wide_for_a_plate_are_refused_before_anything_is_written() {
    let dir = tempfile::tempdir().expect("temp dir");
    let real = dir.path().join("real");
    std::fs::create_dir_all(&real).expect("dir");
    RgbImage::from_pixel(2000, 64, Rgb([170, 180, 200]))
        .save(real.join("strip.png"))
        .expect("png");
    label(&real.join("strip.txt"), "");
    let out = dir.path().join("out");
    let base = Path::new(env!("CARGO_MANIFEST_DIR")).join("presets/realistic.ron");
    let o = std::process::Command::new(env!("CARGO_BIN_EXE_swarmshot"))
        .args(["fit", "--rounds", "0", "--real"])
        .args([&real, Path::new("--out"), &out, Path::new("--base"), &base])
        .output()
        .expect("run");
    let e = String::from_utf8_lossy(&o.stderr);
    assert!(!o.status.success(), "{e}");
    assert!(e.contains("past the 150° a plate may have"), "{e}");
    assert!(!out.exists(), "{e}");
}
