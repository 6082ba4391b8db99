#!/usr/bin/env python3
"""Swing-ups of pendubot runs, per algorithm variant and prior, from a summary CSV.

  swing_ups.py SUMMARY.csv [CAMPAIGN] [--by EPISODE]

SUMMARY.csv: a pendubot summary (results/summaries/pendubot.csv or one made by
summarize_campaign.py); CAMPAIGN: only the rows of that campaign. Per variant and prior it prints
the runs, how many swung up (a real return >= 14) by episode EPISODE (default 8), how many of
those held it (never more than 2 below their best return from the swing-up on, to the last
episode), the first swing-up episode of each run ("-" for none), and the median real return at
episode EPISODE and at the last episode. When the summary has the calibration columns
(summarize_campaign.py), a second table gives per variant and prior the episodes with a new
policy and the replays of the best one apart: how many, the fraction whose real return fell
inside the model's 5-95 % band, and the median gap predicted - real (drops report's numbers).
Standard library only.
"""

import argparse
import csv
import signal
import statistics
from collections import defaultdict

import calibration as cal

SWING_UP = 14.0  # a return that holds the pendubot upright for most of a 2.5 s episode
HOLD_MARGIN = 2.0
# Table I's priors in the paper's order, A-D
PRIORS = {"tunable-useful": "A", "tunable": "B", "tunable-misleading": "C", "partially-tunable": "D"}


def main():
    parser = argparse.ArgumentParser(description=__doc__,
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("summary", metavar="SUMMARY.csv", help="a pendubot summary CSV")
    parser.add_argument("campaign", metavar="CAMPAIGN", nargs="?",
                        help="only the rows of this campaign")
    parser.add_argument("--by", type=int, default=8, metavar="EPISODE",
                        help="count the swing-ups by this episode (default 8)")
    args = parser.parse_args()
    if args.by < 1:
        parser.error(f"--by {args.by}: an episode is 1 or more")
    by, campaign = args.by, args.campaign
    runs = defaultdict(dict)  # (variant, prior, seed) -> {episode: return}
    calibration = cal.new_table()  # (variant, prior) -> (new policies, replays, episode 1)
    with open(args.summary, newline="") as f:
        for row in csv.DictReader(f):
            if campaign is not None and row["campaign"] != campaign:
                continue
            key = (row["variant"], row["prior"], int(row["seed"]))
            runs[key][int(row["episode"])] = float(row["real_return"])
            cal.add(calibration, key[:2], row)
    if not runs:
        raise SystemExit(f"{args.summary}: no runs" + (f" of campaign {campaign}" if campaign else ""))
    groups = defaultdict(list)
    for (variant, prior, seed), episodes in sorted(runs.items()):
        returns = [episodes[e] for e in sorted(episodes)]
        first = next((i + 1 for i, r in enumerate(returns) if r >= SWING_UP), None)
        held = None
        if first is not None:
            best, held = float("-inf"), True
            for r in returns[first - 1:]:
                best = max(best, r)
                held = held and r >= best - HOLD_MARGIN
        groups[(variant, prior)].append((seed, returns, first, held))
    print(f"| variant | prior | runs | swing up by episode {by} | of those, held | first swing-up per run "
          f"| median return, episode {by} | median return, last episode |")
    print("|---|---|---:|---:|---:|---|---:|---:|")
    order = lambda k: (k[0], list(PRIORS).index(k[1]) if k[1] in PRIORS else len(PRIORS), k[1])
    for (variant, prior), rs in sorted(groups.items(), key=lambda item: order(item[0])):
        up = [r for r in rs if r[2] is not None and r[2] <= by]
        held = [r for r in up if r[3]]
        at = [r[1][by - 1] for r in rs if len(r[1]) >= by]
        last = [r[1][-1] for r in rs]
        firsts = " ".join(str(r[2]) if r[2] is not None else "-" for r in rs)
        name = f"{PRIORS[prior]} ({prior})" if prior in PRIORS else prior
        print(f"| {variant} | {name} | {len(rs)} | {len(up)}/{len(rs)} | {len(held)}/{len(up)} | {firsts} "
              f"| {statistics.median(at):.2f} | {statistics.median(last):.2f} |")
    cal.print_table(calibration, "prior", order=order,
                    name=lambda k: f"{PRIORS[k[1]]} ({k[1]})" if k[1] in PRIORS else k[1])

if __name__ == "__main__":
    # a reader that stops early (| head) ends the script quietly, as it would a Unix tool
    signal.signal(signal.SIGPIPE, signal.SIG_DFL)
    main()
