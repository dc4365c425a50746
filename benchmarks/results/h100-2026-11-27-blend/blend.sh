# Blended surfaces folded into one layer (new: the build of 021cc12) against the build of
# 918067c with its bench fix (old): the PC and mobile tiers' pass times on
# GasStation (two BLEND glass materials) and Sponza, two alternating rounds; then both builds'
# quality on GasStation against the GPU reference.
. .gpu/setup.sh
xz -dc .gpu/gi-bench-old.xz > /tmp/bin/gi-bench-old; chmod +x /tmp/bin/gi-bench-old
cp /tmp/bin/gi-bench /tmp/bin/gi-bench-new
cp benchmarks/lighting/Sponza.lighting.json .gpu/scenes/Sponza/
R=/tmp/res; mkdir -p $R; S=.gpu/scenes; nvidia-smi -L > $R/gpu.txt
SC=$S/GasStation/GasStation.gltf,$S/Sponza/Sponza.gltf
for r in 1 2; do for v in old new; do for t in pc mobile; do
  timeout 150 gi-bench-$v $t --scenes $SC --frames 64 --settle-s 1 > $R/$t-$v-$r.md 2>&1
  echo "$t $v round $r: $(grep -E '^\*\*GI|^\| \*\*GI' $R/$t-$v-$r.md | tr -s ' ' | tr '\n' ' ')"
done; done; done 2>&1 | tee $R/tiers.txt
for v in old new; do
  timeout 250 gi-bench-$v --scenes $S/GasStation/GasStation.gltf --tiers pc,mobile --size 1920x1080 --repeats 1 --frames 16 --reference-engine gpu --out /tmp/q-$v > $R/quality-$v.log 2>&1
  cp /tmp/q-$v/results.md $R/quality-$v.md; grep -E '^\| GasStation|^\| +\| (pc|mobile)' $R/quality-$v.md | head -4
done
cp benchmarks/results/h100-2026-11-27-blend/blend.sh $R/; cd $R && tar cJf $OUT/blend.tar.xz .
