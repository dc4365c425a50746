#!/usr/bin/env bash
# The benchmark suite before and after the techniques' common shape (gi_gpu::Technique) and
# the shaders split one file per pass, on one H100: old = build of ec6ec9c, new = the build
# named in README.md (gi-bench and gi, release, stripped). The references are rendered on the
# GPU once and cached; each suite runs 3 repeats of every bundled scene x direct, path, mobile,
# pc at 1280x720. "old2" runs the old build again with the new run as its baseline (the reverse
# check, and the old build's own spread of timings). Then the time to open the PC and mobile
# tiers (shader composition and pipeline creation), old and new alternating, three rounds.
set -euo pipefail
source .gpu/setup.sh
for b in old new; do
  xz -dc .gpu/gi-bench-$b.xz > /tmp/bin/gi-bench-$b && chmod +x /tmp/bin/gi-bench-$b
  xz -dc .gpu/gi-$b.xz > /tmp/bin/gi-$b && chmod +x /tmp/bin/gi-$b
done
S=/tmp/suite; rm -rf $S; mkdir -p $S
A="--tiers direct,path,mobile,pc --repeats 3 --reference-engine gpu --cache-dir /tmp/refcache"
gi-bench-old $A --out $S/old > $S/old.log 2>&1
gi-bench-new $A --out $S/new --baseline $S/old/results.json > $S/new.log 2>&1
gi-bench-old $A --out $S/old2 --baseline $S/new/results.json > $S/old2.log 2>&1
for r in old new old2; do mkdir -p $OUT/$r; cp $S/$r/results.json $S/$r/results.md $OUT/$r/ 2>/dev/null || true; done
for round in 1 2 3; do
  for b in old new; do
    for t in pc mobile; do
      line=$(gi-$b render cornell-box --tier $t --width 1280 --height 720 --frames 1 --out /tmp/o.png 2>&1 | grep -o "tier [0-9.]* s" || true)
      echo "round $round $b $t $line"
    done
  done
done | tee $OUT/open.txt
