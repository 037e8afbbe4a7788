#!/usr/bin/env python3
"""How many statistics one preset can match on several real sets at once.

`swarmshot gap` calls a statistic "inside" when the synthetic median (or share) lies in
the real set's range: its inter-quartile range (shares: the 50 % Wilson interval). One
preset has one median per statistic, so where the real sets' ranges share no value, at
least one set must miss that statistic. For each statistic this script finds the largest
number of sets whose ranges share a value (a sweep over the range ends); the others are
forced misses. Summed over the statistics, the forced misses bound what any single
preset can reach: some set misses at least ceil(total / sets) statistics.

Usage: for each set, a gap report of the set against itself (only its `real` side is
read), then this script on their report.json files:

    swarmshot gap --real REAL_A --synthetic REAL_A --out /tmp/range/a
    swarmshot gap --real REAL_B --synthetic REAL_B --out /tmp/range/b
    python3 scripts/real_sets/common_range.py /tmp/range/a/report.json /tmp/range/b/report.json

Reads only the given files; writes nothing.
"""

import json
import math
import sys
from pathlib import Path


def real_range(statistic):
    """The real side's (low, high) range, or None when the set has no value."""
    real = statistic.get("real") or {}
    if real.get("kind") == "distribution":
        low, high = real.get("q25"), real.get("q75")
    elif real.get("kind") == "share":
        low, high = real.get("low"), real.get("high")
    else:
        return None
    if low is None or high is None:
        return None
    return (float(low), float(high))


def most_sharing(ranges):
    """The largest number of ranges that hold one common value."""
    ends = [x for r in ranges for x in r]
    return max((sum(1 for lo, hi in ranges if lo <= p <= hi) for p in ends), default=0)


def main(paths):
    if len(paths) < 2:
        sys.exit("usage: common_range.py REPORT.json REPORT.json [...]")
    reports = {}
    for path in paths:
        try:
            data = json.loads(Path(path).read_text())
            reports[path] = {s["key"]: s for s in data["statistics"]}
        except (OSError, ValueError, KeyError, TypeError) as e:
            sys.exit(f"{path}: not a swarmshot gap report.json ({e})")
    names = [Path(p).parent.name or p for p in paths]
    keys = list(next(iter(reports.values())).keys())
    total = 0
    print(f"{'statistic':30s} {'sets sharing a value':>22s}  ranges ({', '.join(names)})")
    for key in keys:
        ranges = [real_range(reports[p].get(key, {})) for p in paths]
        have = [r for r in ranges if r is not None]
        best = most_sharing(have)
        total += len(have) - best
        shown = " ".join("-" if r is None else f"[{r[0]:.3g}, {r[1]:.3g}]" for r in ranges)
        print(f"{key:30s} {best:>12d} of {len(have):<7d}  {shown}")
    bound = math.ceil(total / len(paths))
    print(f"forced misses in all: {total}; some set misses at least {bound} "
          f"of {len(keys)}, so one preset is inside on at most {len(keys) - bound} there")


if __name__ == "__main__":
    main(sys.argv[1:])
