#!/usr/bin/env python3
"""The two markdown tables of comparison.md, from two RTI results folders.

    python3 compare.py ../2026-12-06-lavapipe-rti-wg-a0-partial .

Growth: the log-slope d ln(a)/dt over each 4 ms window, the ln of the ratio of the values
recorded at the window's ends over 4 ms, for the lowest grain's depth
(lowest-grain-depth-vs-upper-bound.csv) and the lowest layer's mode cos kx cos kz
(lowest-layer-mode-vs-upper-bound.csv), windows both folders hold. Fluid: the
`fluid_layers` snapshot lines of each folder's fluid.txt from 50 ms, times both hold.
"""
import csv
import math
import re
import sys

WINDOW = 0.004  # s
FLUID_FROM_MS = 50


def window_slopes(path):
    """Window index k (from k WINDOW to (k + 1) WINDOW) -> log-slope, 1/s."""
    at = {}
    for t, a in ((float(r[0]), float(r[1])) for r in list(csv.reader(open(path)))[1:]):
        k = round(t / WINDOW)
        if abs(t - k * WINDOW) < 2.5e-4:  # records every 2 ms, within a quarter step
            at[k] = a
    return {k: math.log(at[k + 1] / at[k]) / WINDOW for k in at if k + 1 in at}


def growth_table(plain, dsph):
    series = [window_slopes(f"{d}/{name}") for name in
              ("lowest-grain-depth-vs-upper-bound.csv", "lowest-layer-mode-vs-upper-bound.csv")
              for d in (plain, dsph)]
    rows = ["| window (ms) | lowest grain: plain | δ-SPH | lowest layer's mode cos kx cos kz: plain | δ-SPH |",
            "|---|---|---|---|---|"]
    for k in sorted(set.intersection(*(set(s) for s in series))):
        ms = round(WINDOW * 1e3)
        rows.append(f"| {ms * k}–{ms * (k + 1)} | " + " | ".join(f"{s[k]:.2f}" for s in series) + " |")
    return rows


SNAPSHOT = re.compile(
    r"t ([\d.e+-]+) s: mean u \(([^,]+), [^,]+, ([^)]+)\) m/s, largest speed ([\d.e+-]+) m/s "
    r"at y ([\d.e+-]+) m, .*p ([-\d.]+)–([-\d.]+) Pa, p lowest layer ([-\d.]+) Pa, highest ([-\d.]+) Pa")


def snapshots(path):
    """Snapshot time in ms -> the table's columns for one run."""
    out = {}
    for m in filter(None, map(SNAPSHOT.match, open(path))):
        t, ux, uz, v, y, pmin, pmax, low, high = m.groups()
        out[round(float(t) * 1e3)] = (
            f"{float(v) * 1e3:.2f} at {float(y) * 1e3:.2f}", f"{pmin} to {pmax}",
            f"{low} / {high}", f"{max(abs(float(ux)), abs(float(uz))):.1e}")
    return out


def fluid_table(plain, dsph):
    a, b = snapshots(f"{plain}/fluid.txt"), snapshots(f"{dsph}/fluid.txt")
    rows = ["| t (ms) | largest speed (mm/s), at y (mm): plain | δ-SPH | pressure range (Pa): plain | δ-SPH "
            "| lowest / highest layer (Pa): plain | δ-SPH | largest mean lateral u (m/s): plain | δ-SPH |",
            "|---|---|---|---|---|---|---|---|---|"]
    for t in sorted(set(a) & set(b)):
        if t >= FLUID_FROM_MS:
            rows.append(f"| {t} | " + " | ".join(f"{x} | {y}" for x, y in zip(a[t], b[t])) + " |")
    return rows


if __name__ == "__main__":
    plain, dsph = sys.argv[1:3]
    print("\n".join(growth_table(plain, dsph) + [""] + fluid_table(plain, dsph)))
