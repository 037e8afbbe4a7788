#!/usr/bin/env python3
"""Build a labelled real test set from the CC0 drone detection dataset of Svanström et al.

  python3 scripts/sim2real/real_frames.py DATASET_CLONE OUT

DATASET_CLONE is a clone of github.com/DroneDetectionThesis/Drone-detection-dataset (CC0 1.0;
"A dataset for multi-sensor drone detection", Data in Brief 2021). From its visible-light videos
(Data/Video_V, 640x512, 30 fps) it writes, in Ultralytics layout:

  OUT/drone/images/V_DRONE_NNN_fFFF.png + OUT/drone/labels/....txt
      frames 50, 150 and 250 of every V_DRONE video that has a box there (class 0, the
      dataset's own hand-drawn box, clipped to the frame);
  OUT/negative/images/V_{BIRD,AIRPLANE,HELICOPTER}_NNN_f150.png (+ empty label files)
      frame 150 of every bird, aeroplane and helicopter video: no drone, so every drone a
      detector reports there is a false positive.

Frames are decoded losslessly (PNG). Needs: pip install imageio-ffmpeg mcos-decoder.
Videos whose files are missing from the clone are skipped and named on stderr.
"""
import os
import subprocess
import sys
from pathlib import Path

W, H = 640, 512
DRONE_FRAMES = (50, 150, 250)
NEGATIVE_FRAMES = (150,)


def decode_frame(ffmpeg, video, n, png):
    subprocess.run([ffmpeg, "-loglevel", "error", "-y", "-i", str(video), "-vf", f"select=eq(n\\,{n})",
                    "-vframes", "1", str(png)], check=True)


def yolo_row(box):
    x, y, w, h = box
    x0, y0, x1, y1 = max(0.0, x), max(0.0, y), min(W, x + w), min(H, y + h)
    return f"0 {(x0 + x1) / 2 / W:.6f} {(y0 + y1) / 2 / H:.6f} {(x1 - x0) / W:.6f} {(y1 - y0) / H:.6f}\n"


def main(clone, out):
    import imageio_ffmpeg
    import mcos_decoder

    ffmpeg = imageio_ffmpeg.get_ffmpeg_exe()
    videos = sorted((Path(clone) / "Data" / "Video_V").glob("V_*.mp4"))
    if not videos:
        sys.exit(f"real_frames: no Data/Video_V/V_*.mp4 under {clone}")
    for split in ("drone", "negative"):
        for d in ("images", "labels"):
            (Path(out) / split / d).mkdir(parents=True, exist_ok=True)
    made = {"drone": 0, "negative": 0}
    for video in videos:
        labels = video.with_name(video.stem + "_LABELS.mat")
        if not labels.is_file() or video.stat().st_size < 1024:
            print(f"real_frames: skipped {video.name} (missing or not fetched)", file=sys.stderr)
            continue
        split = "drone" if video.stem.startswith("V_DRONE_") else "negative"
        boxes = mcos_decoder.load_groundtruth(str(labels))
        for n in DRONE_FRAMES if split == "drone" else NEGATIVE_FRAMES:
            if n >= len(boxes) or (split == "drone" and boxes[n] is None):
                continue
            name = f"{video.stem}_f{n:03d}"
            decode_frame(ffmpeg, video, n, Path(out) / split / "images" / f"{name}.png")
            row = yolo_row(boxes[n]) if split == "drone" else ""
            (Path(out) / split / "labels" / f"{name}.txt").write_text(row)
            made[split] += 1
    print(f"real_frames: {made['drone']} drone frames, {made['negative']} negative frames in {out}")


if __name__ == "__main__":
    if len(sys.argv) != 3:
        sys.exit(__doc__)
    main(sys.argv[1], sys.argv[2])
