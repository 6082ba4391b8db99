#!/usr/bin/python3
"""Draw every figure of docs/results from the compact summaries of results/summaries/.

  /usr/bin/python3 results/draw_figures.py [--output DIR]

writes to docs/results/ (or DIR):

  pendubot-returns.png              results/summaries/pendubot.csv: the real return per episode of
                                    the 7 algorithms, one panel per starting prior (A-D)
  pendubot-gp_mi-fresh-returns.png  results/summaries/pendubot-gp_mi-fresh.csv: GP-MI on the fresh
                                    seeds 101-120 (configs/campaign-pendubot-gp_mi-fresh.yaml), every
                                    run and the median, one panel per prior
  pendubot-reflected-returns.png    results/summaries/pendubot-gp_mi-fresh-reflected.csv and
                                    pendubot-gp_mi-fresh.csv: GP-MI on the fresh seeds 101-120 with
                                    each prior the summary holds (D and C, then A and B), with the
                                    pendubot's reflected transitions (every run and the median) and
                                    before them (the median)
  pendubot-tolerance-returns.png    results/summaries/pendubot-gp_mi-fresh-tol9.csv and
                                    pendubot-gp_mi-fresh-reflected.csv: GP-MI on the fresh seeds
                                    101-120 with each prior, its phi search to a relative
                                    tolerance of 1e-9 (every run and the median) and of 1e-4 (the
                                    median)
  pendubot-blocks-returns.png       results/summaries/pendubot-gp_mi-fresh-blocks.csv and
                                    pendubot-gp_mi-fresh-tol9.csv: GP-MI on the fresh seeds
                                    101-120 with each prior, with the block computations of the
                                    reflected transitions (every run and the median) and before
                                    them (the median)
  hexapod-speed.png                 results/summaries/hexapod.csv and hexapod-ceiling.csv: the
                                    walking speed per episode of gp_mi, gp_prior (the runs of
                                    configs/campaign-hexapod.yaml) and IT&E, seeds 1-5, intact and
                                    without the rear-right leg, with the ceilings that direct
                                    search on the robot found
  hexapod-intact-20-seeds-speed.png results/summaries/hexapod.csv: gp_mi on the intact robot, the
                                    hexapod's defaults, seeds 1-20, 1-10 and 11-20 (the runs of
                                    configs/campaign-hexapod-intact.yaml)
  hexapod-fresh-speed.png           results/summaries/hexapod-fresh.csv: gp_mi on the fresh seeds
                                    101-110 (configs/campaign-hexapod-fresh.yaml), every run and
                                    the median, intact and without the rear-right leg, with the
                                    paper's speeds and the ceilings
  hexapod-ite-archive-size.png      results/summaries/hexapod-ite-archive-size.csv: IT&E's walking
                                    speed at episode 8 against its archive's size, seeds 101-104,
                                    intact and without the rear-right leg (the runs of
                                    configs/campaign-hexapod-ite-archive-size.yaml), beside
                                    gp_mi's median at episode 8 (hexapod.csv)

The first three figures are the form of `drops report`: per variant, the median over the runs (line) and the
25-75 % band (shaded) against the interaction time, the quartiles interpolated linearly as drops
does. Needs matplotlib (Debian's python3-matplotlib; scripts/install-deps).
"""

import argparse
import csv
import os
import sys

plt = None  # matplotlib.pyplot, imported by main() once the arguments are read


def import_matplotlib():
    """Imports matplotlib.pyplot (headless) into plt; exits 3 when this python3 lacks it."""
    global plt
    try:
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot
    except ImportError as exc:
        print(f"draw_figures.py: {exc}; run it with Debian's /usr/bin/python3 "
              "(python3-matplotlib)", file=sys.stderr)
        sys.exit(3)
    plt = matplotlib.pyplot
    plt.rcParams.update({
        "font.size": 11, "axes.titlesize": 12, "axes.labelsize": 11, "legend.fontsize": 10,
        "axes.grid": True, "grid.alpha": 0.3, "savefig.dpi": 100,
    })

HERE = os.path.dirname(os.path.abspath(__file__))
SUMMARIES = os.path.join(HERE, "summaries")
DEFAULT_OUTPUT = os.path.join(os.path.dirname(HERE), "docs", "results")

