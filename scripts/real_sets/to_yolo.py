#!/usr/bin/env python3
"""Convert public drone-detection annotations to the YOLO layout `swarmshot gap` reads.

Standard library only (video needs an ffmpeg binary, the `svanstrom` labels the mcos-decoder
package). Every sub-command writes

    OUT/images/<prefix>_<frame>.<jpg|png>     the real frame (JPEG or PNG bytes copied
                                              unchanged, the extension following the bytes;
                                              video frames decoded losslessly to PNG)
    OUT/labels/<prefix>_<frame>.txt           one row per drone: `0 cx cy w h`, normalised
                                              to the frame, boxes clipped to it

and appends one line per written frame to OUT/manifest.tsv (image, source, frame, boxes).
Class 0 = drone; boxes of other classes (birds, aeroplanes) are dropped. Frames are picked
deterministically: among the frames that have at least one drone, `--count` of them evenly
spaced (or every `--every`-th one). Nothing is random and nothing is resized.

Sub-commands (the formats of the sets in docs/real-sets.md):

  yolo          images + YOLO txt (a folder or a .zip of them); all classes become 0
                  to_yolo.py yolo --images DIR --labels DIR|ZIP --out OUT [--prefix P]
  xywh-video    a video + one `x y w h` row per frame (pixels, top-left; 0 0 0 0 = none),
                the Anti-UAV tracker format (metric_tracker/crop_gt)
                  to_yolo.py xywh-video --video V --gt T --out OUT --prefix P --count N
  antiuav-json  a video + Anti-UAV's {"exist": [...], "gt_rect": [[x,y,w,h], ...]}
                  to_yolo.py antiuav-json --video V --json J --out OUT --prefix P --count N
  mot           a MOTChallenge sequence (img1/NNNNNN.jpg + gt/gt.txt:
                frame,id,x,y,w,h,conf,class,visibility), e.g. the UAVSwarm dataset
                  to_yolo.py mot --seq DIR --out OUT --prefix P --count N
  dvb           a video + Drone-vs-Bird rows `frame n x y w h class [x y w h class ...]`
                  to_yolo.py dvb --video V --ann T --out OUT --prefix P --count N
  nps           a video + NPS-Drones rows `frame,n,x1,y1,x2,y2[,x1,y1,x2,y2...]`
                (the re-annotation in github.com/mwaseema/Drone-Detection)
                  to_yolo.py nps --video V --ann T --out OUT --prefix P --count N
  svanstrom     a video + its `_LABELS.mat` (MATLAB groundTruth, one drone box per frame) of the
                CC0 drone detection dataset of Svanström et al.; needs `pip install mcos-decoder`.
                MATLAB's boxes are in spatial coordinates (pixel 1 centred on 1.0): moved by
                -0.5 px to the pixel-edge coordinates of YOLO
                  to_yolo.py svanstrom --video V --mat M --out OUT --prefix P --count N
  voc           images + Pascal VOC XML (Det-Fly, MAV-VID, DUT-Anti-UAV); objects whose
                name is in --names (default: drone,uav,UAV,Drone) become class 0
                  to_yolo.py voc --images DIR --xml DIR --out OUT [--prefix P]

ffmpeg is taken from $FFMPEG, else from PATH, else from the imageio-ffmpeg package when
it is installed. A video frame n is decoded with `-vf select=eq(n\\,N)` (0-based).
"""
import argparse
import json
import os
import shutil
import struct
import subprocess
import sys
import xml.etree.ElementTree as ET
import zipfile
from pathlib import Path

IMAGE_EXT = (".jpg", ".jpeg", ".png")


class ConvertError(Exception):
    pass


# ---------------------------------------------------------------- image sizes


def image_size(data):
    """(width, height) of JPEG or PNG bytes, from the header."""
    if data[:8] == b"\x89PNG\r\n\x1a\n":
        return struct.unpack(">II", data[16:24])
    if data[:2] == b"\xff\xd8":
        i = 2
        while i + 9 < len(data):
            if data[i] != 0xFF:
                i += 1
                continue
            marker = data[i + 1]
            if marker in (0xD8, 0x01) or 0xD0 <= marker <= 0xD7:
                i += 2
                continue
            seg = struct.unpack(">H", data[i + 2:i + 4])[0]
            if 0xC0 <= marker <= 0xCF and marker not in (0xC4, 0xC8, 0xCC):
                h, w = struct.unpack(">HH", data[i + 5:i + 9])
                return w, h
            i += 2 + seg
    raise ConvertError("not a JPEG or PNG, or no frame header found")


