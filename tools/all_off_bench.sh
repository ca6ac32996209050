#!/bin/bash
# All-off cost: the volume renderers with clipping, labels and emission off, against a build from before
# they landed (OLD, NEW: two release builds of the volume demo), same scene, runs alternated.
# Writes CSV to stdout: results/volume_bench/all_off.csv.
OLD=${OLD:?release volume binary of the older commit}; NEW=${NEW:-target/release/volume}
echo "round,renderer,build,ms"
for round in 1 2 3; do
 for r in mip iso eam lao dos mcs mcm; do
  f=6; [ $r = lao ] && f=3
  for b in old new; do
   B=$OLD; [ $b = new ] && B=$NEW
   ms=$($B --renderer $r --size 256x256 --frames $f --out /tmp/alloff_$b.png 2>&1 | grep -o '[0-9.]* ms/frame GPU' | cut -d' ' -f1)
   echo "$round,$r,$b,$ms"
  done
 done
done