# Variants in the order and colours of drops report, with its labels.
VARIANTS = [
    ("gp_mi", "Black-DROPS with GP-MI", "#1f77b4"),
    ("gp_prior", "Black-DROPS with priors", "#d62728"),
    ("mi", "Black-DROPS with MI", "#2ca02c"),
    ("gp", "Black-DROPS", "#7f7f7f"),
    ("ite", "IT&E", "#9467bd"),
    ("pilco", "PILCO", "#ff7f0e"),
    ("pilco_prior", "PILCO with priors", "#17becf"),
]
LABEL = {v: l for v, l, _ in VARIANTS}
COLOR = {v: c for v, _, c in VARIANTS}
PENDUBOT_PANELS = [("tunable-useful", "A tunable & useful"), ("tunable", "B tunable"),
                   ("tunable-misleading", "C tunable & misleading"),
                   ("partially-tunable", "D partially tunable")]
# Variants that ignore the prior: drawn once, in the first panel.
IGNORE_PRIOR = {"gp", "pilco"}
HEXAPOD_PANELS = [("intact", "real robot: intact"),
                  ("leg5", "real robot: rear-right leg (leg5) removed")]


def read(name):
    with open(os.path.join(SUMMARIES, name), newline="") as f:
        return list(csv.DictReader(f))


def quantile(values, p):
    """As drops report: linear interpolation between the sorted values."""
    v = sorted(values)
    h = (len(v) - 1) * p
    lo = int(h)
    hi = min(lo + 1, len(v) - 1)
    return v[lo] + (h - lo) * (v[hi] - v[lo])


def curve(rows, value):
    """Per episode: (interaction time, median, q25, q75, runs) of value over the rows' runs."""
    by_episode = {}
    for r in rows:
        if r[value] != "":
            by_episode.setdefault(int(r["episode"]), []).append(
                (float(r["interaction_time_s"]), float(r[value])))
    out = []
    for k in sorted(by_episode):
        times = [t for t, _ in by_episode[k]]
        values = [v for _, v in by_episode[k]]
        out.append((quantile(times, 0.5), quantile(values, 0.5), quantile(values, 0.25),
                    quantile(values, 0.75), len(values)))
    return out


def draw_curve(ax, points, color, label, z):
    t = [p[0] for p in points]
    ax.fill_between(t, [p[2] for p in points], [p[3] for p in points], color=color, alpha=0.15,
                    linewidth=0, zorder=z)
    ax.plot(t, [p[1] for p in points], "-o", color=color, linewidth=2, markersize=4,
            label=label, zorder=z + 1)


def draw_runs(ax, rows, value):
    """Each run of rows as a thin gray line of value against the interaction time."""
    for k, run in enumerate(sorted({r["run"] for r in rows})):
        mine = sorted((r for r in rows if r["run"] == run), key=lambda r: int(r["episode"]))
        ax.plot([float(r["interaction_time_s"]) for r in mine],
                [float(r[value]) for r in mine], "-", color="gray", alpha=0.35,
                linewidth=0.9, zorder=1, label="one run" if k == 0 else None)


def finish(fig, axes, title, path, ncol):
    handles, labels = [], []
    for ax in axes:
        for h, l in zip(*ax.get_legend_handles_labels()):
            if l not in labels:
                handles.append(h)
                labels.append(l)
    rows = (len(labels) + ncol - 1) // ncol
    fig.legend(handles, labels, loc="lower center", ncol=ncol, frameon=False,
               bbox_to_anchor=(0.5, 0.0))
    fig.suptitle(title, fontsize=11)
    fig.tight_layout(rect=(0, (0.3 * rows + 0.15) / fig.get_figheight(), 1, 1))
    fig.savefig(path, bbox_inches="tight")
    plt.close(fig)
    print(f"{path}: {os.path.getsize(path) // 1024} KB")


def pendubot_returns(output):
    rows = read("pendubot.csv")
    fig, axes = plt.subplots(2, 2, figsize=(11, 7.2), sharey=True)
    axes = axes.ravel()
    for i, (prior, title) in enumerate(PENDUBOT_PANELS):
        ax = axes[i]
        for j, (v, label, color) in enumerate(VARIANTS):
            if v in IGNORE_PRIOR and i > 0:
                continue
            sel = [r for r in rows if r["variant"] == v and (v in IGNORE_PRIOR or r["prior"] == prior)]
            if sel:
                draw_curve(ax, curve(sel, "real_return"), color, label, 2 * (len(VARIANTS) - j))
        ax.set_title(title, loc="left")
        ax.set_xlabel("interaction time (s)")
        ax.set_xlim(left=0)
        if i % 2 == 0:
            ax.set_ylabel("return")
    finish(fig, axes, "Pendubot: return on the real system per episode; line = median over "
           "5 runs, band = 25–75 %\n(Black-DROPS and PILCO ignore the prior: panel A only)",
           os.path.join(output, "pendubot-returns.png"), 4)


