# Per-run table of hexapod Black-DROPS runs (docs/results/hexapod.md): for each run directory, the
# walking speed (m/s) per episode, the episodes in which the real robot fell (the body tilted 90
# degrees or more at some step of episodes/NNN/real.csv: independent of the reward's tilt penalty),
# and the issue-14 targets: speed at episode 8 and no fall after episode 3. With --checks, a last
# column lists the episodes in which the paired improvement check ran the best real gait again
# (summary.json details: c = kept by optimizer.improvement_cap, m = by the margin) and those in
# which optimizer.improvement_cap_max_runs had turned the cap off (x).
# Usage: /usr/bin/python3 results/hexapod_runs_table.py [--checks] RUN_DIR [RUN_DIR ...]
#        (e.g. campaigns/hexapod-search/runs/gp_mi-*-seed*)
import csv, json, math, os, statistics, sys


def checks(run):
    """Episodes kept by the cap (c) or the margin (m), and those with the cap off (x)."""
    path = os.path.join(run, "summary.json")
    if not os.path.exists(path):
        return "–"
    marks = []
    for e in json.load(open(path))["episodes"]:
        d = e.get("details") or {}
        if d.get("kept_by_cap"):
            marks.append(f"{e['episode']}c")
        elif d.get("kept_by_margin"):
            marks.append(f"{e['episode']}m")
        elif "best_policy_runs" in d and "kept_by_cap" not in d:
            marks.append(f"{e['episode']}x")
    return " ".join(marks) or "–"


def fell(real_csv):
    with open(real_csv) as f:
        for row in csv.DictReader(f):
            if math.cos(float(row["roll"])) * math.cos(float(row["pitch"])) <= 0.0:
                return True
    return False


args = sys.argv[1:]
with_checks = "--checks" in args
args = [a for a in args if a != "--checks"]
print("| run | speed per episode 1–10 (m/s; * = fell) | episode 8 | best | falls after episode 3 | "
      "minutes (learning + search) |" + (" kept (c cap, m margin; x cap off) |" if with_checks
                                         else ""))
print("|---|---|---:|---:|---:|---:|" + ("---|" if with_checks else ""))
eight, clean = [], 0
for run in args:
    path = os.path.join(run, "episodes.csv")
    if not os.path.exists(path):
        continue
    eps = list(csv.DictReader(open(path)))
    if not eps:  # a run stopped in its first episode
        continue
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
          f"{falls_late} | {mins:.0f} |" + (f" {checks(run)} |" if with_checks else ""))
if eight:
    print(f"\nmedian speed at episode 8: {statistics.median(eight):.3f} m/s over {len(eight)} runs; "
          f"complete runs without a fall after episode 3: {clean}")
