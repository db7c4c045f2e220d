#!/bin/bash
# $1 seed, $2 traj(0/1)
cd "$(git rev-parse --show-toplevel)"
if [ "$2" = 1 ]; then export SCR_TRAJ=1; fi
SCR_SEED=$1 SCR_NOISE=range,angle,gnss,att,pick SCR_QUIET=1 SCR_V=2 SCR_FAR=1 build/tests/mountcal_tests --gtest_filter=Scratch.FarPlanes 2>&1 | grep -E "sigma\)|verdict" | awk -v s=$1 '/verdict/{v=$NF} /sigma\)/{gsub(/\(/,""); r=r" "$6} END{print s, v, r}'
