#!/usr/bin/env python3
"""Per surface kind, and the furniture split into the points in a gap behind it and the others.

    python3 split.py ROOM-PRESET-points.csv ../../references/real_ROOM.csv

Reads a `bench refcheck --seeds N` per-point CSV (`total_lux_<seed>` columns) and the reference
it was compared with (same rows, same order) and prints, per set of points, the mean over the
seeds of the mean |relative error| and of the bias, in percent. A gap point is a point on the
back of the bookcase (normal -x), the cabinet or the sideboard (normal -z), the faces 2.5-7.5 cm
from a wall in bench/scenes/real_*.toml.
"""
import csv
import statistics as st
import sys


def rows(path):
    with open(path) as f:
        return list(csv.DictReader(line for line in f if not line.startswith("#")))


def in_gap(r):
    if r["object"] == "bookcase":
        return float(r["nx"]) < -0.5
    return r["object"] in ("cabinet", "sideboard") and float(r["nz"]) < -0.5


def main(points_csv, reference_csv):
    points, ref = rows(points_csv), rows(reference_csv)
    assert len(points) == len(ref), "the points and the reference differ in length"
    seeds = [k for k in points[0] if k.startswith("total_lux_")]
    sets = {
        "ceiling": lambda r: r["surface"] == "ceiling",
        "floor": lambda r: r["surface"] == "floor",
        "walls": lambda r: r["surface"] == "wall",
        "furniture": lambda r: r["surface"] == "furniture",
        "furniture outside the gap": lambda r: r["surface"] == "furniture" and not in_gap(r),
        "the gap": lambda r: r["surface"] == "furniture" and in_gap(r),
    }
    for name, keep in sets.items():
        pairs = [(p, r) for p, r in zip(points, ref) if keep(r)]
        if not pairs:
            continue
        mean_abs, bias = [], []
        for s in seeds:
            rel = [(float(p[s]) - float(r["lux"])) / float(r["lux"]) for p, r in pairs]
            mean_abs.append(st.mean(abs(e) for e in rel))
            bias.append(st.mean(rel))
        print(f"{name} ({len(pairs)} points): {100 * st.mean(mean_abs):.3f} / "
              f"{100 * st.mean(bias):+.2f} %")


if __name__ == "__main__":
    main(*sys.argv[1:3])
