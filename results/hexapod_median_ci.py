# How precise a study's median walking speed is (docs/results/hexapod.md, "How precise a 10-seed
# median is"): for each episode, the median over the study's runs of the real robot's walking
# speed (m/s) with a percentile bootstrap 95 % interval (the runs resampled with replacement,
# 20,000 resamples, fixed seed), and the fraction of resampled medians >= the target (0.20 m/s,
# issue 14). With a baseline study of the same seeds, also the paired comparison: per episode,
# the median of the per-seed differences (study - baseline), its bootstrap interval (the seeds
# resampled jointly) and how many seeds were faster / slower. A last row does the same for each
# run's mean speed over episodes 6-10 (--window A-B), a score of the curve's end less noisy than
# one episode.
# Usage: /usr/bin/python3 results/hexapod_median_ci.py STUDY_DIR [BASELINE_DIR] [--target V]
#        [--window A-B]
#        (a campaign directory holding runs/seed*/episodes.csv, or several joined by commas:
#        campaigns/hexapod-walls,campaigns/hexapod-walls-seeds)
import csv, glob, os, random, re, statistics, sys

RESAMPLES = 20000


def speeds(studies):
    """{seed: {episode: walking speed}} of the runs of one study or of several, comma-separated
    (e.g. a study and its extra seeds); a seed in two of them is an error."""
    runs = {}
    for study in studies.split(","):
        found = 0
        for f in glob.glob(os.path.join(study, "runs", "*", "episodes.csv")):
            m = re.search(r"seed(\d+)$", os.path.dirname(f))
            if not m:
                continue
            seed = int(m.group(1))
            if seed in runs:
                sys.exit(f"{study}: seed {seed} is also in another directory of {studies}")
            runs[seed] = {int(r["episode"]): float(r["walking_speed_m_s"])
                          for r in csv.DictReader(open(f))}
            found += 1
        if not found:
            sys.exit(f"{study}: no runs/seed*/episodes.csv")
    return runs


def interval(values, rng):
    meds = sorted(statistics.median(rng.choices(values, k=len(values))) for _ in range(RESAMPLES))
    return meds, meds[int(0.025 * RESAMPLES)], meds[int(0.975 * RESAMPLES) - 1]


args = sys.argv[1:]
target = 0.20
window = (6, 10)
if "--window" in args:
    i = args.index("--window")
    try:
        window = tuple(int(x) for x in args[i + 1].split("-"))
        assert len(window) == 2 and 1 <= window[0] <= window[1]
    except (IndexError, ValueError, AssertionError):
        sys.exit("--window needs two episodes A-B with 1 <= A <= B, e.g. 6-10")
    del args[i:i + 2]
if "--target" in args:
    i = args.index("--target")
    try:
        target = float(args[i + 1])
    except (IndexError, ValueError):
        sys.exit("--target needs a number (m/s)")
    del args[i:i + 2]
if len(args) not in (1, 2):
    sys.exit("usage: hexapod_median_ci.py STUDY_DIR [BASELINE_DIR] [--target V] [--window A-B]")
study = speeds(args[0])
base = speeds(args[1]) if len(args) == 2 else None
episodes = sorted({e for s in study.values() for e in s})
# The window's mean per run, as one more "episode" (runs without every episode of it left out).
label = f"{window[0]}–{window[1]} mean"
span = range(window[0], window[1] + 1)
for runs in (study, base or {}):
    for s in runs.values():
        if all(e in s for e in span):
            s[label] = statistics.mean(s[e] for e in span)
episodes.append(label)
head = f"| episode | runs | median | 95 % interval | P(median ≥ {target:.2f}) |"
rule = "|---:|---:|---:|---|---:|"
if base:
    head += " paired seeds | median difference | 95 % interval | faster / slower |"
    rule += "---:|---:|---|---|"
print(head)
print(rule)
for ep in episodes:
    rng = random.Random(str(ep))
    v = [s[ep] for s in study.values() if ep in s]
    if not v:
        continue
    meds, lo, hi = interval(v, rng)
    above = sum(m >= target for m in meds) / len(meds)
    row = f"| {ep} | {len(v)} | {statistics.median(v):.3f} | [{lo:.3f}, {hi:.3f}] | {above:.2f} |"
    if base:
        seeds = sorted(k for k in study if ep in study[k] and k in base and ep in base[k])
        d = [study[k][ep] - base[k][ep] for k in seeds]
        if d:
            _, dlo, dhi = interval(d, rng)
            faster = sum(x > 0 for x in d)
            slower = sum(x < 0 for x in d)
            row += (f" {len(d)} | {statistics.median(d):+.3f} | [{dlo:+.3f}, {dhi:+.3f}] |"
                    f" {faster} / {slower} |")
        else:
            row += " 0 | – | – | – |"
    print(row)
