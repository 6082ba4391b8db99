# Per-run table of hexapod Black-DROPS runs (docs/results/hexapod.md): for each run directory, the
# walking speed (m/s) per episode, the episodes in which the real robot fell (the body tilted 90
# degrees or more at some step of episodes/NNN/real.csv: independent of the reward's tilt penalty),
# and the issue-14 targets: speed at episode 8 and no fall after episode 3.
# Usage: /usr/bin/python3 results/hexapod_runs_table.py RUN_DIR [RUN_DIR ...]
#        (e.g. campaigns/hexapod-search/runs/gp_mi-*-seed*)
import csv, math, os, statistics, sys


def fell(real_csv):
    with open(real_csv) as f:
        for row in csv.DictReader(f):
            if math.cos(float(row["roll"])) * math.cos(float(row["pitch"])) <= 0.0:
                return True
    return False


print("| run | speed per episode 1–10 (m/s; * = fell) | episode 8 | best | falls after episode 3 | "
      "minutes (learning + search) |")
print("|---|---|---:|---:|---:|---:|")
eight, clean = [], 0
for run in sys.argv[1:]:
    path = os.path.join(run, "episodes.csv")
    if not os.path.exists(path):
        continue
    eps = list(csv.DictReader(open(path)))
    cells, falls_late, speeds = [], 0, []
    for e in eps:
        k = int(e["episode"])
        v = float(e["walking_speed_m_s"])
        speeds.append(v)
        f = fell(os.path.join(run, "episodes", f"{k:03d}", "real.csv"))
        if f and k > 3:
            falls_late += 1
        cells.append(f"{v:.3f}{'*' if f else ''}")
    e8 = f"{speeds[7]:.3f}" if len(speeds) >= 8 else "–"
    if len(speeds) >= 8:
        eight.append(speeds[7])
    if len(eps) == 10 and falls_late == 0:
        clean += 1
    mins = sum(float(e["model_learning_s"]) + float(e["policy_optimization_s"]) for e in eps) / 60
    print(f"| {os.path.basename(run.rstrip('/'))} | {' '.join(cells)} | {e8} | {max(speeds):.3f} | "
          f"{falls_late} | {mins:.0f} |")
if eight:
    print(f"\nmedian speed at episode 8: {statistics.median(eight):.3f} m/s over {len(eight)} runs; "
          f"complete runs without a fall after episode 3: {clean}")
