# Per-episode table of a policy-search study campaign (docs/results/pendubot-search.md): for each
# group of runs that differ only in their seed, the median real return per episode, the median
# seconds per episode (model learning + policy search), and two summaries: the median return of
# the second half of the episodes, and "drops" = episodes more than 2 below the run's best so far
# once that best reached 14 (a swing-up).
# Usage: /usr/bin/python3 results/search_study_table.py CAMPAIGN_DIR [CAMPAIGN_DIR ...]
import csv, os, re, statistics, sys

groups = {}
for root in sys.argv[1:]:
    runs = os.path.join(root, "runs")
    for name in sorted(os.listdir(runs)):
        f = os.path.join(runs, name, "episodes.csv")
        if not os.path.isfile(f):
            continue
        rows = list(csv.DictReader(open(f)))
        if rows:
            groups.setdefault(re.sub(r"-seed\d+$", "", name), []).append(rows)

def med(xs):
    return statistics.median(xs) if xs else float("nan")

for g, runs in groups.items():
    n = max(len(r) for r in runs)
    print(f"\n#### {g} ({len(runs)} runs)\n")
    print("| episode | median return | returns (per seed) | median s/episode |")
    print("|---:|---:|---|---:|")
    for k in range(n):
        rets = [float(r[k]["real_return"]) for r in runs if k < len(r)]
        secs = [float(r[k]["model_learning_s"]) + float(r[k]["policy_optimization_s"])
                for r in runs if k < len(r)]
        print(f"| {k + 1} | {med(rets):.1f} | {' '.join(f'{x:.1f}' for x in rets)} | {med(secs):.1f} |")
    late = [float(e["real_return"]) for r in runs for e in r[len(r) // 2:]]
    drops = 0
    for r in runs:
        best = -1e300
        for e in r:
            x = float(e["real_return"])
            if best >= 14 and x < best - 2:
                drops += 1
            best = max(best, x)
    total = sum(float(e["model_learning_s"]) + float(e["policy_optimization_s"]) for r in runs for e in r)
    print(f"\nsecond half: median {med(late):.1f}; drops > 2 below the best after a swing-up: {drops}; "
          f"model learning + policy search {total / len(runs) / 60:.1f} min per run (mean)")
