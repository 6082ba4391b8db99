#!/usr/bin/python3
"""Figures of `drops report` and `drops plot` (run by the drops command line; see docs/reports.md).

Every statistic is computed by the C++ side; this script only draws.

  drops_plot.py report TABLE_CSV OUTPUT_PNG [--ylabel LABEL]
      The paper's Fig. 3 form from returns.csv (or a task metric's table, e.g. speed.csv): one
      panel per panel_title, one line per variant_label in its variant_colour (the variant's
      declared colour; a free one when empty), in the table's row order, median with the 25-75 %
      band against interaction time.
  drops_plot.py run PLOT_DATA_JSON OUTPUT_DIR
      returns.png, phi.png, the task metric's figure and trajectories-NNN.png of one run, from the
      plot-data.json that `drops plot` writes with drops's run-directory reader; with body
      positions (x, y, yaw) also path-NNN.png, with foot heights gait-NNN.png. Axes carry the
      labels and units the task declared (plot-data.json "phi_labels", "columns", "metric"); a
      quantity it did not declare is shown by its name, without a unit.

  drops_plot.py identify DIR
      The figures of a `drops identify` directory (docs/identify.md): validation-NN.png from each
      validation-NN.csv (per state, the recorded trajectory and the model's open-loop
      predictions over the longest horizon from every start point) and, when the model has a
      prior, phi.png from phi.csv (per tunable parameter: its start, the learned value and the
      posterior's 95% interval).

  drops_plot.py archive ARCHIVE_CSV OUTPUT_PNG
      An IT&E MAP-Elites archive (a run's archive.csv, or any file of that format): every cell of
      the grid coloured by its elite's fitness (empty cells blank; with more than 2 descriptor
      dimensions the grid is unrolled into 2-D, dimensions 0, 2, 4, ... nested along x and 1, 3,
      5, ... along y, the first of each the outermost), the coverage per value of each dimension
      and the distribution of the elites' fitness.

In the returns figures (and the report's figure of a task metric) a value far from all the others
(a diverged episode: outlier_limits) is left outside the y-axis, marked by a triangle at its edge
and named with its value, so that it does not flatten the other points into a line.

Exit codes: 0 success, 1 error, 2 usage error, 3 matplotlib or numpy missing.
Needs Debian's python3-matplotlib and python3-numpy (scripts/install-deps).
"""

import argparse
import csv
import json
import math
import os
import sys

try:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    import numpy as np
except ImportError as exc:  # reported by drops as "needs Debian's python3-matplotlib"
    print(f"drops_plot.py: {exc}", file=sys.stderr)
    sys.exit(3)

# Colours of the variants that declare none (drops records each variant's declared colour in
# summary.json; returns.csv carries it as variant_colour).
COLORS = ["#1f77b4", "#d62728", "#2ca02c", "#7f7f7f", "#9467bd", "#ff7f0e", "#8c564b",
          "#e377c2", "#17becf", "#bcbd22"]
plt.rcParams.update({
    "font.size": 11,
    "axes.titlesize": 12,
    "axes.labelsize": 11,
    "legend.fontsize": 10,
    "axes.grid": True,
    "grid.alpha": 0.3,
    "savefig.dpi": 130,
})


def number(text):
    """A CSV/JSON number; '' and None read as NaN."""
    if text is None or text == "":
        return math.nan
    return float(text)


def save(fig, path):
    fig.savefig(path, bbox_inches="tight")
    plt.close(fig)


# ---------------------------------------------------------------- outliers on the y-axis
# One diverged episode (a return of -372,046 among returns of 60-69) would flatten every other
# point of a figure into a line. Such a value is left outside the y-axis, marked at its edge (a
# triangle) and named in the figure with its value.

# A value is an outlier when it lies more than this many times the bulk's scale beyond the bulk.
OUTLIER_RATIO = 10.0


