# One device call: the runs of sun.sh, emitters.sh and trail.sh that fit in about 9 minutes,
# most wanted first; each run starts only while under $BUDGET seconds (default 500), and the
# results are packed whatever ran.
. benchmarks/results/h100-2026-12-07-material-edits/common.sh
BUDGET=${BUDGET:-500}
S=.gpu/scenes/Sponza/glTF/Sponza.gltf; T=.gpu/scenes/ToyCar/glTF/ToyCar.gltf
go() { [ $SECONDS -lt $BUDGET ] && run "$@" || echo "skipped (time): $*"; }
{
for c in off turn; do for b in old new; do
  s=""; [ $c = off ] && [ $b = new ] && s="--strip-dir $R/strips"; go $b mobile atrium $c $s
done; done
for sc in cornell-box $T; do for t in mobile pc; do go new $t $sc emissive-off --strip-dir $R/strips; done; done
for t in mobile pc; do for b in old new; do go $b $t atrium move --move-node Basin; done; done
for b in old new; do
  [ $SECONDS -lt $BUDGET ] || { echo "skipped (time): flicker $b"; continue; }
  bin=gi-bench; [ $b = old ] && bin=gi-bench-old
  timeout 100 $bin stability --tier mobile --size 1920x1080 --settle-frames 24 --converged-frames 8 \
    --clock-settle-s 0.5 --json $R/flicker-mobile-$b.json > $R/flicker-mobile-$b.md 2>&1
  echo "flicker mobile $b: $(grep -E '^\| mobile' $R/flicker-mobile-$b.md | head -3 | tr -s ' ' | tr '\n' ' ')"
done
for b in old new; do go $b mobile $S off; done
go new mobile glossy emissive-off; go new pc glossy emissive-off
} 2>&1 | tee $R/summary-all.txt
cd $R && tar cJf $OUT/all.tar.xz .
