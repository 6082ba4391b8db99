"""The calibration table of drops report from a summary's calibration columns, shared by
speeds.py and swing_ups.py. Standard library only.

Per group (variant and prior or damage), from episode 2 on the episodes with a new policy and
the replays of the best one apart, and episode 1 (predicted before any real data by the prior
simulator alone, whose rollouts agree: a band of zero width) apart too: how many, the fraction
whose real return fell inside the model's 5-95 % band, the fraction inside the range of the
model's rollouts (above the lowest predicted return and below the highest:
0 < calibration_quantile < 1), and the median gap predicted - real return.

What a calibrated model scores (the real return one more draw from the rollouts' distribution):
90 % inside the band as drops computes it since the band moved to Hyndman & Fan's definition 6
(summaries made before that used definition 7, which holds 81 % with 20 rollouts), and
(n - 1) / (n + 1) inside the range of n rollouts (90.5 % for 20) whatever the drops version.
The band lies inside the range, so for an older summary the two bracket the definition-6 rate.
"""

import statistics
from collections import defaultdict


def new_table():
    """group key -> (new policies, replays, episode 1), each a list of (inside the band, inside
    the range, gap)."""
    return defaultdict(lambda: ([], [], []))


def add(table, key, row):
    """Adds a summary row to group key when the row has a calibration (a predicted new policy
    or replay); rows without one are skipped."""
    if row.get("calibration_gap"):
        which = 2 if row["episode"] == "1" else 1 if row["calibration_replay"] == "1" else 0
        q = float(row["calibration_quantile"])
        table[key][which].append(
            (row["calibration_inside_band"] == "1", 0 < q < 1, float(row["calibration_gap"])))


def print_table(table, column, name=lambda key: key[1], order=lambda key: key, digits=2):
    """Prints the markdown table, one row per group: `variant | <column>` named by name(key),
    groups sorted by order(key), gaps with `digits` decimals. Prints nothing for an empty table."""
    if not table:
        return
    print()
    print(f"| variant | {column} | new policies | real return inside the 5-95 % band | inside the "
          "rollouts' range | median gap (predicted - real) | replays | inside the band | inside "
          "the range | median gap | episode 1 | inside the band | median gap |")
    print("|---|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|")
    for key, (new, replays, first) in sorted(table.items(), key=lambda item: order(item[0])):
        cells = []
        for eps in (new, replays, first):
            inside = sum(1 for i, _, _ in eps if i)
            in_range = sum(1 for _, r, _ in eps if r)
            cells += [str(len(eps)), f"{100 * inside / len(eps):.0f} %" if eps else "-"]
            if eps is not first:  # the range and the band are one point there
                cells.append(f"{100 * in_range / len(eps):.0f} %" if eps else "-")
            cells.append(f"{statistics.median(g for _, _, g in eps):+.{digits}f}" if eps else "-")
        print(f"| {key[0]} | {name(key)} | " + " | ".join(cells) + " |")
