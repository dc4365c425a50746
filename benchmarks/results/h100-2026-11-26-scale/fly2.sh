# The brick cache flying through Sponza x1/x4/x16 (build after the inside-voxel clipping
# shortcut), and Sponza's quality in the real-time tiers, build before against build after.
. .gpu/setup.sh 2>/dev/null
R=/tmp/res; mkdir -p $R; S=.gpu/scenes/Sponza
for b in gi gi-bench; do xz -dc .gpu/$b-old.xz > /tmp/bin/$b-old; chmod +x /tmp/bin/$b-old; done
for n in 1 4 16; do python3 benchmarks/scale/tile_gltf.py $S/Sponza.gltf --copies $n --step 60 --fly 15 --out $S/Sponza-x$n.gltf; done
for n in 1 4 16; do
  timeout 150 gi-bench cache-update --scene $S/Sponza-x$n.gltf --frames 240 --screen-inject --json $R/fly-new2-x$n.json > $R/fly-new2-x$n.md 2>&1
  grep "worst frame" $R/fly-new2-x$n.md
done 2>&1 | tee $R/fly2-summary.txt
for b in old new; do
  bin=gi-bench; [ $b = old ] && bin=gi-bench-old
  timeout 150 $bin --scenes $S/Sponza.gltf --tiers pc,mobile --size 1920x1080 --repeats 1 --frames 16 --reference-engine gpu --out $R/quality-$b > $R/quality-$b.log 2>&1
  grep -E "^\| .*(pc|mobile)" $R/quality-$b/results.md | head -4
done 2>&1 | tee $R/quality-summary.txt
cd /tmp/res && find . -name "*.png" -delete; tar cJf $OUT/fly2.tar.xz .