def swing_up_panel(ax, title, rows):
    """A pendubot panel's marks: the swing-up line, episode 8, the title and the time axis."""
    ax.axhline(14, color="black", linestyle=":", linewidth=1.2, label="swing-up (return ≥ 14)")
    ax.axvline(20, color="black", linestyle="--", linewidth=0.8, alpha=0.6,
               label="episode 8 (20 s)")
    ax.set_title(title, loc="left")
    ax.set_xlabel("interaction time (s)")
    ax.set_xlim(0, max(float(r["interaction_time_s"]) for r in rows) + 1)


def pendubot_gp_mi_fresh(output, name="pendubot-gp_mi-fresh.csv"):
    rows = read(name)
    seeds = sorted({int(r["seed"]) for r in rows})
    fig, axes = plt.subplots(2, 2, figsize=(11, 7.2), sharey=True)
    axes = axes.ravel()
    for i, (prior, title) in enumerate(PENDUBOT_PANELS):
        ax = axes[i]
        sel = [r for r in rows if r["prior"] == prior]
        draw_runs(ax, sel, "real_return")
        draw_curve(ax, curve(sel, "real_return"), COLOR["gp_mi"],
                   "Black-DROPS with GP-MI: median, 25–75 %", 4)
        swing_up_panel(ax, title, rows)
        if i % 2 == 0:
            ax.set_ylabel("return")
    finish(fig, axes, f"Pendubot, Black-DROPS with GP-MI on fresh seeds {seeds[0]}–{seeds[-1]} "
           f"({len(seeds)} runs per prior; the defaults were chosen on seeds 1–10):\nreturn on "
           "the real system per episode",
           os.path.join(output, name.replace(".csv", "-returns.png")), 3)


def pendubot_before_after(output, name, before, label, before_label, title, png):
    """GP-MI on fresh seeds per prior, D and C first (the priors the pendubot's last changes of
    default were chosen for), then A and B, those the summary `name` holds: every run and the
    median of `name`, and the median of the same seeds in `before` (the default before)."""
    rows, old = read(name), read(before)
    order = [PENDUBOT_PANELS[i] for i in (3, 2, 0, 1)]
    panels = [(p, t) for p, t in order if any(r["prior"] == p for r in rows)]
    shape = (1, 2) if len(panels) <= 2 else (2, 2)
    fig, axes = plt.subplots(*shape, figsize=(11, 4.2 * shape[0]), sharey=True)
    axes = axes.ravel()
    for i, (prior, panel_title) in enumerate(panels):
        ax = axes[i]
        sel = [r for r in rows if r["prior"] == prior]
        ps = sorted({int(r["seed"]) for r in sel})
        draw_runs(ax, sel, "real_return")
        draw_curve(ax, curve(sel, "real_return"), COLOR["gp_mi"], label, 4)
        same = {r["seed"] for r in sel}
        draw_curve(ax, curve([r for r in old if r["prior"] == prior and r["seed"] in same],
                             "real_return"), "black", before_label, 3)
        swing_up_panel(ax, f"{panel_title} ({len(ps)} runs, seeds {ps[0]}–{ps[-1]})", rows)
        if i % shape[1] == 0:
            ax.set_ylabel("return")
    finish(fig, axes, title, os.path.join(output, png), 2)


def pendubot_reflected(output):
    pendubot_before_after(
        output, "pendubot-gp_mi-fresh-reflected.csv", "pendubot-gp_mi-fresh.csv",
        "reflected transitions (the default): median, 25–75 %",
        "before them (exact variances; the same seeds): median, 25–75 %",
        "Pendubot, Black-DROPS with GP-MI on fresh seeds, with and without the reflected "
        "transitions:\nreturn on the real system per episode", "pendubot-reflected-returns.png")


def pendubot_tolerance(output):
    pendubot_before_after(
        output, "pendubot-gp_mi-fresh-tol9.csv", "pendubot-gp_mi-fresh-reflected.csv",
        "φ's search to 1e-9 (the default): median, 25–75 %",
        "to 1e-4 (the default before; the same seeds): median, 25–75 %",
        "Pendubot, Black-DROPS with GP-MI on fresh seeds, GP-MI's φ search to a relative "
        "tolerance of 1e-9 and of 1e-4:\nreturn on the real system per episode",
        "pendubot-tolerance-returns.png")


def pendubot_blocks(output):
    pendubot_before_after(
        output, "pendubot-gp_mi-fresh-blocks.csv", "pendubot-gp_mi-fresh-tol9.csv",
        "block computations (the default): median, 25–75 %",
        "before them (the same seeds): median, 25–75 %",
        "Pendubot, Black-DROPS with GP-MI on fresh seeds, with the reflected transitions' block "
        "computations and before them:\nreturn on the real system per episode",
        "pendubot-blocks-returns.png")


