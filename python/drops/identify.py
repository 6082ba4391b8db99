"""drops.identify: a dynamics model learned from recorded logs, as ``drops identify`` does
(docs/identify.md)."""

from dataclasses import dataclass

import numpy as _np

from . import _drops


@dataclass(frozen=True)
class IdentifyResult:
    """What drops.identify learned and measured; the files are in `directory`.

    directory: the output directory (str; phi.csv, errors.csv, model.json, data.csv, report.md,
        validation-NN.csv).
    model_type: model.type ("gp", "gp_prior", "gp_mi", "mi").
    state_names, action_names: lists of E and U names; dt: the control period (s).
    transitions: transitions in the fit logs; points: those the model learned from.
    phi_names: P names (empty for model.type=gp); phi_start, phi, phi_lower95, phi_upper95: (P,)
        the prior's parameters at the start, learned, and the bounds of the posterior's 95%
        interval (NaN where the model has no posterior or the entry is not tunable);
        phi_tunable: (P,) bool.
    horizons: (H + 1,) s: dt (the one-step errors), then identify.horizons.
    validation_files: F paths as given.
    median, p90: (F, H + 1, E) the median and 90th percentile over the start points of
        |predicted - recorded| per validation file, horizon and state dimension (the state's
        units; NaN where no start point fits a horizon); n: (F, H + 1) start points counted.
    prior_median, prior_p90: the same for the prior alone at phi_start (None without a prior).
    learn_seconds: wall-clock of the learning; brief: a few lines of summary.
    """

    directory: str
    model_type: str
    state_names: list
    action_names: list
    dt: float
    transitions: int
    points: int
    phi_names: list
    phi_start: _np.ndarray
    phi: _np.ndarray
    phi_lower95: _np.ndarray
    phi_upper95: _np.ndarray
    phi_tunable: _np.ndarray
    horizons: _np.ndarray
    validation_files: list
    median: _np.ndarray
    p90: _np.ndarray
    n: _np.ndarray
    prior_median: object
    prior_p90: object
    learn_seconds: float
    brief: str

    def __repr__(self):
        return (f"IdentifyResult(model_type='{self.model_type}', directory='{self.directory}', "
                f"points={self.points}, phi={_np.array2string(self.phi, precision=4)})")


def _tables(rows, files, horizons, E):
    # The rows come per file, then per horizon (the one-step errors first), then per dimension.
    F, H = len(files), len(horizons) + 1
    median = _np.full((F, H, E), _np.nan)
    p90 = _np.full((F, H, E), _np.nan)
    n = _np.zeros((F, H), dtype=int)
    index = {f: i for i, f in enumerate(files)}
    seen = [0] * F
    for file, _horizon, _steps, dim, med, q90, count in rows:
        f = index[file]
        h = seen[f] // E
        seen[f] += 1
        if count > 0:
            median[f, h, dim], p90[f, h, dim] = med, q90
        n[f, h] = count
    return median, p90, n


def _result(d):
    E, files, horizons = len(d["state_names"]), d["validation_files"], list(d["horizons"])
    median, p90, n = _tables(d["errors"], files, horizons, E)
    prior_median = prior_p90 = None
    if d["prior_errors"]:
        prior_median, prior_p90, _ = _tables(d["prior_errors"], files, horizons, E)
    return IdentifyResult(
        directory=d["directory"], model_type=d["model_type"], state_names=list(d["state_names"]),
        action_names=list(d["action_names"]), dt=d["dt"], transitions=d["transitions"],
        points=d["points"], phi_names=list(d["phi_names"]), phi_start=d["phi_start"],
        phi=d["phi"], phi_lower95=d["phi_lower95"], phi_upper95=d["phi_upper95"],
        phi_tunable=_np.array(d["phi_tunable"], dtype=bool),
        horizons=_np.array([d["dt"]] + horizons), validation_files=list(files), median=median,
        p90=p90, n=n, prior_median=prior_median, prior_p90=prior_p90,
        learn_seconds=d["learn_seconds"], brief=d["brief"])
