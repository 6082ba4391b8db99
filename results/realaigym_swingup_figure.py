#!/usr/bin/python3
"""Draw one RealAIGym pendubot swing-up: the angles and the torque of a drops episode, beside a
leaderboard entry's published trajectory.

  /usr/bin/python3 results/realaigym_swingup_figure.py RUN_DIR [--episode K]
      [--reference SIM_SWINGUP.csv --reference-label NAME] [--seconds S] --output FIGURE.png

RUN_DIR       a `drops run task=realaigym_pendubot ...` directory (or a campaign's runs/<run>);
              the episode drawn is its episodes/<K>/real.csv (t, q1, q2, qd1, qd2, tau1: the
              control period's states and the torque held over it), K the episode with the
              highest realai_score in episodes.csv unless --episode is given
--reference   a leaderboard entry's sim_swingup.csv (columns time, pos_meas1, pos_meas2, ...,
              tau_con1), e.g. data/pendubot/simulation_v2/mcpilco/sim_swingup.csv of a clone of
              github.com/dfki-ric-underactuated-lab/real_ai_gym_leaderboard (that repository
              states no license: its files are read, never copied into this tree)
--seconds     the time axis' extent (default 10 s: the whole episode)

Both trajectories start hanging at rest (q = 0) with the goal upright at q1 = pi or -pi (either
way round), q2 = 0 (the lab's convention, which the task keeps). The dashed lines of the angle
panels mark the goal.
Needs matplotlib (Debian's python3-matplotlib; scripts/install-deps); exits 3 without it.
"""

import argparse
import csv
import math
import os
import sys


def read_columns(path, names):
    """Returns {name: [float]} for the given columns of a CSV file; exits naming a missing one."""
    with open(path, newline="") as f:
        reader = csv.DictReader(f)
        missing = [n for n in names if n not in (reader.fieldnames or [])]
        if missing:
            sys.exit(f"{path}: no column {', '.join(missing)} (has: {', '.join(reader.fieldnames or [])})")
        out = {n: [] for n in names}
        for row in reader:
            for n in names:  # an empty cell (the last state has no action) reads as NaN
                out[n].append(float(row[n]) if row[n] != "" else math.nan)
    return out


def episode_rows(run_dir):
    """The rows of RUN_DIR/episodes.csv; exits when there is no such file or no realai_score."""
    path = os.path.join(run_dir, "episodes.csv")
    if not os.path.exists(path):
        sys.exit(f"{path}: no such file (RUN_DIR must be a drops run directory)")
    with open(path, newline="") as f:
        rows = list(csv.DictReader(f))
    if not rows or "realai_score" not in rows[0]:
        sys.exit(f"{path}: no realai_score column (is this a realaigym_pendubot run?)")
    return rows


def best_episode(rows):
    """The episode (its number) with the highest realai_score among episodes.csv's rows, and that
    score."""
    best = max(rows, key=lambda r: (float(r["realai_score"]), -int(r["episode"])))
    return int(best["episode"]), float(best["realai_score"])


def episode_score(rows, episode):
    """The realai_score of EPISODE among episodes.csv's rows; None when it has none."""
    for r in rows:
        if r["episode"] == str(episode) and r["realai_score"] != "":
            return float(r["realai_score"])
    return None


def main():
    parser = argparse.ArgumentParser(description=__doc__,
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("run_dir")
    parser.add_argument("--episode", type=int, help="the episode to draw (default: the best score's)")
    parser.add_argument("--reference", help="a leaderboard entry's sim_swingup.csv")
    parser.add_argument("--reference-label", default="reference", help="its name in the legend")
    parser.add_argument("--label", default="drops", help="the drops episode's name in the legend")
    parser.add_argument("--seconds", type=float, default=10.0, help="time axis extent (s)")
    parser.add_argument("--output", required=True, help="the figure (PNG)")
    args = parser.parse_args()

    rows = episode_rows(args.run_dir)
    if args.episode is None:
        episode, score = best_episode(rows)
        label = f"{args.label} (episode {episode}, score {score:.3f})"
    else:
        episode = args.episode
        score = episode_score(rows, episode)
        label = (f"{args.label} (episode {episode}, score {score:.3f})" if score is not None
                 else f"{args.label} (episode {episode})")
    real = os.path.join(args.run_dir, "episodes", f"{episode:03d}", "real.csv")
    if not os.path.exists(real):
        sys.exit(f"{real}: no such file (episodes are numbered from 1)")
    ours = read_columns(real, ["t", "q1", "q2", "tau1"])
    print(f"episode {episode} of {args.run_dir}")

    try:
        import matplotlib
        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
    except ImportError:
        print("realaigym_swingup_figure.py: needs matplotlib (run it with /usr/bin/python3)",
              file=sys.stderr)
        sys.exit(3)

    fig, axes = plt.subplots(3, 1, figsize=(8, 7), sharex=True)
    # The goal: upright, reached either way round (q1 = pi or -pi), link 2 aligned.
    panels = [("q1", "pos_meas1", "q1 (rad)", (math.pi, -math.pi)),
              ("q2", "pos_meas2", "q2 (rad)", (0.0,))]
    ref = None
    if args.reference:
        ref = read_columns(args.reference, ["time", "pos_meas1", "pos_meas2", "tau_con1"])
    for ax, (mine, theirs, ylabel, goal) in zip(axes, panels):
        ax.plot(ours["t"], ours[mine], color="C0", label=label)
        if ref:
            ax.plot(ref["time"], ref[theirs], color="C1", label=args.reference_label)
        for g in goal:
            ax.axhline(g, color="0.5", lw=0.8, ls="--")
        ax.set_ylabel(ylabel)
    # the policy's torque is held over each control period: a step plot
    axes[2].step(ours["t"], ours["tau1"], where="post", color="C0", label=label)
    if ref:
        axes[2].plot(ref["time"], ref["tau_con1"], color="C1", label=args.reference_label)
    axes[2].set_ylabel("torque on joint 1 (N m)")
    axes[2].set_xlabel("time (s)")
    axes[2].set_xlim(0, args.seconds)
    axes[0].legend(loc="center right", fontsize=8)
    fig.suptitle("RealAIGym pendubot swing-up (simulation, design C.1)")
    fig.tight_layout()
    fig.savefig(args.output, dpi=110)
    print(f"wrote {args.output}")


if __name__ == "__main__":
    main()
