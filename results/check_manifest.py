#!/usr/bin/env python3
"""Check the data release of results/: the compact summaries against results/manifest.csv.

  python3 results/check_manifest.py [RESULTS_DIR]

Checks (exit 1 with one line per failure, 0 when all hold):
  - manifest.csv has the documented columns, and (kind, name) is unique;
  - every archive row: a 64-hex sha256, a size, a 40-hex tree_commit, added_in and git object,
    the path results/NAME.tar.xz, a status canonical, superseded or study;
  - every campaign row: its summary file exists, its size and sha256 are the manifest's, a
    config and source are given, the commits are 40-hex (code_commit may be empty);
  - config names files of today's tree (checked when RESULTS_DIR sits in a checkout that has
    configs/): every campaign and canonical archive has one, superseded and study archives none;
    original_config is COMMIT:configs/NAME.yaml (the files the runs were made with, for
    `git show`), given for every campaign (an archive made by commands alone has none);
  - every summary file: exactly the documented columns; each of its campaigns is in the manifest
    and each campaign row of the manifest has rows in it; no duplicate (campaign, run, episode)
    (for the ceilings: (campaign, search)); the episodes of each run are 1, 2, ..., n; the
    numbers parse; the file is below 300 KB;
  - results/ holds no *.tar.xz the manifest does not list with that size and sha256, and no
    other file over 1 MB;
  - inside a git clone that has the commits: each archive's git object is the blob at
    tree_commit:file, and each original_config exists (skipped, and said so, without git or
    without those commits).
Standard library only, so any python3 runs it.
"""

import argparse
import csv
import hashlib
import math
import os
import re
import subprocess
import sys

MANIFEST_COLUMNS = ["kind", "name", "task", "status", "config", "original_config", "command", "code_commit",
                    "added_in", "tree_commit", "file", "bytes", "sha256", "git_object", "source",
                    "description"]
COMMON = ["campaign", "run", "task", "algorithm", "variant", "prior", "damage", "seed", "episode",
          "interaction_time_s", "real_return", "predicted_return", "solved"]
# A realaigym_pendubot campaign's summary: the leaderboard's criteria of each episode, phi.
REALAIGYM = COMMON + [
    "swingup_success", "swingup_time_s", "energy_j", "max_tau_nm", "integrated_tau_nms",
    "tau_cost", "tau_smoothness_nm", "velocity_cost", "realai_score", "phi",
    "calibration_quantile", "calibration_inside_band", "calibration_gap", "calibration_replay"]
SUMMARY_COLUMNS = {
    "summaries/pendubot.csv": COMMON + ["phi_m1", "phi_m2", "phi_l1", "phi_l2", "phi_b1",
                                        "phi_b2"],
    "summaries/hexapod.csv": COMMON + ["speed_m_s", "predicted_speed_m_s", "phi_prior"],
    "summaries/hexapod-ite-archive-size.csv": COMMON + [
        "speed_m_s", "predicted_speed_m_s", "phi_prior", "archive_evaluations", "archive_cells",
        "archive_coverage"],
    "summaries/pendubot-gp_mi-fresh.csv": COMMON + [
        "phi_m1", "phi_m2", "phi_l1", "phi_l2", "phi_b1", "phi_b2", "calibration_quantile",
        "calibration_inside_band", "calibration_gap", "calibration_replay"],
    "summaries/pendubot-gp_mi-fresh-reflected.csv": COMMON + [
        "phi_m1", "phi_m2", "phi_l1", "phi_l2", "phi_b1", "phi_b2", "calibration_quantile",
        "calibration_inside_band", "calibration_gap", "calibration_replay"],
    "summaries/pendubot-gp_mi-fresh-tol9.csv": COMMON + [
        "phi_m1", "phi_m2", "phi_l1", "phi_l2", "phi_b1", "phi_b2", "calibration_quantile",
        "calibration_inside_band", "calibration_gap", "calibration_replay"],
    "summaries/pendubot-gp_mi-fresh-blocks.csv": COMMON + [
        "phi_m1", "phi_m2", "phi_l1", "phi_l2", "phi_b1", "phi_b2", "calibration_quantile",
        "calibration_inside_band", "calibration_gap", "calibration_replay"],
    "summaries/hexapod-fresh.csv": COMMON + [
        "speed_m_s", "predicted_speed_m_s", "phi_prior", "calibration_quantile",
        "calibration_inside_band", "calibration_gap", "calibration_replay"],
    "summaries/realaigym-pendubot.csv": REALAIGYM,
    "summaries/realaigym-pendubot-3nm.csv": REALAIGYM,
    "summaries/hexapod-ceiling.csv": [
        "campaign", "search", "task", "algorithm", "damage", "seed", "start", "sigma0",
        "episodes", "status", "best_episode", "best_return", "best_speed_m_s", "max_speed_m_s",
        "command", "start_theta", "best_theta"],
}
# Columns that hold numbers (empty allowed where a value does not exist, e.g. no prediction).
NUMBERS = {"seed", "episode", "interaction_time_s", "real_return", "predicted_return", "solved",
           "phi_m1", "phi_m2", "phi_l1", "phi_l2", "phi_b1", "phi_b2", "speed_m_s",
           "predicted_speed_m_s", "sigma0", "episodes", "best_episode", "best_return",
           "best_speed_m_s", "max_speed_m_s", "archive_evaluations", "archive_cells",
           "archive_coverage", "calibration_quantile", "calibration_inside_band",
           "calibration_gap", "calibration_replay", "swingup_success", "swingup_time_s",
           "energy_j", "max_tau_nm", "integrated_tau_nms", "tau_cost", "tau_smoothness_nm",
           "velocity_cost", "realai_score"}
