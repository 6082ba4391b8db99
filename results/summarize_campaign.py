#!/usr/bin/env python3
"""Make the compact summary of a new campaign directory (results/README.md, "New campaigns").

  summarize_campaign.py CAMPAIGN_DIR OUTPUT.csv

One row per run and episode, with the columns of the task's summary (summaries/pendubot.csv,
summaries/hexapod.csv, or for realaigym_pendubot the leaderboard's criteria of each episode and
phi; the campaign column is the campaign directory's name) and, for IT&E runs,
the archive each run adapted with: archive_evaluations (config.yaml's ite.evaluations, the prior
episodes of the MAP-Elites run that built it, also when the run read it from the archive cache),
archive_cells and archive_coverage (summary.json "archive"); when the runs recorded it, the
calibration of each episode a model predicted: calibration_quantile, calibration_inside_band,
calibration_gap and calibration_replay (summary.json "calibration", docs/reports.md). Every run
must be complete.
Standard library only.
"""

import argparse
import csv
import json
import os

import summarize_archives as sa

ARCHIVE_COLUMNS = ["archive_evaluations", "archive_cells", "archive_coverage"]
# summary.json's "calibration" of each episode a model predicted (docs/reports.md): where the real
# return fell among the model's Monte-Carlo rollouts of the policy; empty for the others.
CALIBRATION_COLUMNS = ["calibration_quantile", "calibration_inside_band", "calibration_gap",
                       "calibration_replay"]


def ite_evaluations(run_dir):
    """ite.evaluations of a run's config.yaml."""
    inside = False
    with open(os.path.join(run_dir, "config.yaml")) as f:
        for line in f:
            if line.startswith("ite:"):
                inside = True
            elif inside and line.strip().startswith("evaluations:"):
                return int(line.split(":", 1)[1])
            elif inside and not line.startswith("  "):
                inside = False
    raise SystemExit(f"{run_dir}: no ite.evaluations")


def main():
    parser = argparse.ArgumentParser(description=__doc__,
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("campaign_dir", metavar="CAMPAIGN_DIR", help="a campaign directory (with runs/)")
    parser.add_argument("output", metavar="OUTPUT.csv", help="the summary to write")
    args = parser.parse_args()
    campaign_dir, output = args.campaign_dir, args.output
    campaign_dir = os.path.normpath(campaign_dir)
    parent, campaign = os.path.split(campaign_dir)
    if not os.path.isdir(os.path.join(campaign_dir, "runs")):
        raise SystemExit(f"{campaign_dir}: not a campaign directory (no runs/)")
    runs = sa.runs_of(campaign_dir)
    if not runs:
        raise SystemExit(f"{campaign_dir}: no run with an episodes.csv under runs/")
    with open(os.path.join(runs[0][1], "summary.json")) as f:
        task = json.load(f)["task"]
    rows = sa.episode_rows(parent or ".", campaign, task)
    columns = {"pendubot": sa.PENDUBOT_COLUMNS, "hexapod": sa.HEXAPOD_COLUMNS,
               "realaigym_pendubot": sa.REALAIGYM_COLUMNS}.get(task)
    if columns is None:
        raise SystemExit(f"{campaign_dir}: task {task}: no summary format (pendubot, hexapod, "
                         "realaigym_pendubot)")
    archives = {}
    for name, run_dir in runs:
        with open(os.path.join(run_dir, "summary.json")) as f:
            archive = json.load(f).get("archive")
        if archive:
            archives[name] = dict(archive, evaluations=ite_evaluations(run_dir))
    if archives:
        if len(archives) != len(runs):
            raise SystemExit(f"{campaign_dir}: some runs have an archive and some do not")
        columns = columns + ARCHIVE_COLUMNS
        for r in rows:
            a = archives[r["run"]]
            r.update(archive_evaluations=a["evaluations"], archive_cells=a["cells"],
                     archive_coverage=repr(a["coverage"]))
    calibration = {}
    for name, run_dir in runs:
        with open(os.path.join(run_dir, "summary.json")) as f:
            for e in json.load(f).get("episodes", []):
                if isinstance(e.get("calibration"), dict):
                    calibration[name, int(e["episode"])] = e["calibration"]
    if calibration:
        columns = columns + CALIBRATION_COLUMNS
        for r in rows:
            c = calibration.get((r["run"], r["episode"]))
            r.update(calibration_quantile=repr(c["quantile"]) if c else "",
                     calibration_inside_band=int(c["inside_band"]) if c else "",
                     calibration_gap=repr(c["gap"]) if c and c["gap"] is not None else "",
                     calibration_replay=int(c["replay"]) if c else "")
    sa.write(output, columns, rows)


if __name__ == "__main__":
    main()