# ---------------------------------------------------------------- writing


def yolo_rows(boxes, w, h):
    """Pixel boxes (x0, y0, x1, y1) → YOLO rows, clipped to the frame; empty boxes dropped."""
    rows = []
    for x0, y0, x1, y1 in boxes:
        x0, y0 = max(0.0, min(float(w), x0)), max(0.0, min(float(h), y0))
        x1, y1 = max(0.0, min(float(w), x1)), max(0.0, min(float(h), y1))
        if x1 - x0 < 0.5 or y1 - y0 < 0.5:
            continue
        rows.append(f"0 {(x0 + x1) / 2 / w:.6f} {(y0 + y1) / 2 / h:.6f} "
                    f"{(x1 - x0) / w:.6f} {(y1 - y0) / h:.6f}\n")
    return rows


class Writer:
    def __init__(self, out):
        self.out = Path(out)
        (self.out / "images").mkdir(parents=True, exist_ok=True)
        (self.out / "labels").mkdir(parents=True, exist_ok=True)
        self.manifest = open(self.out / "manifest.tsv", "a", encoding="utf-8")
        self.written = 0

    def put(self, stem, ext, data, boxes, source, frame):
        """Writes one frame (bytes) and its label; returns the number of rows kept. The file
        gets the extension of what the bytes are (some sets store PNG frames as `.jpg`)."""
        w, h = image_size(data)
        ext = ".png" if data[:8] == b"\x89PNG\r\n\x1a\n" else (ext if ext in (".jpg", ".jpeg") else ".jpg")
        rows = yolo_rows(boxes, w, h)
        (self.out / "images" / f"{stem}{ext}").write_bytes(data)
        (self.out / "labels" / f"{stem}.txt").write_text("".join(rows), encoding="utf-8")
        self.manifest.write(f"images/{stem}{ext}\t{source}\t{frame}\t{len(rows)}\t{w}x{h}\n")
        self.written += 1
        return len(rows)

    def close(self):
        self.manifest.close()
        print(f"to_yolo: {self.written} frames -> {self.out}", file=sys.stderr)


