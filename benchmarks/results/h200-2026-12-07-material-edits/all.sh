# One device call: the runs of sun.sh, emitters.sh and trail.sh that fit in about 9 minutes,
# most wanted first; each run starts only while under $BUDGET seconds (default 500), and the
# results are packed whatever ran.
. benchmarks/results/h200-2026-12-07-material-edits/common.sh
BUDGET=${BUDGET:-500}
S=.gpu/scenes/Sponza/glTF/Sponza.gltf; T=.gpu/scenes/ToyCar/glTF/ToyCar.gltf
go() { [ $SECONDS -lt $BUDGET ] && run "$@" || echo "skipped (time): $*"; }
{
# 160 frames after the light change: the build before does not converge within 64 (its probe
# volume keeps the old light for hundreds of frames), and its figures are then against a wrong
# converged state.
for b in old new; do
  s=""; [ $b = new ] && s="--strip-dir $R/strips"; SETTLE=160 go $b mobile atrium off $s
done
for t in mobile pc; do go new $t cornell-box emissive-off --strip-dir $R/strips; done
for b in old new; do go $b mobile atrium move --move-node Basin; done
for b in old new; do
  [ $SECONDS -lt $BUDGET ] || { echo "skipped (time): flicker $b"; continue; }
  bin=gi-bench; [ $b = old ] && bin=gi-bench-old
  timeout 100 $bin stability --tier mobile --size 1920x1080 --settle-frames 24 --converged-frames 8 \
    --clock-settle-s 0.5 --json $R/flicker-mobile-$b.json > $R/flicker-mobile-$b.md 2>&1
  echo "flicker mobile $b: $(grep -E '^\| mobile' $R/flicker-mobile-$b.md | head -3 | tr -s ' ' | tr '\n' ' ')"
done
for t in mobile pc; do go new $t $T emissive-off --strip-dir $R/strips; done
for b in old new; do go $b pc atrium move --move-node Basin; done
for b in old new; do SETTLE=160 go $b mobile $S off; done
for b in old new; do SETTLE=160 go $b mobile atrium turn; done
go new mobile glossy emissive-off; go new pc glossy emissive-off
} 2>&1 | tee $R/summary-all.txt
cd $R && tar cJf $OUT/all.tar.xz .
