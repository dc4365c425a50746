# What the light-power run left out, measured later the same day with build 67cd817 (its mobile
# tier is b48ce17's; only the cache's CPU update changed since): Sponza's sun turned 30 degrees,
# and the flicker cases (still camera, animated objects, camera path), 1920x1080, the mobile
# tier. Runs start only while under $BUDGET seconds of the call (default 240).
. .gpu/setup.sh 2>/dev/null
R=/tmp/res-light; mkdir -p $R/strips; BUDGET=${BUDGET:-240}
ok() { [ $SECONDS -lt $BUDGET ] || { echo "skipped (time): $*"; return 1; }; }
S=.gpu/scenes/Sponza/glTF/Sponza.gltf
{
  ok sponza turn && timeout 150 gi-bench stability --tier mobile --size 1920x1080 --no-flicker \
    --settle-scene $S --change turn --settle-frames 160 --converged-frames 8 --clock-settle-s 0.5 \
    --strip-dir $R/strips --json $R/Sponza-turn.json > $R/Sponza-turn.md 2>&1
  echo "Sponza turn: $(grep -E '^\| mobile' $R/Sponza-turn.md | tr -s ' ' | tr '\n' ' ')"
  ok flicker && timeout 100 gi-bench stability --tier mobile --size 1920x1080 --settle-frames 24 \
    --converged-frames 8 --clock-settle-s 0.5 --json $R/flicker.json > $R/flicker.md 2>&1
  echo "flicker: $(grep -E '^\| mobile' $R/flicker.md | head -3 | tr -s ' ' | tr '\n' ' ')"
} 2>&1 | tee $R/summary.txt
cp benchmarks/results/h100-2026-12-07-light-power/sponza.sh $R/
cd $R && tar cJf $OUT/light-sponza.tar.xz .
