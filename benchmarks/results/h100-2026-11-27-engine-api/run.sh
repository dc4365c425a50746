#!/usr/bin/env bash
# The benchmark suite before and after the engine-facing API and the gi-tiers restructuring,
# on one H100: old = build of 641f6c3, new = build of 5495479 (gi-bench, release, stripped).
# The references are rendered on the GPU once and cached; each suite runs 3 repeats of every
# bundled scene x direct, path, mobile, pc at 1280x720. "old2" runs the old build again with the
# new run as its baseline (the reverse check, and the old build's own spread of timings).
set -euo pipefail
source .gpu/setup.sh
for b in old new; do xz -dc .gpu/gi-bench-$b.xz > /tmp/bin/gi-bench-$b && chmod +x /tmp/bin/gi-bench-$b; done
S=/tmp/suite; rm -rf $S; mkdir -p $S
A="--tiers direct,path,mobile,pc --repeats 3 --reference-engine gpu --cache-dir /tmp/refcache"
gi-bench-old $A --out $S/old > $S/old.log 2>&1
gi-bench-new $A --out $S/new --baseline $S/old/results.json > $S/new.log 2>&1
gi-bench-old $A --out $S/old2 --baseline $S/new/results.json > $S/old2.log 2>&1
for r in old new old2; do mkdir -p $OUT/$r; cp $S/$r/results.json $S/$r/results.md $OUT/$r/ 2>/dev/null || true; done
