# What the paired improvement check (optimizer.improvement_margin / _cap) claimed against what the robot
# did, over the runs of one or more studies (docs/results/hexapod.md, "The paired check without a
# margin"): for each episode where the check let the new policy run, its paired improvement (the
# median of the per-stream return differences, summary.json details.paired_improvement) against
# its real gain (its walking speed minus the best real speed before it), by bands of the claimed
# improvement; then an offline counterfactual: the median speed per episode if the episodes with a
# claimed improvement above CAP had run the best real gait again at the best real speed before.
# Usage: /usr/bin/python3 results/hexapod_check_analysis.py [--cap CAP] STUDY_DIR...
#   (e.g. campaigns/hexapod-margin campaigns/hexapod-paired; each holds runs/seed*/summary.json)
import argparse, glob, json, os, sys
import numpy as np

FASTER = 0.005  # m/s: "faster" or "slower" than the best real gait before by more than this


def ranks(v):
    return np.argsort(np.argsort(v))


def main():
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--cap", type=float, default=2.0, help="claimed improvement above which the "
                    "counterfactual runs the best real gait again (return units; default 2)")
    ap.add_argument("studies", nargs="+")
    args = ap.parse_args()
    bands = [(0, 0.16), (0.16, 2), (2, np.inf)]
    for study in args.studies:
        runs = sorted(glob.glob(os.path.join(study, "runs", "seed*[0-9]")))
        if not runs:
            sys.exit(f"{study}: no runs/seed*/ directories")
        ran, kept, per_episode = [], 0, {}
        for run in runs:
            episodes = json.load(open(os.path.join(run, "summary.json")))["episodes"]
            best = -np.inf
            for i, e in enumerate(episodes):
                d = e.get("details") or {}
                p = d.get("paired_improvement")
                k = d.get("kept_by_margin") or d.get("kept_by_cap")
                speed = e["walking_speed_m_s"]
                value = speed
                if k:
                    kept += 1
                elif i > 0 and p is not None:
                    ran.append((p, speed - best, d.get("start_reevaluated_return", np.nan)))
                    if p > args.cap:
                        value = best
                per_episode.setdefault(i + 1, []).append(value)
                best = max(best, speed)
        ran = np.array(ran).reshape(-1, 3)
        if len(ran) < 2:
            sys.exit(f"{study}: fewer than 2 episodes ran a new policy after a paired check")
        print(f"{study}: {len(runs)} runs, start kept in {kept} episodes, new policy run in "
              f"{len(ran)} with a paired improvement")
        print(f"  rank correlation, claimed improvement vs real gain: "
              f"{np.corrcoef(ranks(ran[:, 0]), ranks(ran[:, 1]))[0, 1]:.2f}")
        for lo, hi in bands:
            m = (ran[:, 0] > lo) & (ran[:, 0] <= hi)
            if not m.any():
                continue
            g = ran[m, 1]
            print(f"  claimed in ({lo:g}, {hi:g}]: {m.sum()} episodes, faster {(g > FASTER).sum()}, "
                  f"slower {(g < -FASTER).sum()}, median real gain {np.median(g):+.3f} m/s, "
                  f"median re-evaluated return of the best real gait {np.nanmedian(ran[m, 2]):.1f}")
        print(f"  counterfactual (claimed > {args.cap:g}: best real gait again), median per episode: "
              + " ".join(f"{np.median(per_episode[k]):.3f}" for k in sorted(per_episode)))


if __name__ == "__main__":
    main()
