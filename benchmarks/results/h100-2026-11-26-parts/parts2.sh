# The brick cache flying through Sponza x1/x4/x16: the build before this change (fdc5fde, one
# workgroup per brick) against the build after (788952b: parts of 128, chunk triangles in
# workgroup memory, linear-time fill selection, binning on all cores); part sizes at x4; and
# Sponza's quality in the real-time tiers with the build after.
. .gpu/setup.sh 2>/dev/null
R=/tmp/res; mkdir -p $R; S=.gpu/scenes/Sponza
xz -dc .gpu/gi-bench-old.xz > /tmp/bin/gi-bench-old; chmod +x /tmp/bin/gi-bench-old
for n in 1 4 16; do python3 benchmarks/scale/tile_gltf.py $S/Sponza.gltf --copies $n --step 60 --fly 15 --out $S/Sponza-x$n.gltf; done
for n in 1 4 16; do for b in old new; do
  bin=gi-bench; [ $b = old ] && bin=gi-bench-old
  timeout 150 $bin cache-update --scene $S/Sponza-x$n.gltf --frames 240 --screen-inject --json $R/fly-$b-x$n.json > $R/fly-$b-x$n.md 2>&1
  echo "x$n $b: $(grep 'worst frame' $R/fly-$b-x$n.md)"
done; done 2>&1 | tee $R/summary.txt
for p in 64 256 512; do
  timeout 150 gi-bench cache-update --scene $S/Sponza-x4.gltf --frames 240 --screen-inject --voxelize-part $p --json $R/fly-p$p-x4.json > $R/fly-p$p-x4.md 2>&1
  echo "x4 part $p: $(grep 'worst frame' $R/fly-p$p-x4.md)"
done 2>&1 | tee -a $R/summary.txt
timeout 200 gi-bench --scenes $S/Sponza.gltf --tiers pc,mobile --size 1920x1080 --repeats 1 --frames 16 --reference-engine gpu --out $R/quality > $R/quality.log 2>&1
grep -E "^\| .*(pc|mobile)" $R/quality/results.md | head -4 | tee -a $R/summary.txt
cd /tmp/res && find . -name "*.png" -delete; find . -name "*.exr" -delete; tar cJf $OUT/parts2.tar.xz .
