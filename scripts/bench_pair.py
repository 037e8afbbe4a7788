#!/usr/bin/env python3
"""Time a command as a whole process, alone or paired against a second one.

  scripts/bench_pair.py [-n RUNS] [--warmup N] [--timeout S] [--vs 'COMMAND B'] -- COMMAND A ...

Runs A (and B, in turn: A B A B …) RUNS times after N uncounted warm-up runs, and prints the
minimum, median and maximum of each one's wall, user, system and CPU seconds and, with --vs,
the ratios A/B taken pair by pair (so a machine whose speed drifts still compares fairly).
The commands' output is discarded; their exit codes are printed when not 0. --timeout bounds
the whole call: runs not started by then are skipped. B is split as a shell splits words,
and neither command is given a shell. Used for the figures in docs/benchmarks.md.
"""
import argparse
import os
import resource
import shlex
import statistics
import subprocess
import sys
import time


def run(cmd):
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    start = time.perf_counter()
    rc = subprocess.run(cmd, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL).returncode
    wall = time.perf_counter() - start
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    user, sys_ = after.ru_utime - before.ru_utime, after.ru_stime - before.ru_stime
    if rc != 0:
        print(f"exit code {rc}: {shlex.join(cmd)}", file=sys.stderr)
    return {"wall s": wall, "user s": user, "sys s": sys_, "cpu s": user + sys_}


def row(label, values):
    return f"{label:<14}{min(values):>12.4f}{statistics.median(values):>12.4f}{max(values):>12.4f}"


def main():
    p = argparse.ArgumentParser(description=__doc__.split("\n")[1])
    p.add_argument("-n", type=int, default=5)
    p.add_argument("--warmup", type=int, default=1)
    p.add_argument("--timeout", type=float, default=3600.0)
    p.add_argument("--vs")
    p.add_argument("command", nargs=argparse.REMAINDER)
    a = p.parse_args()
    cmd_a = a.command[1:] if a.command[:1] == ["--"] else a.command
    if not cmd_a or a.n < 1:
        p.error("a command after -- and -n of at least 1")
    cmds = {"A": cmd_a} | ({"B": shlex.split(a.vs)} if a.vs else {})
    deadline = time.monotonic() + a.timeout
    for _ in range(a.warmup):
        for cmd in cmds.values():
            run(cmd)
    runs = {k: [] for k in cmds}
    for _ in range(a.n):
        if time.monotonic() > deadline:
            break
        for k, cmd in cmds.items():
            runs[k].append(run(cmd))
    counted = min(len(v) for v in runs.values())
    print(f"{os.cpu_count()} cpus; {counted} counted runs each; " + "; ".join(f"{k}: {shlex.join(c)}" for k, c in cmds.items()))
    print(f"{'':<14}{'min':>12}{'median':>12}{'max':>12}")
    for k in cmds:
        for m in ("user s", "sys s", "cpu s", "wall s"):
            print(row(f"{k} {m}", [r[m] for r in runs[k][:counted]]))
    if "B" in cmds:
        for m in ("user s", "cpu s", "wall s"):
            print(row(f"A/B {m.split()[0]}", [x[m] / y[m] for x, y in zip(runs["A"], runs["B"]) if y[m] > 0]))


if __name__ == "__main__":
    main()
