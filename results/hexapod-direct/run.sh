#!/bin/bash
# Direct-optimization ceiling of the hexapod: 1000 real episodes, intact and rear-right leg removed.
D=build/drops
C=configs/hexapod-gp_mi.yaml
$D direct $C --evaluations 1000 --threads 1 --output /work/ceiling --name intact -q > intact.out 2>&1 &
$D direct $C hexapod.damage.removed_leg=leg5 --evaluations 1000 --threads 1 --output /work/ceiling --name leg5 -q > leg5.out 2>&1 &
wait
