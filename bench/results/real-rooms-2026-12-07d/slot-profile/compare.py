#!/usr/bin/env python3
"""Bias and seed-to-seed spread of bakes read at points across the lounge's slot.

    python3 compare.py ../../real-rooms-2026-12-07c/slot-profile/reference.csv default-points.csv ...
    python3 compare.py --per-seed REFERENCE.csv RUN-points.csv ...

Each CSV after the reference is a `bench refcheck --seeds N --references REFERENCE.csv`
per-point file (`total_lux_<seed>` columns, same rows as the reference); prints per point its
height y, its z and the reference's lux, then per file the bias of the seeds' mean and the
standard deviation over the seeds (with two or more), both relative to the reference, in
percent; with `--per-seed`, each seed's relative error instead.
"""
import csv
import statistics as st
import sys


def rows(path):
    with open(path) as f:
        return list(csv.DictReader(line for line in f if not line.startswith("#")))


def main(reference, runs, per_seed):
    ref = rows(reference)
    bakes = [rows(r) for r in runs]
    print("y [m]  z [m]   Radiance [lx]  " + "  ".join(f"{r[-28:]:>28s}" for r in runs))
    for i, r in enumerate(ref):
        lux = float(r["lux"])
        line = f"{float(r['y']):5.2f}  {float(r['z']):+6.3f}  {lux:12.3f}  "
        for b in bakes:
            assert len(b) == len(ref), "a bake's points differ from the reference's"
            v = [float(b[i][k]) for k in b[i] if k.startswith("total_lux_")]
            if per_seed:
                cell = " ".join(f"{100 * (x / lux - 1):+.1f}" for x in v) + " %"
            elif len(v) > 1:
                cell = f"{100 * (st.mean(v) / lux - 1):+.1f} ± {100 * st.stdev(v) / lux:.1f} %"
            else:
                cell = f"{100 * (v[0] / lux - 1):+.1f} %"
            line += f"  {cell:>28s}"
        print(line)


if __name__ == "__main__":
    args = sys.argv[1:]
    per_seed = "--per-seed" in args
    args = [a for a in args if a != "--per-seed"]
    main(args[0], args[1:], per_seed)
