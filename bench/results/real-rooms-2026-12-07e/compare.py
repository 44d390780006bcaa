#!/usr/bin/env python3
"""The slot profile's error per point for several `bench refcheck --references` runs.

    python3 compare.py slot-profile/*-points.csv
    python3 compare.py slot-profile-2/*-points.csv

Each CSV is a `bench refcheck --seeds N --references REFERENCE` per-point file (`rel_<seed>`
columns: (bake - reference) / reference), all of them against the same reference. Prints a
Markdown table: per point its height y, its z and the reference's lux, per file the seeds'
relative errors in percent.
"""
import csv
import sys


def rows(path):
    with open(path) as f:
        return list(csv.DictReader(line for line in f if not line.startswith("#")))


def main(paths):
    runs = [rows(p) for p in paths]
    names = [p.rsplit("/", 1)[-1].removesuffix("-points.csv") for p in paths]
    print("| y [m] | z [m] | Radiance [lx] | " + " | ".join(f"`{n}`" for n in names) + " |")
    print("|--:|--:|--:|" + "--:|" * len(names))
    for i, r in enumerate(runs[0]):
        cells = []
        for run in runs:
            seeds = [k for k in run[i] if k.startswith("rel_")]
            cells.append(" ".join(f"{100 * float(run[i][s]):+.1f}" for s in seeds))
        print(f"| {float(r['y']):.2f} | {float(r['z']):+.3f} | {float(r['lux']):.3f} | "
              + " | ".join(cells) + " |")


if __name__ == "__main__":
    main(sys.argv[1:])
