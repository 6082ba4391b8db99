# The per-episode table of the hexapod policy-search studies (docs/results/hexapod.md, "Two changes
# to the search") against the seed-1 gp_mi runs of configs/campaign-hexapod.yaml: walking speed
# (m/s), the prior used, "tipped" when the real return < -50.
# Usage: /usr/bin/python3 results/hexapod_study_table.py CAMPAIGNS_DIR (the parent of hexapod/,
# hexapod-local/ and hexapod-budget/)
import csv, os, sys, statistics
root = sys.argv[1]
cols = [("campaign: 500, σ0 0.5", "hexapod/runs/gp_mi-{r}-seed1"),
        ("local: 500, σ0 0.1, start kept", "hexapod-local/runs/{r}-seed1"),
        ("budget: 2,000, σ0 0.5", "hexapod-budget/runs/{r}-seed1")]
name = lambda p: "intact" if p < 0 else f"leg {p}"
for r, title in (("none", "intact"), ("leg5", "rear-right leg (5) removed")):
    eps = {}
    for c, path in cols:
        f = os.path.join(root, path.format(r=r), "episodes.csv")
        eps[c] = list(csv.DictReader(open(f))) if os.path.exists(f) else []
    print(f"\n#### Real robot {title}\n")
    print("| episode | " + " | ".join(c for c, _ in cols) + " |")
    print("|---:|" + "---|" * len(cols))
    for k in range(10):
        cells = []
        for c, _ in cols:
            if k < len(eps[c]):
                e = eps[c][k]
                t = " tipped" if float(e["real_return"]) < -50 else ""
                cells.append(f"{float(e['walking_speed_m_s']):.3f} ({name(int(float(e['phi'])))}){t}")
            else:
                cells.append("–")
        print(f"| {k + 1} | " + " | ".join(cells) + " |")
    cells = []
    for c, _ in cols:
        sp = [float(e["walking_speed_m_s"]) for e in eps[c][1:]]
        n = len(eps[c])
        tip = sum(1 for e in eps[c] if float(e["real_return"]) < -50)
        mins = sum(float(e["model_learning_s"]) + float(e["policy_optimization_s"]) for e in eps[c]) / 60
        cells.append(f"median {statistics.median(sp):.3f}, best {max(sp):.3f}; {tip} tipped of {n}; {mins:.0f} min" if sp else "–")
    print("| episodes 2–10 | " + " | ".join(cells) + " |")