def pick(frames, count, every):
    """Deterministic choice among the frames (sorted): every `every`-th, or `count` spread evenly."""
    frames = sorted(frames)
    if every:
        return frames[::every]
    if not count or count >= len(frames):
        return frames
    return [frames[(2 * i + 1) * len(frames) // (2 * count)] for i in range(count)]


# ---------------------------------------------------------------- video


def ffmpeg_exe():
    exe = os.environ.get("FFMPEG") or shutil.which("ffmpeg")
    if exe:
        return exe
    try:
        import imageio_ffmpeg  # optional; the binary is a plain ffmpeg
        return imageio_ffmpeg.get_ffmpeg_exe()
    except ImportError:
        raise ConvertError("no ffmpeg: set $FFMPEG, put ffmpeg on PATH or pip install imageio-ffmpeg")


def decode_frame(video, n):
    """Frame n (0-based) of a video as PNG bytes, decoded losslessly."""
    cmd = [ffmpeg_exe(), "-loglevel", "error", "-i", str(video), "-vf", f"select=eq(n\\,{n})",
           "-vframes", "1", "-f", "image2pipe", "-vcodec", "png", "-"]
    res = subprocess.run(cmd, stdin=subprocess.DEVNULL, stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                         check=False)
    if res.returncode != 0 or not res.stdout:
        raise ConvertError(f"{video}: frame {n} could not be decoded: {res.stderr.decode()[-300:]}")
    return res.stdout


def from_video(args, per_frame):
    """per_frame: {frame: [(x0, y0, x1, y1), ...]} for the frames that have drones."""
    wr = Writer(args.out)
    for n in pick([f for f, b in per_frame.items() if b], args.count, args.every):
        wr.put(f"{args.prefix}_f{n:06d}", ".png", decode_frame(args.video, n), per_frame[n],
               Path(args.video).name, n)
    wr.close()


# ---------------------------------------------------------------- formats


def parse_xywh_rows(text):
    """`x y w h` per line (space, tab or comma separated), line i = frame i."""
    out = {}
    for i, line in enumerate(text.splitlines()):
        f = line.replace(",", " ").split()
        if len(f) < 4:
            continue
        x, y, w, h = map(float, f[:4])
        out[i] = [(x, y, x + w, y + h)] if w > 0 and h > 0 else []
    return out


def parse_antiuav_json(text):
    d = json.loads(text)
    rects, exist = d.get("gt_rect", []), d.get("exist", [])
    out = {}
    for i, r in enumerate(rects):
        ok = (exist[i] if i < len(exist) else 1) and len(r) == 4 and r[2] > 0 and r[3] > 0
        out[i] = [(r[0], r[1], r[0] + r[2], r[1] + r[3])] if ok else []
    return out


def parse_mot(text, min_visibility=0.0):
    """MOTChallenge gt: frame,id,x,y,w,h,conf,class,visibility (1-based frames; conf 0 = ignore)."""
    out = {}
    for line in text.splitlines():
        f = [s.strip() for s in line.replace(" ", "").split(",")]
        if len(f) < 6 or not f[0]:
            continue
        frame, x, y, w, h = int(float(f[0])), *map(float, f[2:6])
        conf = float(f[6]) if len(f) > 6 else 1.0
        vis = float(f[8]) if len(f) > 8 else 1.0
        if conf == 0 or vis < min_visibility or w <= 0 or h <= 0:
            continue
        out.setdefault(frame, []).append((x, y, x + w, y + h))
    return out


def parse_dvb(text, classes=("drone",)):
    """Drone-vs-Bird: `frame n x y w h class ...` (0-based frames)."""
    out = {}
    for line in text.splitlines():
        f = line.split()
        if len(f) < 2:
            continue
        frame, n = int(f[0]), int(f[1])
        boxes = []
        for k in range(n):
            x, y, w, h = map(float, f[2 + 5 * k:6 + 5 * k])
            if f[6 + 5 * k] in classes:
                boxes.append((x, y, x + w, y + h))
        out[frame] = boxes
    return out


def parse_nps(text):
    """NPS-Drones (mwaseema re-annotation): `frame,n,x1,y1,x2,y2[,...]` (0-based frames)."""
    out = {}
    for line in text.splitlines():
        f = [s for s in line.replace(" ", "").split(",") if s]
        if len(f) < 2:
            continue
        frame, n = int(f[0]), int(f[1])
        out[frame] = [tuple(map(float, f[2 + 4 * k:6 + 4 * k])) for k in range(n)]
    return out


def read_svanstrom_mat(path):
    """{frame: [box]} from a Svanström `_LABELS.mat` (0-based frames, pixel-edge coordinates)."""
    try:
        import mcos_decoder  # the groundTruth objects are MATLAB MCOS: no stdlib reader
    except ImportError:
        raise ConvertError("the svanstrom labels need the mcos-decoder package: pip install mcos-decoder")
    out = {}
    for i, b in enumerate(mcos_decoder.load_groundtruth(str(path))):
        ok = b is not None and len(b) == 4 and b[2] > 0 and b[3] > 0
        out[i] = [(b[0] - 0.5, b[1] - 0.5, b[0] - 0.5 + b[2], b[1] - 0.5 + b[3])] if ok else []
    return out


def parse_voc(text, names):
    root = ET.fromstring(text)
    boxes = []
    for obj in root.iter("object"):
        if (obj.findtext("name") or "").strip() not in names:
            continue
        bb = obj.find("bndbox")
        boxes.append(tuple(float(bb.findtext(k)) for k in ("xmin", "ymin", "xmax", "ymax")))
    return boxes


# ---------------------------------------------------------------- sub-commands


def cmd_yolo(args):
    src = Path(args.labels)
    if src.suffix == ".zip":
        with zipfile.ZipFile(src) as z:
            labels = {Path(n).stem: z.read(n).decode() for n in z.namelist() if n.endswith(".txt")}
    else:
        labels = {p.stem: p.read_text() for p in src.rglob("*.txt")}
    wr = Writer(args.out)
    images = sorted(p for p in Path(args.images).rglob("*") if p.suffix.lower() in IMAGE_EXT)
    chosen = pick([p for p in images if p.stem in labels], args.count, args.every)
    for p in chosen:
        data = p.read_bytes()
        w, h = image_size(data)
        boxes = []
        for line in labels[p.stem].splitlines():
            f = line.split()
            if len(f) >= 5:
                cx, cy, bw, bh = (float(v) for v in f[1:5])
                boxes.append(((cx - bw / 2) * w, (cy - bh / 2) * h, (cx + bw / 2) * w, (cy + bh / 2) * h))
        wr.put(f"{args.prefix}{p.stem}" if args.prefix else p.stem, p.suffix.lower(), data, boxes,
               p.name, p.stem)
    wr.close()


def cmd_mot(args):
    seq = Path(args.seq)
    per_frame = parse_mot((seq / "gt" / "gt.txt").read_text(), args.min_visibility)
    wr = Writer(args.out)
    for n in pick([f for f, b in per_frame.items() if b], args.count, args.every):
        img = next((seq / "img1" / f"{n:06d}{e}" for e in IMAGE_EXT
                    if (seq / "img1" / f"{n:06d}{e}").is_file()), None)
        if img is None:
            print(f"to_yolo: {seq.name}: frame {n} has boxes but no image; skipped", file=sys.stderr)
            continue
        wr.put(f"{args.prefix}_f{n:06d}", img.suffix.lower(), img.read_bytes(), per_frame[n],
               f"{seq.name}/img1/{img.name}", n)
    wr.close()


def cmd_voc(args):
    names = set(args.names.split(","))
    wr = Writer(args.out)
    xmls = {p.stem: p for p in Path(args.xml).rglob("*.xml")}
    images = sorted(p for p in Path(args.images).rglob("*") if p.suffix.lower() in IMAGE_EXT)
    for p in pick([p for p in images if p.stem in xmls], args.count, args.every):
        boxes = parse_voc(xmls[p.stem].read_text(), names)
        wr.put(f"{args.prefix}{p.stem}" if args.prefix else p.stem, p.suffix.lower(), p.read_bytes(),
               boxes, p.name, p.stem)
    wr.close()


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    sub = ap.add_subparsers(dest="cmd", required=True)

    def common(p, video=False):
        p.add_argument("--out", required=True)
        p.add_argument("--prefix", default="")
        p.add_argument("--count", type=int, default=0, help="frames to keep, spread evenly (0 = all)")
        p.add_argument("--every", type=int, default=0, help="keep every N-th frame with drones instead")
        if video:
            p.add_argument("--video", required=True)
        return p

    p = common(sub.add_parser("yolo"))
    p.add_argument("--images", required=True)
    p.add_argument("--labels", required=True)
    p = common(sub.add_parser("xywh-video"), video=True)
    p.add_argument("--gt", required=True)
    p = common(sub.add_parser("antiuav-json"), video=True)
    p.add_argument("--json", required=True)
    p = common(sub.add_parser("mot"))
    p.add_argument("--seq", required=True)
    p.add_argument("--min-visibility", type=float, default=0.0)
    p = common(sub.add_parser("dvb"), video=True)
    p.add_argument("--ann", required=True)
    p = common(sub.add_parser("nps"), video=True)
    p.add_argument("--ann", required=True)
    p = common(sub.add_parser("svanstrom"), video=True)
    p.add_argument("--mat", required=True)
    p = common(sub.add_parser("voc"))
    p.add_argument("--images", required=True)
    p.add_argument("--xml", required=True)
    p.add_argument("--names", default="drone,uav,UAV,Drone")

    args = ap.parse_args(argv)
    try:
        if args.cmd == "yolo":
            cmd_yolo(args)
        elif args.cmd == "mot":
            cmd_mot(args)
        elif args.cmd == "voc":
            cmd_voc(args)
        elif args.cmd == "svanstrom":
            from_video(args, read_svanstrom_mat(args.mat))
        else:
            readers = {"xywh-video": ("gt", parse_xywh_rows), "antiuav-json": ("json", parse_antiuav_json),
                       "dvb": ("ann", parse_dvb), "nps": ("ann", parse_nps)}
            attr, parse = readers[args.cmd]
            from_video(args, parse(Path(getattr(args, attr)).read_text()))
    except (ConvertError, OSError, ValueError, KeyError) as e:
        sys.exit(f"to_yolo {args.cmd}: {e}")


if __name__ == "__main__":
    main()
