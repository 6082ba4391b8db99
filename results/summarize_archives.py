#!/usr/bin/env python3
"""Make the compact summaries of results/summaries/ from unpacked campaign archives.

This is the one-off conversion that turned the raw campaign archives into the compact CSV files
of the data release (results/README.md). It reads each run's episodes.csv and summary.json and
nothing else; the figures and the checks read only the summaries.

  summarize_archives.py ARCHIVES_DIR [OUTPUT_DIR]

ARCHIVES_DIR holds these archives unpacked side by side (results/fetch-archive gets each one):

  pendubot-search.tar.xz        pendubot-gp_mi/ pendubot-rest/ pendubot-gp/ pendubot-ite/
  pendubot-pilco.tar.xz         pendubot-pilco/
  pendubot-pilco_prior.tar.xz   pendubot-pilco_prior/
  hexapod-walls.tar.xz          hexapod-walls/ hexapod-walls-leg5/
  hexapod-walls-campaign.tar.xz hexapod-walls-campaign/
  hexapod-walls-seeds.tar.xz    hexapod-walls-seeds/
  hexapod-ite.tar.xz            hexapod-ite/
  hexapod-ceiling.tar.xz        hexapod-ceiling/
  results/hexapod-direct/       hexapod-direct/   (a folder of commit cfe60a1, not an archive)

The campaign directories keep the names they were made under, and the summaries' `campaign`
column is that name. Today's configs make the hexapod's runs under other names: the runs of
hexapod-walls-leg5 (gp_mi, leg 5) and hexapod-walls-campaign (gp_prior) are runs of
configs/campaign-hexapod.yaml (campaign `hexapod`), those of hexapod-walls and hexapod-walls-seeds
(gp_mi, intact, seeds 1-10 and 11-20) of configs/campaign-hexapod-intact.yaml (campaign
`hexapod-intact`); results/manifest.csv has the mapping (columns config and original_config).

OUTPUT_DIR defaults to the summaries/ folder beside this script. Standard library only.
"""

import argparse
import csv
import json
import os

PENDUBOT_PHI = ["m1", "m2", "l1", "l2", "b1", "b2"]

COMMON = ["campaign", "run", "task", "algorithm", "variant", "prior", "damage", "seed", "episode",
          "interaction_time_s", "real_return", "predicted_return", "solved"]
PENDUBOT_COLUMNS = COMMON + ["phi_" + p for p in PENDUBOT_PHI]
HEXAPOD_COLUMNS = COMMON + ["speed_m_s", "predicted_speed_m_s", "phi_prior"]
# The RealAIGym pendubot's episode metrics: the leaderboard's criteria of each real episode
# (docs/decisions/realaigym-scorer.md), then phi as episodes.csv writes it (space-separated).
REALAIGYM_METRICS = ["swingup_success", "swingup_time_s", "energy_j", "max_tau_nm",
                     "integrated_tau_nms", "tau_cost", "tau_smoothness_nm", "velocity_cost",
                     "realai_score"]
REALAIGYM_COLUMNS = COMMON + REALAIGYM_METRICS + ["phi"]
CEILING_COLUMNS = ["campaign", "search", "task", "algorithm", "damage", "seed", "start", "sigma0",
                   "episodes", "status", "best_episode", "best_return", "best_speed_m_s",
                   "max_speed_m_s", "command", "start_theta", "best_theta"]

# (campaign directory, task) of the summaries of episodes, in the order of their rows.
PENDUBOT_CAMPAIGNS = ["pendubot-gp_mi", "pendubot-rest", "pendubot-gp", "pendubot-ite",
                      "pendubot-pilco", "pendubot-pilco_prior"]
HEXAPOD_CAMPAIGNS = ["hexapod-walls", "hexapod-walls-leg5", "hexapod-walls-campaign",
                     "hexapod-walls-seeds", "hexapod-ite"]


