# pc/shadow without a visibility ray for a pixel whose spatial reuse kept its own sample (new)
# against the build before (base): `gi-bench pc`, two alternating rounds; then `gi compare --tiers
# pc` with both builds against the same 256-spp GPU reference.
. .gpu/setup.sh 2>/dev/null
for b in gi gi-bench; do xz -dc .gpu/$b-base.xz > /tmp/bin/$b-base; chmod +x /tmp/bin/$b-base; done
R=/tmp/res; mkdir -p $R; S=.gpu/scenes
SC=$S/Sponza/Sponza.gltf,$S/ToyCar/ToyCar.gltf,$S/GasStation/GasStation.gltf,cornell-box,atrium,glossy,thin-wall
for r in 1 2; do for v in base new; do b=gi-bench; [ $v = base ] && b=gi-bench-base
  timeout 200 $b pc --scenes $SC --frames 64 --settle-s 1 > $R/pc-$v-$r.md 2>&1
  echo "$v round $r: $(grep -E '^\| \*\*GI|pc/shadow \|' $R/pc-$v-$r.md | tr -s ' ' | tr '\n' ' ')"
done; done 2>&1 | tee $R/cost.txt
for sc in $S/Sponza/Sponza.gltf $S/ToyCar/ToyCar.gltf cornell-box atrium thin-wall; do
  n=$(basename $sc .gltf)
  for v in base new; do b=gi; [ $v = base ] && b=gi-base
    timeout 120 $b compare $sc --tiers pc --width 1920 --height 1080 --reference-spp 256 \
      --reference-engine gpu --cache-dir /tmp/refs --out-dir /tmp/img-$n-$v > $R/q-$n-$v.txt 2>&1
    echo "$n $v: $(grep -E '^pc ' $R/q-$n-$v.txt | tr -s ' ')"
  done
done 2>&1 | tee $R/quality.txt
cd $R && tar cJf $OUT/own.tar.xz .
