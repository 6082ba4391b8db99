#!/bin/bash
# Ceiling on the intact "real" robot, from the hand-made tripod gait (0.24 m/s).
build/drops direct configs/hexapod-gp_mi.yaml --start results/hexapod-direct/tripod.csv optimizer.sigma0=0.1 --evaluations 600 --threads 1 --output /work/ceiling --name intact-tripod -q > intact-tripod.out 2>&1