REQUIRED = {"campaign", "run", "search", "task", "algorithm", "variant", "seed", "episode",
            "interaction_time_s", "real_return", "solved", "best_return", "best_speed_m_s",
            "best_theta"}
HEX64 = re.compile(r"^[0-9a-f]{64}$")
HEX40 = re.compile(r"^[0-9a-f]{40}$")
ORIGINAL_CONFIG = re.compile(r"^[0-9a-f]{7,40}:configs/[A-Za-z0-9_.-]+\.ya?ml$")
MAX_SUMMARY_BYTES = 300 * 1024
MAX_FILE_BYTES = 1024 * 1024

failures = []


def fail(message):
    failures.append(message)


def sha256_of(path):
    h = hashlib.sha256()
    with open(path, "rb") as f:
        for block in iter(lambda: f.read(1 << 20), b""):
            h.update(block)
    return h.hexdigest()


def read_csv(path):
    with open(path, newline="") as f:
        reader = csv.DictReader(f)
        return reader.fieldnames or [], list(reader)


def check_configs(results, rows):
    """config: files of today's tree; original_config: COMMIT:configs/NAME.yaml."""
    root = os.path.dirname(os.path.abspath(results))
    in_checkout = os.path.isdir(os.path.join(root, "configs"))
    if not in_checkout:
        print("check_manifest.py: config files not checked (no configs/ beside results/)")
    for i, r in enumerate(rows, start=2):
        where = f"manifest.csv line {i} ({r['kind']} {r['name']})"
        if r["kind"] == "directory":
            continue
        wants_config = r["kind"] == "campaign" or r["status"] == "canonical"
        if wants_config and not r["config"]:
            fail(f"{where}: no config of today's tree")
        if not wants_config and r["config"]:
            fail(f"{where}: a {r['status']} archive names a config of today's tree "
                 f"({r['config']}); its configs are original_config")
        for path in r["config"].split():
            if not path.startswith("configs/"):
                fail(f"{where}: config {path!r} is not configs/NAME")
            elif in_checkout and not os.path.isfile(os.path.join(root, path)):
                fail(f"{where}: config {path} is not in the tree (a file that left it goes "
                     "in original_config as COMMIT:PATH)")
        if r["kind"] == "campaign" and not r["original_config"]:
            fail(f"{where}: no original_config")
        for spec in r["original_config"].split():
            if not ORIGINAL_CONFIG.match(spec):
                fail(f"{where}: original_config {spec!r} is not COMMIT:configs/NAME.yaml")


