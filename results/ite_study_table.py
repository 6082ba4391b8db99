# Tables of the IT&E study on the pendubot (configs/study-pendubot-ite.yaml; docs/ite.md, "Not done
# yet"). For each setting (run names without the prior and the seed), over the runs of
# every prior and seed: the median best real return of the 15 episodes (the policy IT&E found), the
# median final return (the last episode: the best tested cell repeated once the stopping rule
# fired, else the last trial), the runs solved at some episode, the median number of trials, the
# median archive coverage and best archive fitness (the return on the prior); then the same per prior for the chosen setting (argv[2], e.g.
# "5-0.1-0.4" = bins 5, performance scale 0.1, length scale 0.4).
# Usage: /usr/bin/python3 results/ite_study_table.py CAMPAIGN_DIR [SETTING]
import csv, json, os, re, statistics, sys

root = sys.argv[1]
runs_dir = os.path.join(root, "runs")
PRIORS = ["tunable-useful", "tunable", "tunable-misleading", "partially-tunable"]
rows = []
for name in sorted(os.listdir(runs_dir)):
    d = os.path.join(runs_dir, name)
    f = os.path.join(d, "episodes.csv")
    s = os.path.join(d, "summary.json")
    if not (os.path.isfile(f) and os.path.isfile(s)):
        continue
    eps = list(csv.DictReader(open(f)))
    summary = json.load(open(s))
    if summary.get("status") != "complete" or not eps:
        continue
    prior = next(p for p in sorted(PRIORS, key=len, reverse=True) if name.startswith(p + "-"))
    setting = re.sub(r"-seed\d+$", "", name[len(prior) + 1:])
    details = summary.get("details", {})
    rows.append({"prior": prior, "setting": setting, "seed": int(name.rsplit("seed", 1)[1]),
                 "final": float(eps[-1]["real_return"]),
                 "best": max(float(e["real_return"]) for e in eps),
                 "solved_last": eps[-1]["solved"] == "1",
                 "solved_any": any(e["solved"] == "1" for e in eps),
                 "trials": details.get("trials", float("nan")),
                 "coverage": summary.get("archive", {}).get("coverage", float("nan")),
                 "archive_best": summary.get("archive", {}).get("best_fitness", float("nan"))})


def med(xs):
    return statistics.median(xs) if xs else float("nan")


def table(group_key, select=lambda r: True):
    groups = {}
    for r in rows:
        if select(r):
            groups.setdefault(group_key(r), []).append(r)
    print("| group | runs | median best return | [min, max] | median final return | solved once | median trials | median coverage | median archive best |")
    print("|---|---:|---:|---|---:|---:|---:|---:|---:|")
    for g, rs in sorted(groups.items(), key=lambda kv: -med([r["best"] for r in kv[1]])):
        best = [r["best"] for r in rs]
        print(f"| {g} | {len(rs)} | {med(best):.2f} | [{min(best):.2f}, {max(best):.2f}] | "
              f"{med([r['final'] for r in rs]):.2f} | {sum(r['solved_any'] for r in rs)} | "
              f"{med([r['trials'] for r in rs]):.0f} | {100 * med([r['coverage'] for r in rs]):.1f} % | "
              f"{med([r['archive_best'] for r in rs]):.2f} |")


print(f"## {len(rows)} complete runs of {root}\n")
print("### Per setting (bins-performance_scale-length_scale), all priors and seeds\n")
table(lambda r: r["setting"])
print("\n### Per grid (bins), all priors, seeds and adaptation settings\n")
table(lambda r: r["setting"].split("-")[0] + " bins")
if len(sys.argv) > 2:
    print(f"\n### Setting {sys.argv[2]} per prior\n")
    table(lambda r: r["prior"], lambda r: r["setting"] == sys.argv[2])