def cell(text):
    """A value of episodes.csv as written there; missing values ("nan", "") become empty."""
    text = (text or "").strip()
    return "" if text.lower() in ("nan", "-nan", "") else text


def runs_of(campaign_dir):
    runs_dir = os.path.join(campaign_dir, "runs")
    names = [n for n in os.listdir(runs_dir)
             if os.path.isfile(os.path.join(runs_dir, n, "episodes.csv"))]

    def key(name):  # by name without the seed, then the seed as a number
        stem, _, seed = name.rpartition("seed")
        return (stem, int(seed) if seed.isdigit() else 0, name)

    return [(n, os.path.join(runs_dir, n)) for n in sorted(names, key=key)]


def read_run(run_dir):
    with open(os.path.join(run_dir, "summary.json")) as f:
        summary = json.load(f)
    with open(os.path.join(run_dir, "episodes.csv"), newline="") as f:
        episodes = list(csv.DictReader(f))
    if summary.get("status") != "complete":
        raise SystemExit(f"{run_dir}: status {summary.get('status')}, expected complete")
    if len(episodes) != summary["episodes_planned"]:
        raise SystemExit(f"{run_dir}: {len(episodes)} episodes of {summary['episodes_planned']}")
    return summary, episodes


def damage_of(run_dir):
    """hexapod.damage.removed_leg of a run's config.yaml: none -> intact, legN -> legN."""
    with open(os.path.join(run_dir, "config.yaml")) as f:
        lines = f.read().splitlines()
    inside = False
    for line in lines:
        if line.startswith("  damage:"):
            inside = True
        elif inside and line.strip().startswith("removed_leg:"):
            value = line.split(":", 1)[1].strip()
            return "intact" if value == "none" else value
        elif inside and not line.startswith("    "):
            inside = False
    raise SystemExit(f"{run_dir}: no hexapod.damage.removed_leg")


def episode_rows(archives, campaign, task):
    rows = []
    for name, run_dir in runs_of(os.path.join(archives, campaign)):
        summary, episodes = read_run(run_dir)
        assert summary["task"] == task, run_dir
        labels = {v: l for v, l in summary["report"].get("phi_value_labels", [])}
        damage = damage_of(run_dir) if task == "hexapod" else ""
        for e in episodes:
            row = {
                "campaign": campaign, "run": name, "task": task,
                "algorithm": summary["algorithm"], "variant": summary["model"],
                "prior": summary["prior"], "damage": damage, "seed": summary["seed"],
                "episode": int(e["episode"]), "interaction_time_s": cell(e["interaction_time_s"]),
                "real_return": cell(e["real_return"]),
                "predicted_return": cell(e["predicted_return"]), "solved": cell(e["solved"]),
            }
            phi = cell(e["phi"]).split()
            if task == "pendubot":
                if phi and len(phi) != len(PENDUBOT_PHI):
                    raise SystemExit(f"{run_dir}: phi {e['phi']}")
                for i, p in enumerate(PENDUBOT_PHI):
                    row["phi_" + p] = phi[i] if phi else ""
            elif task == "realaigym_pendubot":
                for m in REALAIGYM_METRICS:
                    row[m] = cell(e[m])
                row["phi"] = " ".join(phi)
            else:
                row["speed_m_s"] = cell(e["walking_speed_m_s"])
                row["predicted_speed_m_s"] = cell(e["predicted_speed_m_s"])
                row["phi_prior"] = labels[float(phi[0])] if phi else ""
            rows.append(row)
    return rows


def theta_text(values):
    return " ".join(repr(float(v)) for v in values)


def read_theta(path):
    with open(path) as f:
        return [float(line) for line in f.read().split()]


