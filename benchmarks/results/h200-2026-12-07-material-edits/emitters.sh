# An emissive material switched off (`gi-bench stability --change emissive-off`, this build;
# the build before could not edit materials): cornell-box's ceiling panel (its only light),
# glossy's softbox, ToyCar's emissive material (under its lighting file's sun), both GPU tiers,
# with contact strips; then the PC tier's still-camera flicker.
. benchmarks/results/h200-2026-12-07-material-edits/common.sh
T=.gpu/scenes/ToyCar/glTF/ToyCar.gltf
{
for sc in cornell-box glossy $T; do for t in pc mobile; do
  run new $t $sc emissive-off --strip-dir $R/strips
done; done
timeout 150 gi-bench stability --tier pc --size 1920x1080 --settle-frames 64 --converged-frames 8 \
  --clock-settle-s 0.5 --json $R/flicker-pc-new.json > $R/flicker-pc-new.md 2>&1
echo "flicker pc new: $(grep -E '^\| pc' $R/flicker-pc-new.md | head -3 | tr -s ' ' | tr '\n' ' ')"
} 2>&1 | tee $R/summary-emitters.txt
cd $R && tar cJf $OUT/emitters.tar.xz .
