#!/usr/bin/env python3
"""Split a real set (the layout fetch.sh writes) into two halves by a number in its names.

    split.py SET OUT_A OUT_B --key REGEX (--odd | --below N)

Each frame SET/images/NAME.{jpg,png} with its SET/labels/NAME.txt is copied to OUT_A or OUT_B
by the integer that the first group of REGEX finds in NAME: with --odd, odd numbers go to
OUT_A; with --below N, numbers under N go to OUT_A; the rest to OUT_B. A name REGEX does not
match is an error (nothing is written). The halves of docs/realism.md ("A second thermal
camera") are

    split.py /work/realsets/svanstrom-ir sv-odd sv-even --key '^svir_(\\d+)_' --odd
    split.py /work/realsets/svanstrom-ir sv-a sv-b --key '^svir_(\\d+)_' --below 79

Standard library only; OUT_A and OUT_B must not exist yet.
"""
import argparse
import re
import shutil
import sys
from pathlib import Path


def plan(images, key, odd, below):
    """[(image, label, to_a)] for every frame, or SystemExit naming a frame the key misses."""
    out = []
    for img in images:
        m = key.search(img.stem)
        if not m:
            sys.exit(f"split: {img.name}: --key {key.pattern!r} finds no number in the name")
        n = int(m.group(1))
        to_a = n % 2 == 1 if odd else n < below
        out.append((img, img.parent.parent / "labels" / f"{img.stem}.txt", to_a))
    return out


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("set")
    ap.add_argument("out_a")
    ap.add_argument("out_b")
    ap.add_argument("--key", required=True, help="regex whose first group is the number")
    rule = ap.add_mutually_exclusive_group(required=True)
    rule.add_argument("--odd", action="store_true", help="odd numbers to OUT_A")
    rule.add_argument("--below", type=int, help="numbers under N to OUT_A")
    args = ap.parse_args(argv)
    key = re.compile(args.key)
    if key.groups < 1:
        sys.exit(f"split: --key {args.key!r} has no group")
    images = sorted(p for p in (Path(args.set) / "images").iterdir()
                    if p.suffix.lower() in (".jpg", ".jpeg", ".png"))
    if not images:
        sys.exit(f"split: no frames in {args.set}/images")
    frames = plan(images, key, args.odd, args.below)
    outs = [Path(args.out_a), Path(args.out_b)]
    for o in outs:
        if o.exists():
            sys.exit(f"split: {o} exists; give a new folder")
    for o in outs:
        (o / "images").mkdir(parents=True)
        (o / "labels").mkdir()
    counts = [0, 0]
    for img, label, to_a in frames:
        o = outs[0] if to_a else outs[1]
        shutil.copyfile(img, o / "images" / img.name)
        if label.is_file():
            shutil.copyfile(label, o / "labels" / label.name)
        counts[0 if to_a else 1] += 1
    print(f"split: {counts[0]} frames -> {outs[0]}, {counts[1]} -> {outs[1]}")


if __name__ == "__main__":
    main()
