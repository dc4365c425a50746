# Normal maps at the PC tier's GI hits: the same binary with its embedded shaders (hits shaded
# with the geometric normal) and with the working tree's shaders (GI_SHADER_DIR: the shading
# normal with the normal map): pass times, then quality against the GPU reference.
. .gpu/setup.sh 2>/dev/null
R=/tmp/res; mkdir -p $R; S=.gpu/scenes
SC=$S/Sponza/Sponza.gltf,$S/ToyCar/ToyCar.gltf,$S/SheenChair/SheenChair.gltf
run() { if [ $1 = new ]; then GI_SHADER_DIR=$PWD/shaders "${@:2}"; else "${@:2}"; fi; }
for r in 1 2; do for v in old new; do
  run $v timeout 150 gi-bench pc --scenes $SC --frames 64 --settle-s 1 --json $R/pc-$v-$r.json > $R/pc-$v-$r.md 2>&1
  echo "pc $v round $r: $(grep -E '^\| \*\*GI|pc/trace \|' $R/pc-$v-$r.md | tr -s ' ' | tr '\n' ' ')"
done; done 2>&1 | tee $R/tiers.txt
for v in old new; do
  run $v timeout 250 gi-bench --scenes $SC --tiers pc --size 1920x1080 --repeats 2 --frames 16 --reference-engine gpu --out /tmp/q-$v > $R/quality-$v.log 2>&1
  echo "quality $v:"; grep -E '^\| .*\| pc \|' /tmp/q-$v/results.md | head -5; cp /tmp/q-$v/results.md $R/quality-$v.md
done
cd $R && tar cJf $OUT/nm.tar.xz .
