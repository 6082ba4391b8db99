#!/bin/bash
# Ceiling with the rear-right leg removed, stage 2: from the best gait of 1,000 episodes (leg5/), sigma0 0.2.
build/drops direct configs/hexapod-gp_mi.yaml hexapod.damage.removed_leg=leg5 --start results/hexapod-direct/leg5-best.csv optimizer.sigma0=0.2 --evaluations 1000 --threads 1 --output /work/ceiling --name leg5-stage2 -q > leg5-stage2.out 2>&1
