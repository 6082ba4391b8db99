#!/usr/bin/python3
"""python/drops_plot.py's returns figures with one diverged episode: a return of -372,046 among
returns of 60-69 (a user's pendulum of 120 steps; issue 65) is left outside the y-axis, which
still holds every other point, and the figure names it with its value; a learning curve without
such a point keeps matplotlib's own limits. Needs Debian's python3-matplotlib and python3-numpy;
exits 77 (ctest: skipped) without them.

  /usr/bin/python3 tests/plot_script_test.py PYTHON_DIR
"""

import csv
import os
import sys
import tempfile
import unittest

d = None  # drops_plot, imported from the command line's folder

OUTLIER = -372046.0
# Real and predicted returns of 10 episodes; episode 5 diverged.
REAL = [2.1, 15.3, 60.2, 64.8, OUTLIER, 66.1, 68.9, 63.0, 69.2, 61.7]
PREDICTED = [None, 40.0, 62.5, 65.0, 70.3, 66.0, 68.4, 64.1, 69.0, 62.2]


class Drawn:
    """Records the y-limits and texts of every figure drops_plot saves, then saves it."""

    def __init__(self):
        self.figures = []
        self.save = d.save

    def __call__(self, fig, path):
        texts = [t.get_text() for ax in fig.axes for t in
                 (ax.get_legend().get_texts() if ax.get_legend() else [])]
        texts += [t.get_text() for legend in fig.legends for t in legend.get_texts()]
        title = fig._suptitle.get_text() if fig._suptitle else ""
        self.figures.append({"ylims": [ax.get_ylim() for ax in fig.axes if ax.get_visible()
                                       and ax.axison],
                             "texts": texts, "title": title, "path": path})
        self.save(fig, path)


def plot_data(real, predicted):
    return {"name": "rotary-pendulum", "variant_label": "Black-DROPS with GP-MI",
            "panel_title": "own prior",
            "episodes": [{"episode": k + 1, "interaction_time_s": 6.0 * (k + 1),
                          "real_return": r, "predicted_return": p, "solved": False}
                         for k, (r, p) in enumerate(zip(real, predicted))]}


class OutlierLimits(unittest.TestCase):
    def test_a_far_return_is_left_out_and_the_others_kept(self):
        lo, hi = d.outlier_limits(REAL + PREDICTED[1:])
        self.assertLess(OUTLIER, lo)
        for v in REAL + PREDICTED[1:]:
            if v != OUTLIER:
                self.assertTrue(lo <= v <= hi, f"{v} outside ({lo}, {hi})")

    def test_far_values_at_both_ends_are_left_out(self):
        values = [60.0 + (k % 10) for k in range(30)] + [-5e5, 7e6]
        lo, hi = d.outlier_limits(values)
        self.assertTrue(-5e5 < lo < 60.0 and 69.0 < hi < 7e6, (lo, hi))

    def test_learning_curves_keep_their_own_limits(self):
        # A jump from the first episodes to the solved ones (the pendubot's replays of its best
        # policy return the same 20.1 again and again), a curve that only rises, a flat one, a
        # first prediction far above the first real returns, too few values to judge.
        for values in ([6.3, 19.9, 20.13, 20.15, 20.15, 20.15],
                       [1.0, 2.0, 4.0, 8.0, 16.0, 32.0, 64.0],
                       [0.0, 0.0, 0.0, 0.0, 0.0, 90.0],
                       [0.0, 0.3, 3.8],
                       [OUTLIER, 60.0, 65.0]):
            self.assertIsNone(d.outlier_limits(values), values)


class Figures(unittest.TestCase):
    def setUp(self):
        self.tmp = tempfile.TemporaryDirectory()
        self.drawn = Drawn()
        d.save = self.drawn

    def tearDown(self):
        d.save = self.drawn.save
        self.tmp.cleanup()

    def test_drops_plot_returns_figure_names_the_outlier_outside_its_axis(self):
        d.plot_returns(plot_data(REAL, PREDICTED), self.tmp.name)
        fig = self.drawn.figures[-1]
        lo, hi = fig["ylims"][0]
        self.assertLess(OUTLIER, lo)
        for v in REAL + PREDICTED[1:]:
            if v != OUTLIER:
                self.assertTrue(lo <= v <= hi, f"{v} outside ({lo}, {hi})")
        self.assertIn("1 real return below the axis: \u2212372,046 (episode 5)", fig["texts"])
        self.assertTrue(os.path.getsize(os.path.join(self.tmp.name, "returns.png")) > 0)

    def test_drops_plot_returns_figure_without_an_outlier_is_unchanged(self):
        real = [v for v in REAL if v != OUTLIER]
        predicted = PREDICTED[:4] + PREDICTED[5:]
        d.plot_returns(plot_data(real, predicted), self.tmp.name)
        fig = self.drawn.figures[-1]
        values = real + predicted[1:]
        span = max(values) - min(values)  # matplotlib's default margin: 5 % of the span
        self.assertAlmostEqual(fig["ylims"][0][0], min(values) - 0.05 * span)
        self.assertAlmostEqual(fig["ylims"][0][1], max(values) + 0.05 * span)
        self.assertFalse([t for t in fig["texts"] if "the axis" in t], fig["texts"])

    def test_drops_report_figure_names_the_outlier_outside_its_axis(self):
        table = os.path.join(self.tmp.name, "returns.csv")
        with open(table, "w", newline="") as f:
            w = csv.writer(f)
            w.writerow(["variant", "prior", "episode", "interaction_time_s", "runs", "median",
                        "q25", "q75", "variant_label", "panel_title", "variant_colour"])
            for k, r in enumerate(REAL):  # one run: its return is the median and the quartiles
                w.writerow(["gp_mi", "own", k + 1, 6.0 * (k + 1), 1, r, r, r,
                            "Black-DROPS with GP-MI", "own prior", "#1f77b4"])
            for k, r in enumerate(REAL):  # three runs of a second panel, none diverged
                m = abs(r) if r != OUTLIER else 65.0
                w.writerow(["gp_mi", "none", k + 1, 6.0 * (k + 1), 3, m, m - 2.0, m + 2.0,
                            "Black-DROPS with GP-MI", "no prior", "#1f77b4"])
                if k < 6:  # a variant with fewer episodes so far
                    w.writerow(["gp", "none", k + 1, 6.0 * (k + 1), 3, m / 2, m / 2 - 2.0,
                                m / 2 + 2.0, "Black-DROPS", "no prior", ""])
        d.plot_report(table, os.path.join(self.tmp.name, "returns.png"))
        fig = self.drawn.figures[-1]
        for lo, hi in fig["ylims"]:  # the panels share the axis
            self.assertLess(OUTLIER, lo)
            for r in REAL:
                if r != OUTLIER:
                    self.assertTrue(lo <= r - 2.0 and r + 2.0 <= hi, f"{r} outside ({lo}, {hi})")
        self.assertIn("1 median below the axis: \u2212372,046 "
                      "(Black-DROPS with GP-MI, own prior, 30 s)", fig["title"])
        self.assertTrue(os.path.getsize(os.path.join(self.tmp.name, "returns.png")) > 0)


if __name__ == "__main__":
    if len(sys.argv) < 2:
        sys.exit(__doc__)
    sys.path.insert(0, sys.argv.pop(1))
    try:
        import matplotlib  # noqa: F401
        import numpy  # noqa: F401
    except ImportError as exc:
        print(f"skipped: {exc}")
        sys.exit(77)
    import drops_plot as d
    unittest.main()
