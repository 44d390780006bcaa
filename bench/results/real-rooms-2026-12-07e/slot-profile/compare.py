#!/usr/bin/env python3
"""The slot profile's error per point for several `bench refcheck --references` runs.

    python3 compare.py *-points.csv

Each CSV is a `bench refcheck --seeds N --references
../../real-rooms-2026-12-07c/slot-profile/reference.csv` per-point file (`rel_<seed>` columns:
(bake - reference) / reference). Prints a Markdown table: per point its z and Radiance lux,
per file the seeds' relative errors in percent.
"""
import csv
import sys


def rows(path):
    with open(path) as f:
        return list(csv.DictReader(line for line in f if not line.startswith("#")))


def main(paths):
    runs = [rows(p) for p in paths]
    names = [p.rsplit("/", 1)[-1].removesuffix("-points.csv") for p in paths]
    print("| z [m] | Radiance [lx] | " + " | ".join(f"`{n}`" for n in names) + " |")
    print("|--:|--:|" + "--:|" * len(names))
    for i, r in enumerate(runs[0]):
        cells = []
        for run in runs:
            seeds = [k for k in run[i] if k.startswith("rel_")]
            cells.append(" ".join(f"{100 * float(run[i][s]):+.1f}" for s in seeds))
        print(f"| {float(r['z']):.3f} | {float(r['lux']):.3f} | " + " | ".join(cells) + " |")


if __name__ == "__main__":
    main(sys.argv[1:])
