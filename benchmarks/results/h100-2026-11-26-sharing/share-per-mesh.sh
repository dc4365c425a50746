# Per-mesh sharing only (build 7973553 plus the settled rays benchmark): BVH rays with the GPU clock settled (gi-bench rays --settle-s 1, all GPU kinds back to
# back), sharing off/auto/all on Sponza x1/x4/x16; the PC tier at x4/x16, old and new, two rounds.
. .gpu/setup.sh 2>/dev/null
for b in gi gi-bench; do xz -dc .gpu/$b-old.xz > /tmp/bin/$b-old; chmod +x /tmp/bin/$b-old; done
R=/tmp/res; mkdir -p $R; S=.gpu/scenes/Sponza
for n in 1 4 16; do python3 benchmarks/scale/tile_gltf.py $S/Sponza.gltf --copies $n --step 60 --fly 15 --out $S/Sponza-x$n.gltf >/dev/null; done
for n in 1 4 16; do for m in off auto all; do
  timeout 60 gi-bench rays --scene $S/Sponza-x$n.gltf --mesh-sharing $m --json $R/rays-x$n-$m.json > $R/rays-x$n-$m.md 2>&1
  echo "x$n $m: $(head -1 $R/rays-x$n-$m.md | cut -c1-220)"; grep -E "^\| (primary|shadow|incoherent)" $R/rays-x$n-$m.md
done; done 2>&1 | tee $R/rays.txt
for r in 1 2; do for n in 4 16; do for v in old new; do b=gi-bench; [ $v = old ] && b=gi-bench-old; for t in pc mobile; do
  timeout 80 $b $t --scenes $S/Sponza-x$n.gltf --frames 32 --settle-s 1 --json $R/$t-x$n-$v-$r.json > $R/$t-x$n-$v-$r.md 2>&1
  echo "x$n $t $v round $r: $(grep -E 'GI of the pipelined|gbuffer/primary' $R/$t-x$n-$v-$r.md | tr '\n' ' ')"
done; done; done; done 2>&1 | tee $R/tiers.txt
cd $R && tar cJf $OUT/share2.tar.xz .
