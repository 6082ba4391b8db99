#!/usr/bin/env python3
"""Walking speeds of hexapod runs, per algorithm variant and damage, from a summary CSV.

  speeds.py SUMMARY.csv [CAMPAIGN] [--episodes 7,8,9,10]

SUMMARY.csv: a hexapod summary (results/summaries/hexapod*.csv or one made by
summarize_campaign.py); CAMPAIGN: only the rows of that campaign. Per variant and damage it
prints the runs and, at each episode asked for, the median walking speed over the runs with a
percentile-bootstrap 95 % interval (the runs resampled with replacement 20,000 times from a fixed
seed, so the same summary gives the same interval), then each run's speeds and the runs that fell
(a `*` marks an episode in which the robot fell: a real return below -5, as a fall costs -10 per
step left while walking returns stay within about -1 and 3). When the summary has the calibration columns, a
second table gives per variant and damage the episodes with a new policy and the replays of the
best one apart: how many, the fraction whose real return fell inside the model's 5-95 % band and
the median gap predicted - real return (drops report's numbers). Standard library only.
"""

import argparse
import csv
import random
import signal
import statistics
from collections import defaultdict

import calibration as cal

RESAMPLES = 20000
SEED = 1
FALL_RETURN = -5.0


def bootstrap_median(values, rng):
    """Percentile-bootstrap 95 % interval of the median of values."""
    medians = sorted(statistics.median(rng.choices(values, k=len(values)))
                     for _ in range(RESAMPLES))
    return medians[int(0.025 * RESAMPLES)], medians[int(0.975 * RESAMPLES) - 1]


def main():
    parser = argparse.ArgumentParser(description=__doc__,
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("summary", metavar="SUMMARY.csv", help="a hexapod summary CSV")
    parser.add_argument("campaign", metavar="CAMPAIGN", nargs="?",
                        help="only the rows of this campaign")
    parser.add_argument("--episodes", default="7,8,9,10", metavar="LIST",
                        help="comma-separated episodes, e.g. 4,8 (default 7,8,9,10)")
    args = parser.parse_args()
    try:
        episodes = [int(e) for e in args.episodes.split(",")]
    except ValueError:
        parser.error(f"--episodes {args.episodes}: a comma-separated list of episodes, e.g. 4,8")
    if min(episodes) < 1:
        parser.error(f"--episodes {args.episodes}: an episode is 1 or more")
    campaign = args.campaign
    runs = defaultdict(dict)  # (variant, damage, seed) -> {episode: (speed, fell)}
    calibration = cal.new_table()  # (variant, damage) -> (new policies, replays, episode 1)
    with open(args.summary, newline="") as f:
        for row in csv.DictReader(f):
            if campaign is not None and row["campaign"] != campaign:
                continue
            key = (row["variant"], row["damage"], int(row["seed"]))
            fell = float(row["real_return"]) < FALL_RETURN
            runs[key][int(row["episode"])] = (float(row["speed_m_s"]), fell)
            cal.add(calibration, key[:2], row)
    if not runs:
        raise SystemExit(f"{args.summary}: no runs" + (f" of campaign {campaign}" if campaign else ""))
    groups = defaultdict(list)
    for (variant, damage, seed), eps in sorted(runs.items()):
        groups[(variant, damage)].append((seed, [eps[e] for e in sorted(eps)]))
    rng = random.Random(SEED)
    print("| variant | damage | runs | " + " | ".join(f"episode {e}" for e in episodes) + " |")
    print("|---|---|---:|" + "---|" * len(episodes))
    for (variant, damage), rs in sorted(groups.items()):
        cells = []
        for e in episodes:
            values = [r[1][e - 1][0] for r in rs if len(r[1]) >= e]
            if not values:
                cells.append("-")
                continue
            lo, hi = bootstrap_median(values, rng)
            cells.append(f"{statistics.median(values):.3f} [{lo:.3f}, {hi:.3f}]")
        print(f"| {variant} | {damage} | {len(rs)} | " + " | ".join(cells) + " |")
    print()
    print("| variant | damage | seed | speed per episode (m/s; * = fell) | falls after episode 3 |")
    print("|---|---|---:|---|---:|")
    for (variant, damage), rs in sorted(groups.items()):
        for seed, eps in rs:
            speeds = " ".join(f"{s:.3f}" + ("*" if fell else "") for s, fell in eps)
            falls = sum(1 for _, fell in eps[3:] if fell)
            print(f"| {variant} | {damage} | {seed} | {speeds} | {falls} |")
    cal.print_table(calibration, "damage", digits=3)

if __name__ == "__main__":
    # a reader that stops early (| head) ends the script quietly, as it would a Unix tool
    signal.signal(signal.SIGPIPE, signal.SIG_DFL)
    main()
