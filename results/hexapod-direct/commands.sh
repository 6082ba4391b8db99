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

# 2026-11-24 (issue 14, "The ceilings again" in docs/results/hexapod.md): more seeds and larger
# budgets, archived in results/hexapod-ceiling.tar.xz (campaign hexapod-ceiling, its stage2/).
# Each real episode took about 0.6-1.5 s on one core, depending on the load.
H=campaigns/hexapod-ceiling
S=$H/stage2
# without leg 5: 2,000 episodes from the centre, seeds 2 and 3, then 1,000 from each one's best
# (seed 1's protocol above)
build/drops campaign configs/ceiling-hexapod-direct.yaml -j 2
build/drops direct $C hexapod.damage.removed_leg=leg5 --start $H/runs/seed2/episodes/435/policy.csv \
  optimizer.sigma0=0.2 --evaluations 1000 --seed 2 --threads 1 --output $S --name leg5-seed2-stage2
build/drops direct $C hexapod.damage.removed_leg=leg5 --start $H/runs/seed3/episodes/698/policy.csv \
  optimizer.sigma0=0.2 --evaluations 1000 --seed 3 --threads 1 --output $S --name leg5-seed3-stage2
# without leg 5, from the gait GP-MI ran at episode 10 of gp_mi-leg5-seed2 (campaign hexapod-search)
build/drops direct $C hexapod.damage.removed_leg=leg5 \
  --start campaigns/hexapod-search/runs/gp_mi-leg5-seed2/episodes/010/policy.csv \
  optimizer.sigma0=0.1 --evaluations 1000 --seed 1 --threads 1 --output $S --name leg5-from-gp_mi-seed2
# intact: from the tripod gait, seeds 2 and 3, and from the gait of episode 8 of
# gp_prior-seed2 (campaign hexapod-local-search)
for s in 2 3; do
  build/drops direct $C --start $O/tripod.csv optimizer.sigma0=0.1 --evaluations 1000 --seed $s \
    --threads 1 --output $S --name intact-tripod-seed$s
done
build/drops direct $C --start campaigns/hexapod-local-search/runs/gp_prior-seed2/episodes/008/policy.csv \
  optimizer.sigma0=0.1 --evaluations 1000 --seed 1 --threads 1 --output $S \
  --name intact-from-gp_prior-local-seed2
