#!/usr/bin/env python3
"""The tables of docs/results/realaigym-pendubot.md from a campaign's summary.

  realaigym_table.py SUMMARY.csv [--label TEXT]

SUMMARY.csv: results/summarize_campaign.py's summary of a realaigym_pendubot campaign (one row per
run and episode, with the leaderboard's criteria of each real episode). Prints, in Markdown:
- per run (seed): the first episode whose real episode meets the leaderboard's swing-up rule
  (swingup_success: up from the swing-up time to the end, however late that time is: a policy
  that passes the top in the last 0.1 s meets it), the first whose swing-up also comes before 5 s
  (so at least 5 s upright), each with the interaction time up to it; then
  the criteria and the RealAI score of the final episode (the final policy on the benchmark plant);
- the final score's median, quartiles and range over runs, and how many runs swung up;
- drops' row in the leaderboard's own format (its v2 table's columns): the final episode of the
  run with the median final score (the lower median for an even count), success counted over
  every run's final episode;
- per run whose final episode swings up, the v2 score's five terms tanh(pi c / n) of its final
  episode (0: free, 1: the whole penalty; n: time 20 s, energy 60 J, torque cost 20, smoothness
  0.1 N m, velocity cost 400; docs/decisions/realaigym-scorer.md), whose mean is 1 - the score:
  which criteria cost the score. When a recorded score is not the one the terms give (a v1
  campaign, whose score is linear), the terms are not shown and a line says which seed differs.
Every run must have the same number of episodes. Standard library only.
"""

import argparse
import csv
import math
import statistics
import sys

CRITERIA = ["swingup_time_s", "energy_j", "tau_cost", "tau_smoothness_nm", "velocity_cost",
            "realai_score"]
# The v2 (tanh) score's normalisations, all weights 1 (docs/decisions/realaigym-scorer.md).
V2_TERMS = [("time", "swingup_time_s", 20.0), ("energy", "energy_j", 60.0),
            ("τ cost", "tau_cost", 20.0), ("smoothness", "tau_smoothness_nm", 0.1),
            ("velocity", "velocity_cost", 400.0)]


def quartiles(values):
    """(first quartile, median, third quartile), the 'inclusive' method of statistics."""
    if len(values) == 1:
        return values[0], values[0], values[0]
    q = statistics.quantiles(values, n=4, method="inclusive")
    return q[0], q[1], q[2]


def main():
    parser = argparse.ArgumentParser(description=__doc__,
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("summary", metavar="SUMMARY.csv")
    parser.add_argument("--label", default="drops: Black-DROPS with GP-MI + LQR of the learned model",
                        help="the Controller column of drops' leaderboard row")
    args = parser.parse_args()
    with open(args.summary, newline="") as f:
        rows = list(csv.DictReader(f))
    if not rows:
        sys.exit(f"{args.summary}: no rows")
    missing = [c for c in ["run", "seed", "episode", "interaction_time_s", "swingup_success"]
               + CRITERIA if c not in rows[0]]
    if missing:
        sys.exit(f"{args.summary}: no column {', '.join(missing)} (not a realaigym_pendubot "
                 "summary of results/summarize_campaign.py?)")
    runs = {}
    for r in rows:
        runs.setdefault(r["run"], []).append(r)
    lengths = {len(v) for v in runs.values()}
    if len(lengths) != 1:
        sys.exit(f"{args.summary}: runs with different numbers of episodes: {sorted(lengths)}")
    finals = []
    print("| seed | first swing-up, leaderboard's rule (episode, interaction s) | first swing-up "
          "before 5 s | final: success | swing-up s | energy J | τ cost | smoothness | "
          "velocity cost | RealAI score |")
    print("|---:|---|---|---|---:|---:|---:|---:|---:|---:|")
    for name, episodes in sorted(runs.items(), key=lambda kv: int(kv[1][0]["seed"])):
        episodes.sort(key=lambda r: int(r["episode"]))
        first = next((e for e in episodes if e["swingup_success"] == "1"), None)
        early = next((e for e in episodes if e["swingup_success"] == "1"
                      and float(e["swingup_time_s"]) < 5), None)
        final = episodes[-1]
        finals.append(final)

        def when(e):
            return f"{e['episode']} ({float(e['interaction_time_s']):.0f} s)" if e else "–"

        print(f"| {final['seed']} | {when(first)} | {when(early)} | "
              f"{'yes' if final['swingup_success'] == '1' else 'no'}"
              f" | {float(final['swingup_time_s']):.2f} | {float(final['energy_j']):.1f} | "
              f"{float(final['tau_cost']):.1f} | {float(final['tau_smoothness_nm']):.3f} | "
              f"{float(final['velocity_cost']):.1f} | {float(final['realai_score']):.3f} |")
    scores = sorted(float(f["realai_score"]) for f in finals)
    q1, med, q3 = quartiles(scores)
    held = sum(f["swingup_success"] == "1" for f in finals)
    ever = sum(any(e["swingup_success"] == "1" for e in v) for v in runs.values())
    n = len(finals)
    print()
    print(f"- final RealAI score over {n} runs: median {med:.3f}, quartiles {q1:.3f}–{q3:.3f}, "
          f"range {scores[0]:.3f}–{scores[-1]:.3f};")
    print(f"- the final episode swings up (the leaderboard's rule) in {held} of {n} runs; "
          f"some episode does in {ever} of {n}.")
    by_score = sorted(finals, key=lambda f: (float(f["realai_score"]), int(f["seed"])))
    m = by_score[(n - 1) // 2]
    print()
    print("| Controller | Short Controller Description | Swingup Success | Swingup Time [s] | "
          "Energy [J] | Torque Cost[N²m²] | Torque Smoothness [Nm] | Velocity Cost [m²/s²] | "
          "RealAI Score |")
    print("|---|---|---|---:|---:|---:|---:|---:|---:|")
    time = float(m["swingup_time_s"])
    print(f"| {args.label} | final policy of seed {m['seed']} (the median final score of {n} "
          f"seeds) | {held}/{n} | {time:.2f} | {float(m['energy_j']):.2f} | "
          f"{float(m['tau_cost']):.2f} | {float(m['tau_smoothness_nm']):.3f} | "
          f"{float(m['velocity_cost']):.2f} | {float(m['realai_score']):.3f} |")
    succeeded = [f for f in sorted(finals, key=lambda f: int(f["seed"]))
                 if f["swingup_success"] == "1"]
    terms = {f["seed"]: [math.tanh(math.pi * float(f[column]) / n) for _, column, n in V2_TERMS]
             for f in succeeded}
    v2_score = {seed: 1.0 - sum(t) / len(t) for seed, t in terms.items()}
    differ = [f for f in succeeded
              if abs(v2_score[f["seed"]] - float(f["realai_score"])) > 5e-3]
    print()
    if differ:
        f = differ[0]
        print(f"- the v2 score's terms are not shown: seed {f['seed']}'s recorded score "
              f"{float(f['realai_score']):.3f} is not the one they give "
              f"({v2_score[f['seed']]:.3f}; not a v2 campaign?).")
        return
    print("| seed | " + " | ".join(name for name, _, _ in V2_TERMS) + " | score |")
    print("|---:|" + "---:|" * (len(V2_TERMS) + 1))
    for f in succeeded:
        print(f"| {f['seed']} | " + " | ".join(f"{t:.3f}" for t in terms[f["seed"]])
              + f" | {float(f['realai_score']):.3f} |")


if __name__ == "__main__":
    main()