def hexapod_speed(output):
    rows = [r for r in read("hexapod.csv") if int(r["seed"]) <= 5]
    ceilings = read("hexapod-ceiling.csv")
    fig, axes = plt.subplots(1, 2, figsize=(11, 4.2), sharey=True)
    for i, (damage, title) in enumerate(HEXAPOD_PANELS):
        ax = axes[i]
        for j, v in enumerate(["gp_mi", "gp_prior", "ite"]):
            sel = [r for r in rows if r["variant"] == v and r["damage"] == damage]
            draw_curve(ax, curve(sel, "speed_m_s"), COLOR[v], LABEL[v], 2 * (3 - j))
        best = max(float(c["best_speed_m_s"]) for c in ceilings if c["damage"] == damage)
        ax.axhline(best, color="black", linestyle="--", linewidth=1.2,
                   label="ceiling: best gait of direct search on the robot")
        ax.annotate(f"{best:.3f} m/s", (0, best), xycoords=("axes fraction", "data"),
                    xytext=(4, 4), textcoords="offset points", ha="left", fontsize=9)
        ax.set_title(title, loc="left")
        ax.set_xlabel("interaction time (s)")
        ax.set_xlim(left=0)
        if i == 0:
            ax.set_ylabel("walking speed (m/s)")
        ax.set_ylim(-0.12, 0.40)
    finish(fig, axes, "Hexapod: walking speed on the \"real\" robot per episode; line = median "
           "over 5 runs (seeds 1–5), band = 25–75 %",
           os.path.join(output, "hexapod-speed.png"), 4)


def hexapod_20_seeds(output):
    rows = [r for r in read("hexapod.csv") if r["variant"] == "gp_mi" and r["damage"] == "intact"]
    seeds = sorted({int(r["seed"]) for r in rows})
    assert seeds == list(range(1, 21)), seeds
    fig, ax = plt.subplots(figsize=(7.5, 4))
    sets = [("seeds 1–20", 1, 20, "#1f77b4"), ("seeds 1–10", 1, 10, "#d62728"),
            ("seeds 11–20", 11, 20, "#2ca02c")]
    for j, (label, lo, hi, color) in enumerate(sets):
        sel = [r for r in rows if lo <= int(r["seed"]) <= hi]
        draw_curve(ax, curve(sel, "speed_m_s"), color, label, 2 * (3 - j))
    ax.set_title("real robot: intact", loc="left")
    ax.set_xlabel("interaction time (s)")
    ax.set_ylabel("walking speed (m/s)")
    ax.set_xlim(left=0)
    finish(fig, [ax], "Hexapod, Black-DROPS with GP-MI (the defaults): walking speed per "
           "episode;\nline = median over the runs, band = 25–75 %",
           os.path.join(output, "hexapod-intact-20-seeds-speed.png"), 3)


def hexapod_fresh(output, name="hexapod-fresh.csv"):
    rows = read(name)
    seeds = sorted({int(r["seed"]) for r in rows})
    ceilings = read("hexapod-ceiling.csv")
    paper = {"intact": 0.22, "leg5": 0.21}
    fig, axes = plt.subplots(1, 2, figsize=(11, 4.4), sharey=True)
    for i, (damage, title) in enumerate(HEXAPOD_PANELS):
        ax = axes[i]
        sel = [r for r in rows if r["damage"] == damage]
        draw_runs(ax, sel, "speed_m_s")
        draw_curve(ax, curve(sel, "speed_m_s"), COLOR["gp_mi"],
                   "Black-DROPS with GP-MI: median, 25–75 %", 4)
        best = max(float(c["best_speed_m_s"]) for c in ceilings if c["damage"] == damage)
        ax.axhline(best, color="black", linestyle="--", linewidth=1.2,
                   label="ceiling: best gait of direct search on the robot")
        ax.axhline(paper[damage], color="#d62728", linestyle=":", linewidth=1.4,
                   label="the paper's GP-MI at episode 8 (target)")
        ax.axvline(32, color="black", linestyle="--", linewidth=0.8, alpha=0.6,
                   label="episode 8 (32 s)")
        ax.set_title(title, loc="left")
        ax.set_xlabel("interaction time (s)")
        ax.set_xlim(left=0)
        if i == 0:
            ax.set_ylabel("walking speed (m/s)")
        ax.set_ylim(-0.12, 0.40)
    finish(fig, axes, f"Hexapod, Black-DROPS with GP-MI on fresh seeds {seeds[0]}–{seeds[-1]} "
           f"({len(seeds)} runs per robot; the defaults were chosen on seeds 1–10):\nwalking "
           "speed on the \"real\" robot per episode",
           os.path.join(output, name.replace(".csv", "-speed.png")), 3)


