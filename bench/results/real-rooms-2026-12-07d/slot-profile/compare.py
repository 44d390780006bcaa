#!/usr/bin/env python3
"""Bias and seed-to-seed spread of bakes read at the lounge slot's ten points.

    python3 compare.py ../../real-rooms-2026-12-07c/slot-profile/reference.csv default-points.csv ...

Each CSV after the reference is a `bench refcheck --seeds N --references reference.csv`
per-point file (`total_lux_<seed>` columns, same rows as the reference); prints per point the
bias of the seeds' mean and the standard deviation over the seeds, both relative to the
reference, in percent.
"""
import csv
import statistics as st
import sys


def rows(path):
    with open(path) as f:
        return list(csv.DictReader(line for line in f if not line.startswith("#")))


def main(reference, runs):
    ref = rows(reference)
    bakes = [rows(r) for r in runs]
    print("z [m]   Radiance [lx]  " + "  ".join(f"{r[-28:]:>28s}" for r in runs))
    for i, r in enumerate(ref):
        lux = float(r["lux"])
        line = f"{float(r['z']):5.3f}  {lux:12.3f}  "
        for b in bakes:
            assert len(b) == len(ref), "a bake's points differ from the reference's"
            v = [float(b[i][k]) for k in b[i] if k.startswith("total_lux_")]
            line += f"  {100 * (st.mean(v) / lux - 1):+19.1f} ± {100 * st.stdev(v) / lux:4.1f} %"
        print(line)


if __name__ == "__main__":
    main(sys.argv[1], sys.argv[2:])
