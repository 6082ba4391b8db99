#!/bin/bash
# The drops direct searches of this directory, run from the repository root (2026-11-21, one
# thread each, beside the hexapod campaign). The two "-interrupted" ones were stopped with Ctrl-C
# and renamed afterwards (they ran as intact and intact-tripod). Each takes 20-30 CPU-minutes.
set -e
O=results/hexapod-direct
C=configs/hexapod-gp_mi.yaml
build/drops direct $C --evaluations 1000 --threads 1 --output $O --name intact-centre-interrupted
build/drops direct $C --start $O/tripod.csv --evaluations 600 --threads 1 --output $O \
  --name intact-tripod-sigma05-interrupted
build/drops direct $C --start $O/tripod.csv optimizer.sigma0=0.1 --evaluations 600 --threads 1 \
  --output $O --name intact-tripod
build/drops direct $C hexapod.damage.removed_leg=leg5 --evaluations 1000 --threads 1 --output $O \
  --name leg5
# leg5-best.csv: the theta of leg5/summary.json, one value per line
build/drops direct $C hexapod.damage.removed_leg=leg5 --start $O/leg5-best.csv optimizer.sigma0=0.2 \
  --evaluations 1000 --threads 1 --output $O --name leg5-stage2