def check_manifest(results, rows):
    seen = set()
    for i, r in enumerate(rows, start=2):
        where = f"manifest.csv line {i} ({r['kind']} {r['name']})"
        key = (r["kind"], r["name"])
        if key in seen:
            fail(f"{where}: duplicate (kind, name)")
        seen.add(key)
        if r["kind"] not in ("campaign", "archive", "directory"):
            fail(f"{where}: kind {r['kind']!r}")
            continue
        for column in ("tree_commit", "added_in"):
            if not HEX40.match(r[column]):
                fail(f"{where}: {column} {r[column]!r} is not a 40-hex commit")
        if r["code_commit"] and not HEX40.match(r["code_commit"]):
            fail(f"{where}: code_commit {r['code_commit']!r} is not a 40-hex commit")
        if r["status"] not in ("canonical", "superseded", "study"):
            fail(f"{where}: status {r['status']!r}")
        if r["kind"] == "archive":
            if not HEX64.match(r["sha256"]):
                fail(f"{where}: sha256 {r['sha256']!r} is not 64 hex digits")
            if not HEX40.match(r["git_object"]):
                fail(f"{where}: git_object {r['git_object']!r} is not 40 hex digits")
            if not re.match(r"^results/[A-Za-z0-9_.-]+\.tar\.xz$", r["file"]):
                fail(f"{where}: file {r['file']!r} is not results/NAME.tar.xz")
            if not r["bytes"].isdigit() or int(r["bytes"]) <= 0:
                fail(f"{where}: bytes {r['bytes']!r}")
        elif r["kind"] == "directory":
            if not HEX40.match(r["git_object"]):
                fail(f"{where}: git_object {r['git_object']!r} is not a 40-hex git tree")
        else:  # campaign
            for column in ("config", "command", "source", "task"):
                if not r[column]:
                    fail(f"{where}: no {column}")
            relative = r["file"][len("results/"):] if r["file"].startswith("results/") else None
            if relative not in SUMMARY_COLUMNS:
                fail(f"{where}: file {r['file']!r} is not a documented summary")
                continue
            path = os.path.join(results, relative)
            if not os.path.isfile(path):
                fail(f"{where}: {r['file']} is missing")
                continue
            if str(os.path.getsize(path)) != r["bytes"]:
                fail(f"{where}: {r['file']} has {os.path.getsize(path)} bytes, the manifest "
                     f"says {r['bytes']}")
            digest = sha256_of(path)
            if digest != r["sha256"]:
                fail(f"{where}: {r['file']} has sha256 {digest}, the manifest says {r['sha256']}")
    if not any(r["kind"] == "archive" for r in rows):
        fail("manifest.csv lists no archive")


def number_ok(text):
    try:
        value = float(text)
    except ValueError:
        return False
    return not math.isnan(value)


def check_summary(results, relative, manifest_rows):
    path = os.path.join(results, relative)
    columns, rows = read_csv(path)
    if columns != SUMMARY_COLUMNS[relative]:
        fail(f"{relative}: columns {columns}, documented {SUMMARY_COLUMNS[relative]}")
        return
    if os.path.getsize(path) > MAX_SUMMARY_BYTES:
        fail(f"{relative}: {os.path.getsize(path)} bytes, more than {MAX_SUMMARY_BYTES}")
    if not rows:
        fail(f"{relative}: no rows")
    listed = {r["name"] for r in manifest_rows
              if r["kind"] == "campaign" and r["file"] == "results/" + relative}
    present = {r["campaign"] for r in rows}
    for c in sorted(present - listed):
        fail(f"{relative}: campaign {c} is not in the manifest with this file")
    for c in sorted(listed - present):
        fail(f"{relative}: the manifest's campaign {c} has no rows here")
    per_episode = "episode" in columns
    keys, episodes = set(), {}
    for i, r in enumerate(rows, start=2):
        where = f"{relative} line {i}"
        for column in columns:
            value = r[column]
            if value == "" and column in REQUIRED:
                fail(f"{where}: empty {column}")
            elif value != "" and column in NUMBERS and not number_ok(value):
                fail(f"{where}: {column} {value!r} is not a number")
        if per_episode:
            key = (r["campaign"], r["run"], r["episode"])
            if r["episode"].isdigit():
                episodes.setdefault(key[:2], []).append(int(r["episode"]))
            else:
                fail(f"{where}: episode {r['episode']!r}")
        else:
            key = (r["campaign"], r["search"])
            theta = r["best_theta"].split()
            if len(theta) != 36 or not all(number_ok(t) for t in theta):
                fail(f"{where}: best_theta is not 36 numbers")
        if key in keys:
            fail(f"{where}: duplicate {key}")
        keys.add(key)
    for (campaign, run), ks in episodes.items():
        if sorted(ks) != list(range(1, len(ks) + 1)):
            fail(f"{relative}: run {campaign}/{run}: episodes {sorted(ks)} are not 1..{len(ks)}")