def outlier_limits(values):
    """The y-axis limits (low, high) that leave out a few far outliers, or None when there are
    none (matplotlib then chooses the limits as before).

    values: a flat sequence of numbers; NaN and infinities are ignored. The bulk is the narrowest
    range left after removing at most max(1, n // 10) of the n finite values, taken from either
    end, such that each removed value lies more than OUTLIER_RATIO times the bulk's scale beyond
    the bulk; the scale is the larger of the bulk's span and its largest magnitude, so that a
    learning curve that jumps from returns near 5 to 20 is kept whole while -372,046 among
    returns of 60-69 is left out. Fewer than 4 values have no bulk to speak of: None. The
    limits are the bulk's range with matplotlib's default margin (5 % of the span; of the
    largest magnitude when the bulk is one value)."""
    v = np.asarray(values, dtype=float)
    v = np.sort(v[np.isfinite(v)])
    n = len(v)
    if n < 4:
        return None
    best = None
    for removed in range(1, max(1, n // 10) + 1):
        for low in range(removed + 1):
            high = removed - low
            bulk = v[low:n - high]
            scale = max(bulk[-1] - bulk[0], np.abs(bulk).max())
            if scale <= 0:
                continue
            if low and bulk[0] - v[low - 1] <= OUTLIER_RATIO * scale:
                continue
            if high and v[n - high] - bulk[-1] <= OUTLIER_RATIO * scale:
                continue
            if best is None or bulk[-1] - bulk[0] < best[1] - best[0]:
                best = (bulk[0], bulk[-1])
    if best is None:
        return None
    lo, hi = best
    pad = 0.05 * ((hi - lo) if hi > lo else abs(hi))
    return lo - pad, hi + pad


def number_text(v):
    """v for a figure's note: 6 significant digits, thousands separated, a true minus sign."""
    return f"{v:,.6g}".replace("-", "\u2212")


def mark_clipped(ax, x, y, limits, color, markersize=7):
    """Draws a triangle at the edge of ax's y-axis for each point (x, y) beyond limits; returns
    the points below and above: lists of (x, y)."""
    x, y = np.asarray(x, dtype=float), np.asarray(y, dtype=float)
    below, above = y < limits[0], y > limits[1]
    for side, edge, marker in ((below, 0.0, "v"), (above, 1.0, "^")):
        if side.any():
            ax.plot(x[side], np.full(side.sum(), edge), marker, color=color,
                    markersize=markersize, transform=ax.get_xaxis_transform(), clip_on=False,
                    zorder=6)
    return list(zip(x[below], y[below])), list(zip(x[above], y[above]))


def clipped_note(points, what, where, place):
    """'1 real return below the axis: −372,046 (episode 5)': points are (x, y), place(x) names
    where x is; at most 3 points are listed."""
    n = len(points)
    items = [f"{number_text(y)} ({place(x)})" for x, y in points[:3]]
    if n > 3:
        items.append(f"{n - 3} more")
    return f"{n} {what}{'' if n == 1 else 's'} {where} the axis: " + ", ".join(items)


# ---------------------------------------------------------------- drops report

def panels_and_variants(rows):
    """The panels (prior column) and variants of a report table's rows, in the table's order
    (drops sorts the groups), with each variant's legend label, each panel's title and each
    variant's colour (variant_colors)."""
    priors, variants, label, title = [], [], {}, {}
    for r in rows:
        if r["prior"] not in priors:
            priors.append(r["prior"])
        if r["variant"] not in variants:
            variants.append(r["variant"])
        label[r["variant"]] = r.get("variant_label") or r["variant"]
        title[r["prior"]] = r.get("panel_title") or r["prior"]
    return priors, variants, label, title, variant_colors(rows)


def variant_colors(rows):
    """{variant: colour} of the rows of a report table (returns.csv), in the table's order.

    A variant keeps the colour it declared (variant_colour) whatever else the figure holds (a
    figure with PILCO with priors and one without draws PILCO alike), unless an earlier variant
    took it (variants split by a setting, "gp_mi rollouts.count=3" after "gp_mi"); the others
    take the colours the declared ones leave free, in COLORS' order."""
    variants, declared = [], {}
    for r in rows:
        if r["variant"] not in variants:
            variants.append(r["variant"])
        if r.get("variant_colour"):
            declared[r["variant"]] = r["variant_colour"]
    color = {}
    for v in variants:
        if declared.get(v) and declared[v] not in color.values():
            color[v] = declared[v]
    spare = [c for c in COLORS if c not in color.values()]
    for v in variants:
        if v not in color:
            color[v] = spare.pop(0) if spare else COLORS[len(color) % len(COLORS)]
    return color


def plot_report(returns_csv, output_png, ylabel="return"):
    with open(returns_csv, newline="") as f:
        rows = list(csv.DictReader(f))
    if not rows:
        fig, ax = plt.subplots(figsize=(6, 3))
        ax.axis("off")
        ax.text(0.5, 0.5, "no finished episode yet", ha="center", va="center")
        save(fig, output_png)
        return
    priors, variants, label, title, color = panels_and_variants(rows)

    n = len(priors)
    ncols = n if n <= 3 else (2 if n == 4 else 3)
    nrows = math.ceil(n / ncols)
    width = 5.2 * ncols if ncols > 1 else 7.0
    fig, axes = plt.subplots(nrows, ncols, figsize=(width, 3.6 * nrows), sharey=True,
                             squeeze=False)
    partial = False
    drawn = []  # (axes, panel, variant, t, median, q25, q75) of every line, for the outliers
    for i, prior in enumerate(priors):
        ax = axes[i // ncols][i % ncols]
        for v in variants:
            pts = [r for r in rows
                   if r["prior"] == prior and r["variant"] == v and int(r["runs"]) > 0]
            if not pts:
                continue
            pts.sort(key=lambda r: int(r["episode"]))
            t = np.array([number(r["interaction_time_s"]) for r in pts])
            med = np.array([number(r["median"]) for r in pts])
            q25 = np.array([number(r["q25"]) for r in pts])
            q75 = np.array([number(r["q75"]) for r in pts])
            runs = np.array([int(r["runs"]) for r in pts])
            full = runs == runs.max()
            partial = partial or not full.all()
            c = color[v]
            z = 2 * (len(variants) - variants.index(v))  # the first variant (GP-MI) on top
            ax.fill_between(t, q25, q75, color=c, alpha=0.15, linewidth=0, zorder=z)
            ax.plot(t, med, color=c, linewidth=2, label=label[v], zorder=z + 1)
            ax.plot(t[full], med[full], "o", color=c, markersize=4, zorder=z + 1)
            ax.plot(t[~full], med[~full], "o", color=c, markersize=5, markerfacecolor="white",
                    zorder=z + 1)
            drawn.append((ax, prior, v, t, med, q25, q75))
        ax.set_title(title[prior], loc="left")
        ax.set_xlabel("interaction time (s)")
        if i % ncols == 0:
            ax.set_ylabel(ylabel)
        ax.set_xlim(left=0)
    for j in range(n, nrows * ncols):
        axes[j // ncols][j % ncols].axis("off")
    handles, labels = [], []
    for row in axes:
        for ax in row:
            for h, l in zip(*ax.get_legend_handles_labels()):
                if l not in labels:
                    handles.append(h)
                    labels.append(l)
    order = sorted(range(len(labels)), key=lambda k: variants.index(
        next(v for v in variants if label[v] == labels[k])))
    legend_cols = min(len(labels), 4 if fig.get_figwidth() >= 9 else 2)
    legend_rows = math.ceil(len(labels) / legend_cols)
    fig.legend([handles[k] for k in order], [labels[k] for k in order], loc="lower center",
               ncol=legend_cols, frameon=False, bbox_to_anchor=(0.5, 0.0))
    heading = (ylabel[:1].upper() + ylabel[1:] + " on the real system: line = median over the "
               "runs, band = 25–75 %")
    if partial:
        heading += "\nhollow markers: not every run has reached this episode yet"
    limits = outlier_limits(np.concatenate([a for d in drawn for a in d[4:]]) if drawn else [])
    if limits is not None:  # the panels share the y-axis
        axes[0][0].set_ylim(*limits)
        below, above, cut = [], [], False
        for ax, prior, v, t, med, q25, q75 in drawn:
            b, a = mark_clipped(ax, t, med, limits, color[v])
            where = f"{label[v]}, " + (f"{title[prior]}, " if n > 1 else "")
            below += [(f"{where}{x:g} s", y) for x, y in b]
            above += [(f"{where}{x:g} s", y) for x, y in a]
            cut = cut or bool(np.any((q25 < limits[0]) & (med >= limits[0]))
                              or np.any((q75 > limits[1]) & (med <= limits[1])))
        for points, where, mark in ((below, "below", "▼"), (above, "above", "▲")):
            if points:
                heading += f"\n{mark} " + clipped_note(points, "median", where, lambda x: x)
        if cut:
            heading += "\nbands cut at the axis where a quartile lies beyond it"
    fig.suptitle(heading, fontsize=11)
    legend_height_in = 0.3 * legend_rows + 0.1
    fig.tight_layout(rect=(0, legend_height_in / fig.get_figheight(), 1, 1))
    save(fig, output_png)


# ---------------------------------------------------------------- drops plot
# From plot-data.json (experiment::write_plot_data): "episodes" (per episode: returns, phi,
# metrics), "trajectories" (per drawn episode: "real" and "predicted" tables of columns and rows).

class Table:
    """A trajectory table: columns by name as numpy arrays (null cells are NaN)."""

    def __init__(self, data):
        self.names = list(data["columns"])
        rows = np.array([[number(v) for v in r] for r in data["rows"]], dtype=float)
        rows = rows.reshape(len(data["rows"]), len(self.names))
        self.cols = {n: rows[:, i] for i, n in enumerate(self.names)}

    def __getitem__(self, name):
        return self.cols[name]

    def __contains__(self, name):
        return name in self.cols

    def __len__(self):
        return len(self.cols["t"]) if "t" in self.cols else 0


def episode_tables(data, k):
    """Real and predicted (None when absent, e.g. a random first policy) trajectories of k."""
    ep = data["trajectories"][str(k)]
    return Table(ep["real"]), (Table(ep["predicted"]) if "predicted" in ep else None)


def episode_entry(data, k):
    return next((e for e in data["episodes"] if e.get("episode") == k), {})


def phi_value_label(data, v):
    v = number(v)
    if not math.isfinite(v):
        return "?"
    for value, label in data.get("phi_value_labels", []):
        if value == v:
            return label
    return f"{v:g}"


def plot_returns(data, out):
    eps = data["episodes"]
    k = np.array([e["episode"] for e in eps])
    real = np.array([number(e.get("real_return")) for e in eps])
    pred = np.array([number(e.get("predicted_return")) for e in eps])
    solved = np.array([bool(e.get("solved")) for e in eps])
    fig, ax = plt.subplots(figsize=(7.5, 4.2))
    ax.plot(k, real, "-o", color="#1f77b4", linewidth=2, markersize=5 if len(k) <= 60 else 2,
            label="real return")
    if np.isfinite(pred).any():
        ax.plot(k, pred, "--s", color="#ff7f0e", linewidth=1.5, markersize=4,
                label="predicted return (model)")
    if solved.any():
        ax.plot(k[solved], real[solved], "*", color="#2ca02c", markersize=15, zorder=5,
                label="solved")
    notes = []
    limits = outlier_limits(np.concatenate([real, pred]))
    if limits is not None:
        ax.set_ylim(*limits)
        for values, what, c in ((real, "real return", "#1f77b4"),
                                (pred, "predicted return", "#ff7f0e")):
            for points, where, marker in zip(mark_clipped(ax, k, values, limits, c),
                                             ("below", "above"), ("v", "^")):
                if points:
                    ax.plot([], [], marker, color=c, markersize=7, label=clipped_note(
                        points, what, where, lambda x: f"episode {x:g}"))
                    notes.append(where)
    ax.set_xlabel("episode")
    ax.set_ylabel("return")
    ax.set_xticks(k if len(k) <= 20 else np.unique(np.linspace(k.min(), k.max(), 11).round()))
    times = np.array([number(e.get("interaction_time_s")) for e in eps])
    linear = len(k) >= 1 and np.all(np.isfinite(times)) and times[0] > 0
    if linear and np.allclose(times, k * times[0]):
        per = times[0]
        sec = ax.secondary_xaxis("top", functions=(lambda e: e * per, lambda t: t / per))
        sec.set_xlabel("interaction time (s)")
    if notes:
        ax.legend(loc="best", fontsize=9)
    else:
        ax.legend(loc="lower right")
    ax.set_title(f"{data['name']}: {data['variant_label']}, {data['panel_title']}\n"
                 f"{len(eps)} episodes", fontsize=11, pad=10)
    save(fig, os.path.join(out, "returns.png"))


def with_unit(text, unit):
    """'text (unit)', or the text alone without a unit."""
    return f"{text} ({unit})" if unit else text


def phi_label(data, name):
    """The task's label and unit of φ component `name` (plot-data.json "phi_labels")."""
    for entry in data.get("phi_labels", []):
        if entry["name"] == name:
            return with_unit(entry["text"], entry["unit"])
    return name


def plot_phi(data, out):
    names = data["phi_plotted"]
    all_names = data.get("phi_names", [])
    actual = data.get("phi_actual", [])
    eps = data["episodes"]
    discrete = bool(data.get("phi_value_labels"))
    k = np.array([e["episode"] for e in eps])
    n = len(names)
    ncols = 2 if n in (2, 4) else min(n, 3)
    nrows = math.ceil(n / ncols)
    fig, axes = plt.subplots(nrows, ncols, figsize=(3.6 * ncols + (2 if discrete else 0),
                                                    2.8 * nrows), squeeze=False)
    for j, name in enumerate(names):
        ax = axes[j // ncols][j % ncols]
        i = all_names.index(name)
        vals = np.array([number(e["phi"][i]) if i < len(e.get("phi", [])) else math.nan
                         for e in eps])
        ax.plot(k, vals, "-o", color="#1f77b4", markersize=4, label="model's φ")
        sd = np.array([number(e["phi_sd"][i]) if i < len(e.get("phi_sd") or []) else math.nan
                       for e in eps])
        if np.isfinite(sd).any():  # GP-MI's posterior: phi +- 2 sd, clipped to the axes
            ax.fill_between(k, vals - 2 * sd, vals + 2 * sd, color="#1f77b4", alpha=0.2,
                            linewidth=0, label="± 2 sd (posterior)")
        if i < len(actual) and actual[i] is not None:
            ax.axhline(actual[i], color="black", linestyle="--", linewidth=1.2, label="actual")
        if discrete and i == 0:
            values = [v for v, _ in data["phi_value_labels"]]
            ax.set_yticks(values)
            ax.set_yticklabels([label for _, label in data["phi_value_labels"]])
        ax.set_title(phi_label(data, name))
        ax.set_xlabel("episode")
        ax.margins(y=0.25)
        if len(k) <= 20:
            ax.set_xticks(k if len(k) <= 10 else k[::2])
    for j in range(n, nrows * ncols):
        axes[j // ncols][j % ncols].axis("off")
    h, l = axes[0][0].get_legend_handles_labels()
    fig.legend(h, l, loc="lower center", ncol=2, frameon=False, bbox_to_anchor=(0.5, -0.01))
    fig.suptitle("Prior parameters φ chosen by the model per episode", fontsize=12)
    fig.tight_layout(rect=(0, 0.06, 1, 1))
    save(fig, os.path.join(out, "phi.png"))


def plot_phi_correlation(data, out):
    """The correlation matrix of GP-MI's posterior over phi at the last episode that has one:
    values near +-1 mark parameters the data only know in combination (a trade-off)."""
    c = data["phi_correlation"]
    names = [phi_label(data, n) for n in c["names"]]
    m = np.array([[number(v) for v in row] for row in c["matrix"]])
    n = len(names)
    fig, ax = plt.subplots(figsize=(1.1 * n + 2.2, 1.0 * n + 1.2))
    im = ax.imshow(m, vmin=-1, vmax=1, cmap="RdBu_r")
    ax.set_xticks(range(n))
    ax.set_xticklabels(names, rotation=45, ha="right")
    ax.set_yticks(range(n))
    ax.set_yticklabels(names)
    ax.grid(False)
    for a in range(n):
        for b in range(n):
            if np.isfinite(m[a, b]):
                ax.text(b, a, f"{m[a, b]:.2f}", ha="center", va="center", fontsize=8,
                        color="white" if abs(m[a, b]) > 0.6 else "black")
    fig.colorbar(im, ax=ax, fraction=0.046, pad=0.04)
    ax.set_title(f"Correlation of φ's posterior, episode {c['episode']}", fontsize=10)
    save(fig, os.path.join(out, "phi-correlation.png"))


def plot_metric(data, out):
    m = data["metric"]
    eps = data["episodes"]
    k = np.array([e["episode"] for e in eps])
    real = np.array([number(e["metrics"].get(m["name"])) for e in eps])
    if not np.isfinite(real).any():
        return
    fig, ax = plt.subplots(figsize=(7.5, 4.2))
    ax.plot(k, real, "-o", color="#1f77b4", linewidth=2, markersize=5, label="real system")
    pred = np.array([number(e["metrics"].get(m.get("predicted", ""))) for e in eps])
    if np.isfinite(pred).any():
        ax.plot(k, pred, "--s", color="#ff7f0e", linewidth=1.5, markersize=4,
                label="predicted (model mean)")
    if m.get("reference") is not None:
        ax.axhline(m["reference"], color="gray", linestyle=":", linewidth=1.2,
                   label=m.get("reference_label", "reference"))
    ax.set_xlabel("episode")
    ax.set_ylabel(with_unit(m["label"], m["unit"]))
    if len(k) <= 20:
        ax.set_xticks(k)
    ax.legend(loc="best", fontsize=9)
    ax.set_title(f"{data['name']}: {m['label']} per episode\n{data['panel_title']}; "
                 f"{data['variant_label']}", fontsize=11)
    save(fig, os.path.join(out, f"{m.get('file') or m['name']}.png"))


def column_info(data, name):
    """Kind (time, state, action, reward, extra), label with unit and whether the task labelled
    trajectory column `name` (plot-data.json "columns"; a column it does not list: its name)."""
    for c in data.get("columns", []):
        if c["name"] == name:
            return c["kind"], with_unit(c["text"], c["unit"]), bool(c.get("labelled"))
    return {"t": "time", "reward": "reward"}.get(name, "state"), name, False


def trajectory_columns(data, names):
    """The columns a trajectory figure draws, in the file's order: states, actions, then the
    reward; with more than 12 state and action columns (a legged robot), the states the task
    labelled (e.g. the body's pose) and the reward."""
    kind = {n: column_info(data, n)[0] for n in names}
    states = [c for c in names if kind[c] == "state"]
    actions = [c for c in names if kind[c] == "action"]
    if len(states) + len(actions) > 12:
        states = [c for c in states if column_info(data, c)[2]]
        actions = []
    return states + actions + [c for c in names if kind[c] == "reward"]


def plot_trajectory(data, k, out):
    real, pred = episode_tables(data, k)
    columns = trajectory_columns(data, real.names)
    ncols = 2
    nrows = math.ceil(len(columns) / ncols)
    fig, axes = plt.subplots(nrows, ncols, figsize=(10, 2.6 * nrows), sharex=True, squeeze=False)
    for j, c in enumerate(columns):
        ax = axes[j // ncols][j % ncols]
        kind, label, _ = column_info(data, c)
        # Actions are held constant over a time step.
        style = "steps-post" if kind == "action" else "default"
        ax.plot(real["t"], real[c], color="#1f77b4", linewidth=1.8, label="real", drawstyle=style)
        if pred is not None and c in pred:
            ax.plot(pred["t"], pred[c], color="#ff7f0e", linestyle="--", linewidth=1.8,
                    label="predicted (model mean)", drawstyle=style)
        ax.set_ylabel(label)
        if j // ncols == nrows - 1 or j + ncols >= len(columns):
            ax.set_xlabel("time (s)")
            ax.tick_params(labelbottom=True)
    for j in range(len(columns), nrows * ncols):
        axes[j // ncols][j % ncols].axis("off")
    h, l = axes[0][0].get_legend_handles_labels()
    fig.legend(h, l, loc="lower center", ncol=2, frameon=False, bbox_to_anchor=(0.5, -0.01))
    ep = episode_entry(data, k)
    pr = ep.get("predicted_return")
    parts = [f"{data['name']}: episode {k}", f"real return {number(ep.get('real_return')):.2f}"]
    parts.append(f"predicted {pr:.2f}" if pr is not None else "no prediction")
    parts.append("solved" if ep.get("solved") else "not solved")
    fig.suptitle(", ".join(parts), fontsize=12)
    fig.tight_layout(rect=(0, 0.04, 1, 1))
    save(fig, os.path.join(out, f"trajectories-{k:03d}.png"))


# ---- legged robots: body path seen from above, gait diagram (columns x, y, yaw, foot*_height) ----

LEG_NAMES = ["0 rear-left", "1 mid-left", "2 front-left", "3 front-right", "4 mid-right",
             "5 rear-right"]
# A foot touches the ground when its lowest point is within this height of the ground plane (m);
# contacts let it sink a few mm, and the state is sampled every 0.1 s.
CONTACT_HEIGHT = 0.005


def plot_path(data, k, out):
    real, pred = episode_tables(data, k)
    fig, ax = plt.subplots(figsize=(7, 5))
    ax.plot(real["x"], real["y"], "-", color="#1f77b4", linewidth=2, label="real robot")
    if pred is not None:
        ax.plot(pred["x"], pred["y"], "--", color="#ff7f0e", linewidth=1.8,
                label="predicted (model mean)")
    # Heading every second: an arrow along the body's x axis (yaw).
    t = real["t"]
    step = max(1, int(round(1.0 / (t[1] - t[0])))) if len(t) > 1 else 1
    idx = np.arange(0, len(t), step)
    scale = 0.06
    ax.quiver(real["x"][idx], real["y"][idx], scale * np.cos(real["yaw"][idx]),
              scale * np.sin(real["yaw"][idx]), angles="xy", scale_units="xy", scale=1,
              color="#1f77b4", width=0.005, headwidth=4, label="heading (every 1 s)")
    ax.plot(real["x"][0], real["y"][0], "ko", markersize=6, label="start")
    ax.axhline(0.5, color="red", linestyle=":", linewidth=1)
    ax.axhline(-0.5, color="red", linestyle=":", linewidth=1, label="|y| = 0.5 m (penalty)")
    ax.set_xlabel("x, forward (m)")
    ax.set_ylabel("y, left (m)")
    ax.set_aspect("equal", adjustable="datalim")
    ax.legend(loc="best", fontsize=9)
    ep = episode_entry(data, k)
    m = data["metric"]
    value = number(ep.get("metrics", {}).get(m["name"])) if m["name"] else math.nan
    ax.set_title(f"{data['name']}: episode {k}, body path from above\n"
                 + (f"{m['label']} {value:.3f} {m['unit']}, " if math.isfinite(value) else "")
                 + f"model's prior {phi_value_label(data, (ep.get('phi') or [None])[0])}",
                 fontsize=11)
    save(fig, os.path.join(out, f"path-{k:03d}.png"))


def plot_gait(data, k, out):
    real, _ = episode_tables(data, k)
    t = real["t"]
    dt = t[1] - t[0] if len(t) > 1 else 0.1
    fig, (ax, axh) = plt.subplots(2, 1, figsize=(9, 5.5), sharex=True,
                                  gridspec_kw={"height_ratios": [1.2, 1]})
    for leg in range(6):
        col = f"foot{leg}_height"
        if col not in real:
            continue
        h = real[col]
        row = 5 - leg
        if not np.all(np.isnan(h)):
            on = h < CONTACT_HEIGHT
            spans = [(t[i] - dt / 2, dt) for i in range(len(t)) if on[i]]
            ax.broken_barh(spans, (row - 0.4, 0.8), facecolors="#333333")
            axh.plot(t, h * 1000, linewidth=1.3, label=f"leg {LEG_NAMES[leg]}")
        else:
            ax.text(t[0], row, "  removed", va="center", color="gray", fontsize=9)
    ax.set_yticks(range(6))
    ax.set_yticklabels([f"leg {LEG_NAMES[5 - r]}" for r in range(6)])
    ax.set_ylim(-0.6, 5.6)
    ax.set_title(f"{data['name']}: episode {k}, gait diagram of the real robot\n(black: foot on "
                 f"the ground, lowest point < {CONTACT_HEIGHT * 1000:.0f} mm; sampled every "
                 f"{dt:.1f} s)", fontsize=11)
    axh.axhline(CONTACT_HEIGHT * 1000, color="gray", linestyle=":", linewidth=1)
    axh.set_ylabel("foot height (mm)")
    axh.set_xlabel("time (s)")
    axh.legend(loc="upper right", fontsize=7, ncol=3)
    fig.tight_layout()
    save(fig, os.path.join(out, f"gait-{k:03d}.png"))


def plot_run(data_json, out):
    with open(data_json) as f:
        data = json.load(f)
    plot_returns(data, out)
    if data.get("phi_plotted"):
        plot_phi(data, out)
    if data.get("phi_correlation"):
        plot_phi_correlation(data, out)
    if data["metric"].get("name"):
        plot_metric(data, out)
    for key in sorted(data["trajectories"], key=int):
        k = int(key)
        plot_trajectory(data, k, out)
        real, _ = episode_tables(data, k)
        if all(c in real for c in ("x", "y", "yaw")):
            plot_path(data, k, out)
        if any(f"foot{leg}_height" in real for leg in range(6)):
            plot_gait(data, k, out)


# ---------------------------------------------------------------- archives (IT&E)

def read_archive(path):
    """The archive file of drops (docs/ite.md): bins, descriptor names, the MAP-Elites line and
    the elites' cells and fitness."""
    info = {"bins": None, "names": None, "map_elites": {}, "task": "", "prior": ""}
    cells, fitness = [], []
    with open(path) as f:
        lines = f.read().splitlines()
    if not lines or lines[0].strip() != "# drops-map-elites-archive 1":
        raise SystemExit(f"drops_plot.py: {path} is not a drops archive file")
    i = 1
    while i < len(lines) and lines[i].startswith("#"):
        words = lines[i][1:].split()
        if words and words[0] == "bins":
            info["bins"] = [int(w) for w in words[1:]]
        elif words and words[0] == "descriptor":
            info["names"] = words[1:]
        elif words and words[0] in ("task", "prior"):
            info[words[0]] = " ".join(words[1:])
        elif words and words[0] == "map_elites":
            info["map_elites"] = {words[j]: int(words[j + 1]) for j in range(1, len(words) - 1, 2)}
        i += 1
    k = len(info["bins"])
    for row in csv.reader(lines[i + 1:]):
        if not row:
            continue
        cells.append([int(v) for v in row[:k]])
        fitness.append(float(row[2 * k]))
    if info["names"] is None:
        info["names"] = [f"descriptor_{d}" for d in range(k)]
    return info, np.array(cells, dtype=int).reshape(-1, k), np.array(fitness)


def unrolled_index(cells, bins, dims):
    """Position along one axis of the unrolled grid: dims nested, the first the outermost."""
    index = np.zeros(len(cells), dtype=int)
    for d in dims:
        index = index * bins[d] + cells[:, d]
    return index


def plot_archive(archive_csv, output_png):
    info, cells, fitness = read_archive(archive_csv)
    bins, names = info["bins"], info["names"]
    k = len(bins)
    total = int(np.prod(bins))
    xdims, ydims = list(range(0, k, 2)), list(range(1, k, 2))
    width = int(np.prod([bins[d] for d in xdims]))
    height = int(np.prod([bins[d] for d in ydims])) if ydims else 1
    grid = np.full((height, width), np.nan)
    if len(cells):
        xs = unrolled_index(cells, bins, xdims)
        ys = unrolled_index(cells, bins, ydims) if ydims else np.zeros(len(cells), dtype=int)
        grid[ys, xs] = fitness

    fig = plt.figure(figsize=(13, 6.2))
    gs = fig.add_gridspec(2, 2, width_ratios=[1.5, 1], hspace=0.45, wspace=0.25)
    ax = fig.add_subplot(gs[:, 0])
    cmap = plt.get_cmap("viridis").copy()
    cmap.set_bad("white")
    image = ax.imshow(grid, origin="lower", cmap=cmap, interpolation="nearest", aspect="auto")
    fig.colorbar(image, ax=ax, label="fitness (return on the prior)")
    # Lines between the blocks of the outermost dimensions.
    if len(xdims) > 1:
        step = width // bins[xdims[0]]
        for j in range(1, bins[xdims[0]]):
            ax.axvline(j * step - 0.5, color="0.6", linewidth=0.6)
    if len(ydims) > 1:
        step = height // bins[ydims[0]]
        for j in range(1, bins[ydims[0]]):
            ax.axhline(j * step - 0.5, color="0.6", linewidth=0.6)
    ax.set_xlabel(" > ".join(names[d] for d in xdims) + "  (outermost first)")
    ax.set_ylabel(" > ".join(names[d] for d in ydims) + "  (outermost first)" if ydims else "")
    ax.set_xticks([])
    ax.set_yticks([])
    me = info["map_elites"]
    what = ", ".join(filter(None, [info["task"], f"prior {info['prior']}" if info["prior"] else ""]))
    title = f"{len(cells)} of {total} cells filled ({100.0 * len(cells) / total:.1f} %)"
    if me.get("evaluations"):
        title += f" after {me['evaluations']:,} evaluations"
        if not me.get("complete", 1):
            title += " (in progress)"
    ax.set_title((what + "\n" if what else "") + title, fontsize=11)

    # Coverage per value of each dimension: the fraction of the cells with that value filled.
    axc = fig.add_subplot(gs[0, 1])
    for d in range(k):
        per_bin = total // bins[d]
        counts = np.bincount(cells[:, d], minlength=bins[d]) if len(cells) else np.zeros(bins[d])
        centres = (np.arange(bins[d]) + 0.5) / bins[d]
        axc.plot(centres, 100.0 * counts / per_bin, marker="o", linewidth=1.2,
                 color=COLORS[d % len(COLORS)], label=names[d])
    axc.set_xlabel("descriptor value (bin centre)")
    axc.set_ylabel("cells filled (%)")
    axc.set_xlim(0, 1)
    axc.legend(fontsize=8, ncol=2)
    axc.set_title("coverage per descriptor value", fontsize=11)

    axf = fig.add_subplot(gs[1, 1])
    if len(fitness):
        axf.hist(fitness, bins=40, color=COLORS[0])
        axf.axvline(fitness.max(), color=COLORS[1], linestyle="--", linewidth=1,
                    label=f"best {fitness.max():.3g}")
        axf.legend(fontsize=8)
    axf.set_xlabel("fitness (return on the prior)")
    axf.set_ylabel("elites")
    axf.set_title("fitness of the elites", fontsize=11)
    save(fig, output_png)


def plot_calibration(calibration_csv, output_png):
    """Where the real returns fell among the model's predicted rollouts' returns (drops report's
    calibration.csv): per panel, one histogram per variant of the quantiles of the episodes whose
    policy was new (replays of the best policy and episode 1, predicted by the prior alone, left
    out), as fractions of the episodes in 10 bins. A calibrated model gives a flat histogram at
    0.1; mass at 0 means real returns below every predicted one (an optimistic model)."""
    with open(calibration_csv, newline="") as f:
        rows = [r for r in csv.DictReader(f)
                if r["replay"] == "0" and r["episode"] != "1" and r["quantile"] != "nan"]
    priors, variants, label, title, color = panels_and_variants(rows)
    n = max(1, len(priors))
    ncols = n if n <= 3 else (2 if n == 4 else 3)
    nrows = math.ceil(n / ncols)
    fig, axes = plt.subplots(nrows, ncols, figsize=(5.2 * ncols, 3.4 * nrows), sharey=True,
                             squeeze=False)
    edges = np.linspace(0.0, 1.0, 11)
    for i, prior in enumerate(priors):
        ax = axes[i // ncols][i % ncols]
        for v in variants:
            pts = [r for r in rows if r["prior"] == prior and r["variant"] == v]
            if not pts:
                continue
            q = np.array([number(r["quantile"]) for r in pts])
            inside = np.mean([r["inside_band"] == "1" for r in pts])
            counts, _ = np.histogram(np.clip(q, 0.0, 1.0), bins=edges)
            ax.stairs(counts / len(q), edges, color=color[v], linewidth=1.8,
                      label=f"{label[v]} ({len(q)} ep., {100 * inside:.0f} % in 5–95 %)")
        ax.axhline(0.1, color="0.4", linestyle=":", linewidth=1)
        ax.set_title(title[prior])
        ax.set_xlabel("quantile of the real return among the predicted ones")
        ax.set_xlim(0, 1)
        ax.legend(fontsize=7, loc="upper center")
    for j in range(len(priors), nrows * ncols):
        axes[j // ncols][j % ncols].axis("off")
    for r in range(nrows):
        axes[r][0].set_ylabel("fraction of episodes")
    save(fig, output_png)


# ---- drops identify: predicted against recorded trajectories, and phi ----

def read_columns(path):
    """A CSV file as {column: numpy array} (empty cells NaN)."""
    with open(path, newline="") as f:
        rows = list(csv.reader(f))
    header, body = rows[0], rows[1:]
    return {name: np.array([number(r[j]) for r in body]) for j, name in enumerate(header)}


def plot_identify_validation(csv_path, png_path):
    t = read_columns(csv_path)
    states = [c for c in t if c.startswith("pred_")]
    recorded = np.isnan(t["start"])
    ncols = 2 if len(states) > 1 else 1
    nrows = math.ceil(len(states) / ncols)
    fig, axes = plt.subplots(nrows, ncols, figsize=(10, 2.6 * nrows), sharex=True, squeeze=False)
    starts = np.unique(t["start"][~recorded])
    for j, p in enumerate(states):
        c = p[len("pred_"):]
        ax = axes[j // ncols][j % ncols]
        ax.plot(t["t"][recorded], t[c][recorded], color="#1f77b4", linewidth=1.8,
                label="recorded")
        for k, s0 in enumerate(starts):
            rows = t["start"] == s0
            ax.plot(t["t"][rows], t[p][rows], color="#ff7f0e", linestyle="--", linewidth=1.4,
                    label="predicted open loop (model mean)" if k == 0 else None)
            ax.plot(t["t"][rows][:1], t[p][rows][:1], "o", color="#ff7f0e", markersize=3,
                    label="start point" if k == 0 else None)
        ax.set_ylabel(c)
        if j // ncols == nrows - 1 or j + ncols >= len(states):
            ax.set_xlabel("time (s)")
            ax.tick_params(labelbottom=True)
    for j in range(len(states), nrows * ncols):
        axes[j // ncols][j % ncols].axis("off")
    h, l = axes[0][0].get_legend_handles_labels()
    fig.legend(h, l, loc="lower center", ncol=3, frameon=False, bbox_to_anchor=(0.5, -0.01))
    fig.suptitle(f"{os.path.basename(csv_path)}: recorded and predicted from each start point",
                 fontsize=12)
    fig.tight_layout(rect=(0, 0.05, 1, 1))
    save(fig, png_path)


def plot_identify_phi(csv_path, png_path):
    with open(csv_path, newline="") as f:
        rows = [r for r in csv.DictReader(f) if r["tunable"] == "1"]
    if not rows:
        return False
    n = len(rows)
    ncols = 2 if n in (2, 4) else min(n, 3)
    nrows = math.ceil(n / ncols)
    fig, axes = plt.subplots(nrows, ncols, figsize=(3.4 * ncols, 2.2 * nrows), squeeze=False)
    for j, r in enumerate(rows):
        ax = axes[j // ncols][j % ncols]
        v, lo, hi = number(r["value"]), number(r["lower95"]), number(r["upper95"])
        ax.plot([number(r["start"])], [1], "s", color="#7f7f7f", markersize=7, label="start")
        if math.isfinite(lo):
            ax.errorbar([v], [0], xerr=[[v - lo], [hi - v]], fmt="o", color="#1f77b4",
                        capsize=4, label="learned, 95% interval")
        else:
            ax.plot([v], [0], "o", color="#1f77b4", label="learned (no interval)")
        ax.set_yticks([])
        ax.set_ylim(-0.8, 1.8)
        ax.margins(x=0.3)
        ax.set_title(r["name"])
    for j in range(n, nrows * ncols):
        axes[j // ncols][j % ncols].axis("off")
    handles, labels = {}, {}
    for ax in axes.flat:
        for h, l in zip(*ax.get_legend_handles_labels()):
            handles.setdefault(l, h)
    fig.legend(list(handles.values()), list(handles.keys()), loc="lower center", ncol=3,
               frameon=False, bbox_to_anchor=(0.5, -0.02))
    fig.suptitle("Prior parameters φ: start and learned", fontsize=12)
    fig.tight_layout(rect=(0, 0.08, 1, 1))
    save(fig, png_path)
    return True


def plot_identify(directory):
    names = sorted(f for f in os.listdir(directory)
                   if f.startswith("validation-") and f.endswith(".csv"))
    for name in names:
        plot_identify_validation(os.path.join(directory, name),
                                 os.path.join(directory, name[:-4] + ".png"))
    phi = os.path.join(directory, "phi.csv")
    if os.path.exists(phi):
        plot_identify_phi(phi, os.path.join(directory, "phi.png"))


def main():
    parser = argparse.ArgumentParser(description=__doc__,
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    sub = parser.add_subparsers(dest="command", required=True)
    rep = sub.add_parser("report")
    rep.add_argument("table_csv")
    rep.add_argument("output_png")
    rep.add_argument("--ylabel", default="return")
    run = sub.add_parser("run")
    run.add_argument("plot_data")
    run.add_argument("output_dir")
    cal = sub.add_parser("calibration")
    cal.add_argument("calibration_csv")
    cal.add_argument("output_png")
    arch = sub.add_parser("archive")
    arch.add_argument("archive_csv")
    arch.add_argument("output_png")
    ident = sub.add_parser("identify")
    ident.add_argument("directory")
    args = parser.parse_args()
    if args.command == "identify":
        plot_identify(args.directory)
    elif args.command == "report":
        plot_report(args.table_csv, args.output_png, args.ylabel)
    elif args.command == "calibration":
        plot_calibration(args.calibration_csv, args.output_png)
    elif args.command == "archive":
        plot_archive(args.archive_csv, args.output_png)
    else:
        plot_run(args.plot_data, args.output_dir)


if __name__ == "__main__":
    main()
