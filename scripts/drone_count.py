#!/usr/bin/env python3
"""Time and peak memory a frame against the number of drones, as a table and an SVG plot.

  scripts/drone_count.py [--swarmshot PATH] [--preset presets/bench/peer_moving.ron]
                         [--counts 1,15,150,1500,15000] [--frames 10,10,10,3,1]
                         [--runs 3] --out DIR

For each count N the preset is copied into DIR with `count: (N, N)` (its relative paths made
absolute), and `swarmshot batch COPY --out DIR/run --limit F --overwrite` runs RUNS times as a
whole process. Per count it prints the median wall time a frame (the whole process over F
frames, start-up included, divided by F) and the largest peak resident memory of the runs
(the child's ru_maxrss), writes them to DIR/drone_count.csv and draws DIR/drone_count.svg
(log-log: ms a frame and MiB against drones). Writes only inside DIR; needs no Python
package beyond the standard library. Used for the drone-count figures in docs/benchmarks.md.
"""
import argparse
import math
import os
import re
import statistics
import subprocess
import sys
import time
from pathlib import Path


def preset_for(source: Path, count: int, out: Path) -> Path:
    text = source.read_text()
    text, n = re.subn(r"count: \(\d+, \d+\)", f"count: ({count}, {count})", text, count=1)
    if n != 1:
        sys.exit(f"{source}: no `count: (N, N)` to change")
    # Paths in the preset are relative to its folder: make them absolute for the copy.
    base = source.resolve().parent
    text = re.sub(r'"(\.\.?/[^"]*)"', lambda m: '"' + str((base / m.group(1)).resolve()) + '"', text)
    path = out / f"drones_{count}.ron"
    path.write_text(text)
    return path


def run_once(cmd):
    start = time.perf_counter()
    proc = subprocess.Popen(cmd, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    _, status, usage = os.wait4(proc.pid, 0)
    wall = time.perf_counter() - start
    if status != 0:
        sys.exit(f"exit status {status}: {' '.join(cmd)}")
    return wall, usage.ru_maxrss / 1024.0  # KiB -> MiB


def svg(rows, path: Path):
    w, h, left, right, top, bottom = 640, 400, 70, 70, 30, 50
    xs = [math.log10(r[0]) for r in rows]
    x0, x1 = min(xs), max(xs) if max(xs) > min(xs) else min(xs) + 1

    def axis(values):
        lo, hi = math.floor(math.log10(min(values))), math.ceil(math.log10(max(values)))
        return lo, hi if hi > lo else lo + 1

    ms_lo, ms_hi = axis([r[1] for r in rows])
    mb_lo, mb_hi = axis([r[2] for r in rows])
    px = lambda v: left + (math.log10(v) - x0) / (x1 - x0) * (w - left - right)
    py = lambda v, lo, hi: h - bottom - (math.log10(v) - lo) / (hi - lo) * (h - top - bottom)
    out = [f'<svg xmlns="http://www.w3.org/2000/svg" width="{w}" height="{h}" font-family="sans-serif" font-size="12">',
           f'<rect width="{w}" height="{h}" fill="white"/>',
           f'<text x="{w / 2}" y="18" text-anchor="middle">time and peak memory against drones a frame</text>']
    for e in range(ms_lo, ms_hi + 1):
        y = py(10 ** e, ms_lo, ms_hi)
        out.append(f'<line x1="{left}" x2="{w - right}" y1="{y:.1f}" y2="{y:.1f}" stroke="#ddd"/>')
        out.append(f'<text x="{left - 6}" y="{y + 4:.1f}" text-anchor="end" fill="#1f77b4">{10 ** e:g} ms</text>')
    for e in range(mb_lo, mb_hi + 1):
        y = py(10 ** e, mb_lo, mb_hi)
        out.append(f'<text x="{w - right + 6}" y="{y + 4:.1f}" fill="#d62728">{10 ** e:g} MiB</text>')
    for r in rows:
        x = px(r[0])
        out.append(f'<text x="{x:.1f}" y="{h - bottom + 18}" text-anchor="middle">{r[0]}</text>')
    out.append(f'<text x="{w / 2}" y="{h - 10}" text-anchor="middle">drones a frame</text>')
    for col, lo, hi, colour in ((1, ms_lo, ms_hi, "#1f77b4"), (2, mb_lo, mb_hi, "#d62728")):
        points = " ".join(f"{px(r[0]):.1f},{py(r[col], lo, hi):.1f}" for r in rows)
        out.append(f'<polyline points="{points}" fill="none" stroke="{colour}" stroke-width="2"/>')
        out += [f'<circle cx="{px(r[0]):.1f}" cy="{py(r[col], lo, hi):.1f}" r="3" fill="{colour}"/>' for r in rows]
    out.append("</svg>")
    path.write_text("\n".join(out) + "\n")


def main():
    p = argparse.ArgumentParser(description=__doc__.split("\n")[1])
    p.add_argument("--swarmshot", default="target/release/swarmshot")
    p.add_argument("--preset", default="presets/bench/peer_moving.ron")
    p.add_argument("--counts", default="1,15,150,1500,15000")
    p.add_argument("--frames", default="10,10,10,3,1")
    p.add_argument("--runs", type=int, default=3)
    p.add_argument("--out", required=True)
    a = p.parse_args()
    counts = [int(c) for c in a.counts.split(",")]
    frames = [int(f) for f in a.frames.split(",")]
    if len(frames) != len(counts) or min(counts) < 1 or min(frames) < 1 or a.runs < 1:
        p.error("--counts and --frames: as many positive numbers each; --runs at least 1")
    out = Path(a.out)
    out.mkdir(parents=True, exist_ok=True)
    rows = []
    for n, f in zip(counts, frames):
        preset = preset_for(Path(a.preset), n, out)
        cmd = [a.swarmshot, "batch", str(preset), "--out", str(out / "run"), "--limit", str(f), "--overwrite"]
        runs = [run_once(cmd) for _ in range(a.runs)]
        ms = statistics.median(r[0] for r in runs) / f * 1000.0
        mib = max(r[1] for r in runs)
        rows.append((n, ms, mib))
        print(f"{n:>6} drones: {ms:9.1f} ms a frame, peak {mib:6.0f} MiB ({a.runs} runs of {f} frames)", flush=True)
    (out / "drone_count.csv").write_text("drones,ms_per_frame,peak_mib\n" + "".join(f"{n},{ms:.1f},{mib:.0f}\n" for n, ms, mib in rows))
    svg(rows, out / "drone_count.svg")
    print(f"wrote {out / 'drone_count.csv'} and {out / 'drone_count.svg'}")


if __name__ == "__main__":
    main()