def check_files(results, rows):
    archives = {}  # a path may have several versions in history
    for r in rows:
        if r["kind"] == "archive":
            archives.setdefault(r["file"], []).append(r)
    for folder, _, files in os.walk(results):
        for name in files:
            path = os.path.join(folder, name)
            relative = "results/" + os.path.relpath(path, results).replace(os.sep, "/")
            size = os.path.getsize(path)
            if name.endswith(".tar.xz"):
                versions = archives.get(relative)
                if versions is None:
                    fail(f"{relative}: an archive the manifest does not list")
                elif sha256_of(path) not in {r["sha256"] for r in versions
                                             if r["bytes"] == str(size)}:
                    fail(f"{relative}: not the archive of the manifest (size or sha256)")
            elif size > MAX_FILE_BYTES:
                fail(f"{relative}: {size} bytes, more than {MAX_FILE_BYTES}")


def check_git(results, rows):
    root = os.path.dirname(os.path.abspath(results))

    def rev_parse(spec):
        p = subprocess.run(["git", "-C", root, "rev-parse", "--verify", "-q", spec],
                           capture_output=True, text=True)
        return p.stdout.strip() if p.returncode == 0 else None

    try:
        objects = [r for r in rows if r["kind"] in ("archive", "directory")]
        commits = {r["tree_commit"] for r in objects}
        if not objects or any(rev_parse(c + "^{commit}") is None for c in commits):
            print("check_manifest.py: git objects not checked (no git clone with the commits)")
            return
    except OSError:
        print("check_manifest.py: git objects not checked (no git)")
        return
    for r in objects:
        found = rev_parse(f"{r['tree_commit']}:{r['file']}")
        if found != r["git_object"]:
            fail(f"manifest {r['kind']} {r['name']}: {r['tree_commit'][:12]}:{r['file']} is "
                 f"{found}, the manifest says {r['git_object']}")
    for r in rows:
        for spec in r["original_config"].split():
            if ORIGINAL_CONFIG.match(spec) and rev_parse(spec) is None:
                fail(f"manifest {r['kind']} {r['name']}: original_config {spec} is not in "
                     "this clone's history")


def main():
    parser = argparse.ArgumentParser(description=__doc__,
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("results", metavar="RESULTS_DIR", nargs="?",
                        default=os.path.dirname(os.path.abspath(__file__)),
                        help="the results folder (default: the one of this script)")
    results = parser.parse_args().results
    columns, rows = read_csv(os.path.join(results, "manifest.csv"))
    if columns != MANIFEST_COLUMNS:
        print(f"check_manifest.py: manifest.csv columns {columns}, documented {MANIFEST_COLUMNS}")
        sys.exit(1)
    check_manifest(results, rows)
    check_configs(results, rows)
    for relative in SUMMARY_COLUMNS:
        if os.path.isfile(os.path.join(results, relative)):
            check_summary(results, relative, rows)
        else:
            fail(f"{relative}: missing")
    check_files(results, rows)
    check_git(results, rows)
    for message in failures:
        print(f"check_manifest.py: {message}")
    if failures:
        sys.exit(1)
    n = {k: sum(r["kind"] == k for r in rows) for k in ("campaign", "archive", "directory")}
    print(f"check_manifest.py: {len(SUMMARY_COLUMNS)} summaries, {n['campaign']} campaigns, "
          f"{n['archive']} archives and {n['directory']} folder(s) of the manifest: all checks hold")


if __name__ == "__main__":
    main()
