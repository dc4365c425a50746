# The tiled a-trous and the propagation list (new) against the build before them (base): the
# PC and mobile tiers' pass times on the real scenes and cornell-box, two alternating rounds;
# then the new build's quality on Sponza against the GPU reference.
. .gpu/setup.sh 2>/dev/null
for b in gi gi-bench; do xz -dc .gpu/$b-base.xz > /tmp/bin/$b-base; chmod +x /tmp/bin/$b-base; done
R=/tmp/res; mkdir -p $R; S=.gpu/scenes
SC=$S/Sponza/Sponza.gltf,$S/GasStation/GasStation.gltf,$S/ToyCar/ToyCar.gltf,cornell-box
for r in 1 2; do for v in base new; do b=gi-bench; [ $v = base ] && b=gi-bench-base; for t in pc mobile; do
  timeout 150 $b $t --scenes $SC --frames 64 --settle-s 1 --json $R/$t-$v-$r.json > $R/$t-$v-$r.md 2>&1
  echo "$t $v round $r: $(grep -E '^\*\*GI|^\| \*\*GI|cache/propagate \||denoise_atrous' $R/$t-$v-$r.md | tr -s ' ' | tr '\n' ' ')"
done; done; done 2>&1 | tee $R/tiers.txt
timeout 200 gi-bench --scenes $S/Sponza/Sponza.gltf --tiers pc,mobile --size 1920x1080 --repeats 1 --frames 16 --reference-engine gpu --out /tmp/q > $R/quality.log 2>&1
grep -E '^\| Sponza|^\| +\| (pc|mobile)' /tmp/q/results.md | head; cp /tmp/q/results.md $R/quality.md
cd $R && tar cJf $OUT/opt.tar.xz .