def hexapod_ite_archive_size(output):
    rows = read("hexapod-ite-archive-size.csv")
    gp_mi = [r for r in read("hexapod.csv") if r["variant"] == "gp_mi" and r["episode"] == "8"]
    paper = {"leg5": 0.15}  # the paper's IT&E at episode 8 without the rear leg (issue 45)
    fig, axes = plt.subplots(1, 2, figsize=(11, 4.4), sharey=True)
    for i, (damage, title) in enumerate(HEXAPOD_PANELS):
        ax = axes[i]
        sel = [r for r in rows if r["damage"] == damage and int(r["episode"]) <= 8]
        runs = sorted({(int(r["seed"]), int(r["archive_evaluations"])) for r in sel})
        sizes = sorted({n for _, n in runs})
        at8, best8 = {}, {}  # (seed, size) -> speed at episode 8, best speed of episodes 1-8
        for seed, n in runs:
            mine = [r for r in sel if int(r["seed"]) == seed and int(r["archive_evaluations"]) == n]
            at8[seed, n] = next(float(r["speed_m_s"]) for r in mine if r["episode"] == "8")
            best8[seed, n] = max(float(r["speed_m_s"]) for r in mine)
        for k, seed in enumerate(sorted({s for s, _ in runs})):
            ax.plot(sizes, [at8[seed, n] for n in sizes], "o:", color=COLOR["ite"], alpha=0.35,
                    markersize=5, linewidth=1,
                    label="IT&E at episode 8, one seed (101–104)" if k == 0 else None)
        ax.plot(sizes, [quantile([at8[s, n] for s, m in runs if m == n], 0.5) for n in sizes],
                "-o", color=COLOR["ite"], linewidth=2.5, markersize=7,
                label="IT&E at episode 8, median over the seeds")
        ax.plot(sizes, [quantile([best8[s, n] for s, m in runs if m == n], 0.5) for n in sizes],
                "--s", color=COLOR["ite"], linewidth=1.5, markersize=5,
                label="IT&E, best of episodes 1–8, median")
        for n in sizes:
            cov = quantile([float(r["archive_coverage"]) for r in sel
                            if int(r["archive_evaluations"]) == n], 0.5)
            ax.annotate(f"{100 * cov:.0f} %", (n, 1), xycoords=("data", "axes fraction"),
                        xytext=(0, -12), textcoords="offset points", ha="center", fontsize=8,
                        color="dimgray")
        bd = [float(r["speed_m_s"]) for r in gp_mi if r["damage"] == damage]
        ax.axhline(quantile(bd, 0.5), color=COLOR["gp_mi"], linestyle="--", linewidth=1.5,
                   label="Black-DROPS with GP-MI at episode 8, median (seeds 1–20 intact, "
                         "1–5 leg5)")
        if damage in paper:
            ax.axhline(paper[damage], color="black", linestyle=":", linewidth=1.2,
                       label="the paper's IT&E at episode 8")
        ax.set_xscale("log")
        ax.set_xticks(sizes)
        ax.set_xticklabels([f"{n / 1000:g}k" for n in sizes])
        ax.minorticks_off()
        ax.set_xlim(sizes[0] / 1.6, sizes[-1] * 1.6)
        ax.set_title(title, loc="left")
        ax.set_xlabel("archive: MAP-Elites episodes on the prior (grey: cells filled)")
        if i == 0:
            ax.set_ylabel("walking speed (m/s)")
        ax.set_ylim(-0.12, 0.40)
    finish(fig, axes, "Hexapod, IT&E: walking speed against the size of its archive",
           os.path.join(output, "hexapod-ite-archive-size.png"), 2)


def main():
    parser = argparse.ArgumentParser(description=__doc__,
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--output", default=DEFAULT_OUTPUT, help="folder of the figures")
    args = parser.parse_args()
    import_matplotlib()
    os.makedirs(args.output, exist_ok=True)
    pendubot_returns(args.output)
    pendubot_gp_mi_fresh(args.output)
    pendubot_reflected(args.output)
    pendubot_tolerance(args.output)
    pendubot_blocks(args.output)
    hexapod_speed(args.output)
    hexapod_20_seeds(args.output)
    hexapod_fresh(args.output)
    hexapod_ite_archive_size(args.output)


if __name__ == "__main__":
    main()