# The ceiling searches: (campaign, folder in ARCHIVES_DIR, search, damage, start, command).
# The commands are those the searches ran with (results/hexapod-direct/commands.sh at commit
# cfe60a1), run from the repository root; START.csv is the row's start_theta written one value
# per line.
C = "drops direct configs/hexapod-gp_mi.yaml"
CEILING_SEARCHES = [
    ("hexapod-direct", "hexapod-direct/intact-centre-interrupted", "intact", "centre",
     f"{C} --evaluations 1000 --threads 1 --name intact-centre-interrupted"),
    ("hexapod-direct", "hexapod-direct/intact-tripod-sigma05-interrupted", "intact", "tripod",
     f"{C} --start START.csv --evaluations 600 --threads 1 --name intact-tripod-sigma05-interrupted"),
    ("hexapod-direct", "hexapod-direct/intact-tripod", "intact", "tripod",
     f"{C} --start START.csv optimizer.sigma0=0.1 --evaluations 600 --threads 1 --name intact-tripod"),
    ("hexapod-direct", "hexapod-direct/leg5", "leg5", "centre",
     f"{C} hexapod.damage.removed_leg=leg5 --evaluations 1000 --threads 1 --name leg5"),
    ("hexapod-direct", "hexapod-direct/leg5-stage2", "leg5", "best of hexapod-direct/leg5",
     f"{C} hexapod.damage.removed_leg=leg5 --start START.csv optimizer.sigma0=0.2 "
     "--evaluations 1000 --threads 1 --name leg5-stage2"),
    ("hexapod-ceiling", "hexapod-ceiling/runs/seed2", "leg5", "centre",
     "drops campaign configs/ceiling-hexapod-direct.yaml -j 2"),
    ("hexapod-ceiling", "hexapod-ceiling/runs/seed3", "leg5", "centre",
     "drops campaign configs/ceiling-hexapod-direct.yaml -j 2"),
    ("hexapod-ceiling", "hexapod-ceiling/stage2/leg5-seed2-stage2", "leg5",
     "best of hexapod-ceiling/seed2 (episode 435)",
     f"{C} hexapod.damage.removed_leg=leg5 --start START.csv optimizer.sigma0=0.2 "
     "--evaluations 1000 --seed 2 --threads 1 --name leg5-seed2-stage2"),
    ("hexapod-ceiling", "hexapod-ceiling/stage2/leg5-seed3-stage2", "leg5",
     "best of hexapod-ceiling/seed3 (episode 698)",
     f"{C} hexapod.damage.removed_leg=leg5 --start START.csv optimizer.sigma0=0.2 "
     "--evaluations 1000 --seed 3 --threads 1 --name leg5-seed3-stage2"),
    ("hexapod-ceiling", "hexapod-ceiling/stage2/leg5-from-gp_mi-seed2", "leg5",
     "gait of gp_mi-leg5-seed2 episode 10 (campaign hexapod-search)",
     f"{C} hexapod.damage.removed_leg=leg5 --start START.csv optimizer.sigma0=0.1 "
     "--evaluations 1000 --seed 1 --threads 1 --name leg5-from-gp_mi-seed2"),
    ("hexapod-ceiling", "hexapod-ceiling/stage2/intact-tripod-seed2", "intact", "tripod",
     f"{C} --start START.csv optimizer.sigma0=0.1 --evaluations 1000 --seed 2 --threads 1 "
     "--name intact-tripod-seed2"),
    ("hexapod-ceiling", "hexapod-ceiling/stage2/intact-tripod-seed3", "intact", "tripod",
     f"{C} --start START.csv optimizer.sigma0=0.1 --evaluations 1000 --seed 3 --threads 1 "
     "--name intact-tripod-seed3"),
    ("hexapod-ceiling", "hexapod-ceiling/stage2/intact-from-gp_prior-local-seed2", "intact",
     "gait of gp_prior-seed2 episode 8 (study hexapod-local-search)",
     f"{C} --start START.csv optimizer.sigma0=0.1 --evaluations 1000 --seed 1 --threads 1 "
     "--name intact-from-gp_prior-local-seed2"),
]


