# Offline check of policy-choice rules on recorded hexapod runs (docs/results/hexapod.md, "An
# improvement margin"). For each episode e >= 4 of each run, a gp_prior model (the prior of the
# leg GP-MI named at e) is fitted on episodes 1..e-1, and the recorded gait of e and the best real
# gait before it (the incumbent) are replayed on it: 20 sampled rollouts each on common streams
# (apps/tools/hexapod_rollout_error ... samples 20). Each rule then says whether it would have run
# the new gait or the incumbent again, scored by the real speeds the two gaits walked.
#
# Usage: /usr/bin/python3 results/hexapod_selection_check.py [--tool-args "ARGS"] TOOL RUN_DIR
#            [RUN_DIR ...] > out.txt
#        /usr/bin/python3 results/hexapod_selection_check.py --analyze out.txt
# (TOOL: build/apps/tools/hexapod_rollout_error; walls 3, SNR 500, as the hexapod's defaults;
# ARGS are appended to the tool's words, e.g. "scale 0.5" for draws of half the predictive sd.)
import csv, os, re, statistics, subprocess, sys


def cases(run):
    eps = list(csv.DictReader(open(os.path.join(run, "episodes.csv"))))
    best = None
    for i, e in enumerate(eps):
        k = int(e["episode"])
        if k >= 4 and best is not None:
            yield k, best + 1, int(float(e["phi"]))
        if best is None or float(e["real_return"]) > float(eps[best]["real_return"]):
            best = i


def run_tool(tool, runs, extra=()):
    for run in runs:
        for e, inc, phi in cases(run):
            print(f"== {run} episode {e} incumbent {inc} phi {phi}", flush=True)
            out = subprocess.run([tool, run, str(e - 1), f"{e},{inc}", str(phi), "walls", "3",
                                  "500", "samples", "20", *extra], capture_output=True, text=True,
                                 check=True).stdout
            print(out, flush=True)


def analyze(path):
    blocks = []
    for block in open(path).read().split("== ")[1:]:
        walked = [float(x) for x in re.findall(r"walked ([-\d.]+) m/s", block)]
        mean_rollout = [float(x) for x in re.findall(r"^model\s+\|\s+([-\d.]+)", block, re.M)]
        samp = [tuple(map(float, x)) for x in
                re.findall(r"mean ([-\d.]+) sd ([-\d.]+) q25 ([-\d.]+) min ([-\d.]+)", block)]
        if len(walked) >= 2 and len(samp) >= 2 and len(mean_rollout) >= 2:
            blocks.append(dict(new=walked[0], inc=walked[1], mr=mean_rollout, n=samp[0],
                               i=samp[1]))
    rules = {
        "always the new gait": lambda c: True,
        "mean rollout": lambda c: c["mr"][0] > c["mr"][1],
        "sampled mean": lambda c: c["n"][0] > c["i"][0],
        "sampled 25th percentile": lambda c: c["n"][2] > c["i"][2],
        "sampled mean - sd": lambda c: c["n"][0] - c["n"][1] > c["i"][0] - c["i"][1],
        "sampled mean, margin 0.01": lambda c: c["n"][0] - 0.01 > c["i"][0],
        "sampled mean, margin 0.02": lambda c: c["n"][0] - 0.02 > c["i"][0],
        "sampled mean, margin 0.03": lambda c: c["n"][0] - 0.03 > c["i"][0],
    }
    print(f"{len(blocks)} cases\n")
    print("| rule | mean real speed (m/s) | new, faster | new, slower | incumbent, new was slower "
          "| incumbent, new was faster |")
    print("|---|---:|---:|---:|---:|---:|")
    for name, rule in rules.items():
        pick = [rule(c) for c in blocks]
        got = [c["new"] if p else c["inc"] for c, p in zip(blocks, pick)]
        count = lambda p_, better: sum(1 for c, p in zip(blocks, pick)
                                       if p == p_ and (c["new"] > c["inc"]) == better)
        print(f"| {name} | {statistics.mean(got):.4f} | {count(True, True)} | "
              f"{count(True, False)} | {count(False, False)} | {count(False, True)} |")


if __name__ == "__main__":
    if len(sys.argv) == 3 and sys.argv[1] == "--analyze":
        analyze(sys.argv[2])
    elif len(sys.argv) >= 5 and sys.argv[1] == "--tool-args":
        run_tool(sys.argv[3], sys.argv[4:], sys.argv[2].split())
    elif len(sys.argv) >= 3:
        run_tool(sys.argv[1], sys.argv[2:])
    else:
        sys.exit(__doc__ or "usage: see the header of this file")
