# The summary table of docs/results/pendubot.md from campaign run directories: per group of runs
# that differ only in their seed (the run name without "-seedN"), each run's median return over
# episodes 8-15, then the median and [min, max] over the runs; "swing up" = a return >= 14 at some
# episode; "held" = of those, the runs that never fell more than 2 below their best so far after
# it; the median return of episode 15. With --runs, one line per run (returns of every episode,
# first episode >= 14, largest fall below the best after it, median of episodes 8-15).
# Usage: /usr/bin/python3 results/pendubot_table.py [--runs] CAMPAIGN_DIR [CAMPAIGN_DIR ...]
import csv, os, re, statistics, sys

args = sys.argv[1:]
per_run = "--runs" in args
roots = [a for a in args if a != "--runs"]
groups = {}
for root in roots:
    runs = os.path.join(root, "runs")
    for name in sorted(os.listdir(runs)):
        f = os.path.join(runs, name, "episodes.csv")
        if not os.path.isfile(f):
            continue
        rows = list(csv.DictReader(open(f)))
        if rows:
            m = re.search(r"-seed(\d+)$", name)
            seed = int(m.group(1)) if m else 0
            groups.setdefault(re.sub(r"-seed\d+$", "", name), []).append(
                (seed, [float(e["real_return"]) for e in rows]))


def run_stats(r):
    late = statistics.median(r[7:15]) if len(r) >= 8 else float("nan")
    first = next((k + 1 for k, x in enumerate(r) if x >= 14), None)
    fall = 0.0
    if first:
        best = max(r[:first])
        for x in r[first:]:
            fall = max(fall, best - x)
            best = max(best, x)
    return late, first, fall


if per_run:
    print("| run | seed | returns, episodes 1-15 | first >= 14 | largest fall after it | median, episodes 8-15 |")
    print("|---|---:|---|---:|---:|---:|")
    for g, runs in groups.items():
        for seed, r in sorted(runs):
            late, first, fall = run_stats(r)
            print(f"| {g} | {seed} | {' '.join(f'{x:.1f}' for x in r)} | {first or '–'} | "
                  f"{f'{fall:.2f}' if first else '–'} | {late:.2f} |")
else:
    print("| runs | n | median of episodes 8-15 [min, max] | swing up (>= 14) | held | episode 15, median |")
    print("|---|---:|---|---:|---:|---:|")
    for g, runs in groups.items():
        stats = [run_stats(r) for _, r in runs]
        lates = [s[0] for s in stats]
        up = [s for s in stats if s[1]]
        held = sum(1 for s in up if s[2] <= 2)
        last = [r[14] for _, r in runs if len(r) >= 15]
        print(f"| {g} | {len(runs)} | {statistics.median(lates):.1f} [{min(lates):.1f}, {max(lates):.1f}] | "
              f"{len(up)}/{len(runs)} | {f'{held}/{len(up)}' if up else '–'} | "
              f"{statistics.median(last) if last else float('nan'):.1f} |")
