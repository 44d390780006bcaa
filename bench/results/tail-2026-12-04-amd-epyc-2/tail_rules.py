"""The series' tail rules against 30 explicit bounces (issue 29; luxbake::series).

series.json holds, per room, the energies `cargo xtask bake --scene NAME --bounces 30` reports
in its manifest (stats.series: direct, increments, reflected). For K = 4, 5, 6 this prints the
error of the converged total extrapolated after bounce K, as a % of the total of all 30 bounces
(the bounces after 30 are below 10^-5 of it), for three rules: Aitken's trend of the ratios
(the rule before 2026-12-04), the plain last ratio, and the predicted next ratio (now).

    python3 tail_rules.py [series.json]
"""
import json
import sys
from pathlib import Path

MAX_RATIO, MAX_TREND_RATE = 0.995, 0.8


def ratio(inc, k):
    """lambda_k of bounce k (1-based), clamped as luxbake clamps it."""
    return min(max(inc[k - 1] / inc[k - 2], 0.0), MAX_RATIO)


def trend(inc, k):
    """The rule before: the plain tail, or the geometric trend of the last three ratios."""
    now = ratio(inc, k)
    if k >= 4:
        a, b = ratio(inc, k - 2), ratio(inc, k - 1)
        d1, d2 = b - a, now - b
        q = d2 / d1 if d1 != 0 else 0.0
        if 0.0 < q <= MAX_TREND_RATE:
            limit = min(max(now + d2 * q / (1 - q), 0.0), MAX_RATIO)
            f, product, gap = 0.0, 1.0, limit - now
            for _ in range(20000):
                gap *= q
                product *= min(max(limit - gap, 0.0), MAX_RATIO)
                f += product
                if product <= 1e-12 * f:
                    break
            return inc[k - 1] * f
    return inc[k - 1] * now / (1 - now)


def plain(inc, k):
    now = ratio(inc, k)
    return inc[k - 1] * now / (1 - now)


def predicted(inc, refl, k):
    """Now: the next increment is the reflected energy times the mean retention of the two
    bounces before; the tail extrapolates with the predicted ratio."""
    chi = 0.5 * (inc[k - 1] / refl[k - 2] + inc[k - 2] / refl[k - 3])
    now = min(max(chi * refl[k - 1] / inc[k - 1], 0.0), MAX_RATIO)
    return inc[k - 1] * now / (1 - now)


def main():
    path = Path(sys.argv[1]) if len(sys.argv) > 1 else Path(__file__).with_name("series.json")
    rooms = json.loads(path.read_text())["series"]
    print("| room | K | tail share | Aitken trend (before) | plain λ_K | predicted (now) |")
    print("|---|--:|--:|--:|--:|--:|")
    for room, s in rooms.items():
        inc, refl = s["increments"], s["reflected"]
        total = s["direct"] + sum(inc)
        for k in (4, 5, 6):
            exact = sum(inc[k:])
            errs = [trend(inc, k), plain(inc, k), predicted(inc, refl, k)]
            cells = " | ".join(f"{100 * (e - exact) / total:+.2f} %" for e in errs)
            print(f"| {room} | {k} | {100 * exact / total:.1f} % | {cells} |")


if __name__ == "__main__":
    main()
