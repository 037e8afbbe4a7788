#!/usr/bin/env python3
"""Train a small detector on a swarmshot dataset and test it on real footage.

  python3 scripts/sim2real/sim2real.py train DATASET --minutes M --run RUNS/NAME [--workers W]
  python3 scripts/sim2real/sim2real.py eval RUNS/NAME [RUNS/NAME ...] --real REAL --out result.json

train: YOLOv8n from scratch (no pretrained weights, so nothing but the synthetic frames
       teaches it) on DATASET/data.yaml, as written by `swarmshot batch`, at 640 px, for M
       minutes of wall time (Ultralytics' `time`), weights in RUNS/NAME/weights/last.pt.
eval:  each run's last.pt on REAL, a folder made by real_frames.py:
       REAL/drone/{images,labels}: Ultralytics' mAP50 and mAP50-95 against the real boxes, and
         AP_centre, where a detection counts as a hit when its centre lies inside a real box not
         yet matched (the real boxes are hand-drawn and loose: a tight box around a 6 px drone
         in a 27 px hand box has IoU 0.05, which IoU matching scores as a miss and a false
         positive); recall and false positives per image at confidence 0.25;
       REAL/negative/images: birds, aeroplanes and helicopters with no drone: every detection
         at confidence 0.25 is a false positive (per image).
Needs: pip install ultralytics (and torch); a GPU makes it practical.
"""
import argparse
import glob
import json
import os
from pathlib import Path

os.environ.setdefault("YOLO_OFFLINE", "1")
os.environ.setdefault("YOLO_AUTOINSTALL", "false")
CONF = 0.25


def train(a):
    from ultralytics import YOLO

    run = Path(a.run).resolve()
    YOLO("yolov8n.yaml").train(
        data=str(Path(a.dataset).resolve() / "data.yaml"), imgsz=640, epochs=1000, time=a.minutes / 60.0,
        batch=32, workers=a.workers, cache="ram", amp=False, plots=False, val=False,
        project=str(run.parent), name=run.name, exist_ok=True, verbose=False, seed=0, patience=10000)


def real_boxes(labels_dir, size):
    w_img, h_img = size
    boxes = {}
    for p in glob.glob(f"{labels_dir}/*.txt"):
        rows = [list(map(float, line.split()[1:5])) for line in open(p) if line.strip()]
        boxes[Path(p).stem] = [((cx - w / 2) * w_img, (cy - h / 2) * h_img, (cx + w / 2) * w_img,
                                (cy + h / 2) * h_img) for cx, cy, w, h in rows]
    return boxes


def detections(model, images):
    found = {}
    for r in model.predict(source=images, imgsz=640, conf=0.01, iou=0.6, stream=True, verbose=False,
                           batch=32, max_det=50):
        found[Path(r.path).stem] = list(zip(r.boxes.xyxy.cpu().numpy().tolist(), r.boxes.conf.cpu().numpy().tolist()))
    return found


def match(dets, truth, min_conf=0.0):
    """(confidence, hit) of every detection at or above min_conf, a hit being a centre inside a
    real box of the same image that no more confident detection took."""
    out = []
    for key, found in dets.items():
        taken = [False] * len(truth.get(key, []))
        for (x0, y0, x1, y1), conf in sorted(found, key=lambda d: -d[1]):
            if conf < min_conf:
                continue
            cx, cy = (x0 + x1) / 2, (y0 + y1) / 2
            hit = False
            for i, (g0, h0, g1, h1) in enumerate(truth.get(key, [])):
                if not taken[i] and g0 <= cx <= g1 and h0 <= cy <= h1:
                    taken[i] = hit = True
                    break
            out.append((conf, hit))
    return out


def average_precision(matched, positives):
    """All-point interpolated AP (as VOC 2010+ and COCO's per-threshold AP)."""
    matched = sorted(matched, key=lambda m: -m[0])
    tp = 0
    precision, recall = [], []
    for i, (_, hit) in enumerate(matched, 1):
        tp += hit
        precision.append(tp / i)
        recall.append(tp / max(positives, 1))
    for i in range(len(precision) - 2, -1, -1):
        precision[i] = max(precision[i], precision[i + 1])
    ap, last = 0.0, 0.0
    for p, r in zip(precision, recall):
        ap += (r - last) * p
        last = r
    return ap


def evaluate(a):
    from PIL import Image
    from ultralytics import YOLO

    real = Path(a.real).resolve()
    drone_images = sorted(glob.glob(str(real / "drone" / "images" / "*")))
    negative_images = sorted(glob.glob(str(real / "negative" / "images" / "*")))
    size = Image.open(drone_images[0]).size
    truth = real_boxes(real / "drone" / "labels", size)
    positives = sum(len(b) for b in truth.values())
    yaml = Path(a.out).with_suffix(".real.yaml")
    yaml.write_text(f"path: {real / 'drone'}\ntrain: images\nval: images\nnames:\n  0: uav\n")
    result = {"real": str(real), "drone_frames": len(drone_images), "negative_frames": len(negative_images)}
    for run in a.runs:
        model = YOLO(str(Path(run) / "weights" / "last.pt"))
        v = model.val(data=str(yaml), split="val", imgsz=640, batch=32, conf=0.001, iou=0.6, plots=False,
                      verbose=False)
        on_drones = detections(model, drone_images)
        on_negatives = detections(model, negative_images)
        at_conf = match(on_drones, truth, CONF)
        csv = Path(run) / "results.csv"
        result[Path(run).name] = {
            "map50": float(v.box.map50), "map50_95": float(v.box.map),
            "ap_centre": average_precision(match(on_drones, truth), positives),
            "recall_at_0.25": sum(h for _, h in at_conf) / max(positives, 1),
            "fp_per_drone_frame_at_0.25": sum(not h for _, h in at_conf) / max(len(drone_images), 1),
            "fp_per_negative_frame_at_0.25": len(match(on_negatives, {}, CONF)) / max(len(negative_images), 1),
            "epochs": len(csv.read_text().splitlines()) - 1 if csv.exists() else None,
        }
        print(Path(run).name, json.dumps(result[Path(run).name]), flush=True)
    Path(a.out).write_text(json.dumps(result, indent=1) + "\n")


def main():
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    sub = p.add_subparsers(dest="cmd", required=True)
    t = sub.add_parser("train")
    t.add_argument("dataset")
    t.add_argument("--minutes", type=float, required=True)
    t.add_argument("--run", required=True)
    t.add_argument("--workers", type=int, default=4)
    e = sub.add_parser("eval")
    e.add_argument("runs", nargs="+")
    e.add_argument("--real", required=True)
    e.add_argument("--out", required=True)
    a = p.parse_args()
    train(a) if a.cmd == "train" else evaluate(a)


if __name__ == "__main__":
    main()