def sigma0_of(path):
    with open(os.path.join(path, "config.yaml")) as f:
        for line in f:
            if line.startswith("  sigma0:"):
                value = float(line.split(":", 1)[1])
                return value if value > 0 else 0.5  # 0: the search's default, 0.5
    raise SystemExit(f"{path}: no optimizer.sigma0")


def ceiling_rows(archives):
    rows = []
    direct = os.path.join(archives, "hexapod-direct")
    tripod = read_theta(os.path.join(direct, "tripod.csv"))
    leg5_best = read_theta(os.path.join(direct, "leg5-best.csv"))
    for campaign, folder, damage, start, command in CEILING_SEARCHES:
        path = os.path.join(archives, folder)
        with open(os.path.join(path, "summary.json")) as f:
            s = json.load(f)
        row = {"campaign": campaign, "search": os.path.basename(folder), "task": "hexapod",
               "algorithm": "direct", "damage": damage, "seed": s["seed"], "start": start,
               "sigma0": repr(sigma0_of(path)), "status": s["status"], "command": command}
        if campaign == "hexapod-direct":
            # drops direct's first format: summary.json with the best θ, progress.csv per
            # generation; the speed of the best θ only.
            row.update(episodes=s["evaluations"], best_episode="",
                       best_return=repr(s["best_return"]),
                       best_speed_m_s=repr(s["walking_speed_m_s"]), max_speed_m_s="",
                       best_theta=theta_text(s["theta"]))
            start_theta = {"centre": [], "tripod": tripod}.get(start, leg5_best)
            row["start_theta"] = theta_text(start_theta)
        else:
            with open(os.path.join(path, "episodes.csv"), newline="") as f:
                episodes = list(csv.DictReader(f))
            best = max(episodes, key=lambda e: float(e["real_return"]))
            assert int(best["episode"]) == s["best_episode"], path
            k = int(best["episode"])
            row.update(episodes=len(episodes), best_episode=k, best_return=best["real_return"],
                       best_speed_m_s=best["walking_speed_m_s"],
                       max_speed_m_s=max((e["walking_speed_m_s"] for e in episodes), key=float),
                       best_theta=theta_text(read_theta(
                           os.path.join(path, "episodes", f"{k:03d}", "policy.csv"))))
            if start == "centre":
                row["start_theta"] = ""
            elif start == "tripod":
                row["start_theta"] = theta_text(tripod)
            else:  # the start is evaluated first
                row["start_theta"] = theta_text(read_theta(
                    os.path.join(path, "episodes", "001", "policy.csv")))
        rows.append(row)
    return rows


def write(path, columns, rows):
    with open(path, "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=columns, lineterminator="\n")
        w.writeheader()
        for r in rows:
            w.writerow(r)
    print(f"{path}: {len(rows)} rows, {os.path.getsize(path)} bytes")


def main():
    parser = argparse.ArgumentParser(description=__doc__,
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("archives", metavar="ARCHIVES_DIR", help="the archives unpacked side by side")
    parser.add_argument("out", metavar="OUTPUT_DIR", nargs="?",
                        default=os.path.join(os.path.dirname(os.path.abspath(__file__)), "summaries"),
                        help="where the summaries go (default: summaries/ beside this script)")
    args = parser.parse_args()
    archives, out = args.archives, args.out
    os.makedirs(out, exist_ok=True)
    write(os.path.join(out, "pendubot.csv"), PENDUBOT_COLUMNS,
          [r for c in PENDUBOT_CAMPAIGNS for r in episode_rows(archives, c, "pendubot")])
    write(os.path.join(out, "hexapod.csv"), HEXAPOD_COLUMNS,
          [r for c in HEXAPOD_CAMPAIGNS for r in episode_rows(archives, c, "hexapod")])
    write(os.path.join(out, "hexapod-ceiling.csv"), CEILING_COLUMNS, ceiling_rows(archives))


if __name__ == "__main__":
    main()
