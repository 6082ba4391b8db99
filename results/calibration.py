"""The calibration table of drops report from a summary's calibration columns, shared by
speeds.py and swing_ups.py. Standard library only.

Per group (variant and prior or damage), the episodes with a new policy and the replays of the
best one apart: how many, the fraction whose real return fell inside the model's 5-95 % band,
and the median gap predicted - real return.
"""

import statistics
from collections import defaultdict


def new_table():
    """group key -> (new policies, replays), each a list of (inside the band, gap)."""
    return defaultdict(lambda: ([], []))


def add(table, key, row):
    """Adds a summary row to group key when the row has a calibration (a predicted new policy
    or replay); rows without one are skipped."""
    if row.get("calibration_gap"):
        replay = row["calibration_replay"] == "1"
        table[key][replay].append(
            (row["calibration_inside_band"] == "1", float(row["calibration_gap"])))


def print_table(table, column, name=lambda key: key[1], order=lambda key: key, digits=2):
    """Prints the markdown table, one row per group: `variant | <column>` named by name(key),
    groups sorted by order(key), gaps with `digits` decimals. Prints nothing for an empty table."""
    if not table:
        return
    print()
    print(f"| variant | {column} | new policies | real return inside the 5-95 % band | median gap "
          "(predicted - real) | replays | inside | median gap |")
    print("|---|---|---:|---:|---:|---:|---:|---:|")
    for key, (new, replays) in sorted(table.items(), key=lambda item: order(item[0])):
        cells = []
        for eps in (new, replays):
            inside = sum(1 for i, _ in eps if i)
            cells += [str(len(eps)), f"{100 * inside / len(eps):.0f} %" if eps else "-",
                      f"{statistics.median(g for _, g in eps):+.{digits}f}" if eps else "-"]
        print(f"| {key[0]} | {name(key)} | " + " | ".join(cells) + " |")
