# The mobile tier's gather with the probes' measured change (new: build 55b878b; its history also restarts
# where the cache measured a change at what the probe rays hit) against b9c4d5a (old: only at
# the pixel's own surface), one device call, interleaved, 1920x1080, the mobile tier. Each run
# starts only while under $BUDGET seconds (default 480); the results are packed whatever ran.
. .gpu/setup.sh 2>/dev/null
cp /tmp/bin/gi-bench /tmp/bin/gi-bench-old
xz -dc .gpu/gi-bench-new.xz > /tmp/bin/gi-bench-new && chmod +x /tmp/bin/gi-bench-new
R=/tmp/res; mkdir -p $R/strips-old $R/strips-new; BUDGET=${BUDGET:-480}
ok() { [ $SECONDS -lt $BUDGET ] || { echo "skipped (time): $*"; return 1; }; }
flicker() {
  ok flicker $1 || return
  timeout 100 gi-bench-$1 stability --tier mobile --size 1920x1080 --settle-frames 24 \
    --converged-frames 8 --clock-settle-s 0.5 --json $R/flicker-$1-$2.json > $R/flicker-$1-$2.md 2>&1
  echo "flicker $1 round $2: $(grep -E '^\| mobile' $R/flicker-$1-$2.md | head -3 | tr -s ' ' | tr '\n' ' ')"
}
settle() {
  b=$1; sc=$2; c=$3; n=$(basename $sc .gltf); ok $b $n $c || return
  timeout 150 gi-bench-$b stability --tier mobile --size 1920x1080 --no-flicker --settle-scene $sc \
    --change $c --settle-frames ${SETTLE:-160} --converged-frames 8 --clock-settle-s 0.5 \
    --strip-dir $R/strips-$b --json $R/$n-$c-$b.json > $R/$n-$c-$b.md 2>&1
  echo "$n $c $b: $(grep -E '^\| mobile' $R/$n-$c-$b.md | tr -s ' ' | tr '\n' ' ')"
}
S=.gpu/scenes/Sponza/glTF/Sponza.gltf
{
for b in old new; do settle $b atrium turn; done
for b in old new; do settle $b atrium off; done
for b in old new; do flicker $b 1; done
for b in old new; do settle $b $S turn; done
for b in old new; do settle $b $S off; done
for b in old new; do SETTLE=64 settle $b cornell-box emissive-off; done
for b in old new; do flicker $b 2; done
} 2>&1 | tee $R/summary.txt
cp benchmarks/results/h100-2026-12-07-probe-change/run.sh $R/
cd $R && tar cJf $OUT/probe-change.tar.xz .
