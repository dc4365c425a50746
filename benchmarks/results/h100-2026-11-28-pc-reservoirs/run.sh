# The PC tier's ReSTIR reservoirs kept in 32 bytes instead of 48 (initial, resolved), against
# the build before them (gi-old, gi-bench-old: the screen buffers of h100-2026-11-28-pc-memory).
# Cost and memory: `gi-bench pc` on nine scenes, the two builds alternated twice.
. .gpu/setup.sh 2>/dev/null
for b in gi gi-bench; do xz -dc .gpu/$b-old.xz > /tmp/bin/$b-old && chmod +x /tmp/bin/$b-old; done
R=/tmp/res; mkdir -p $R; S=.gpu/scenes
SC=$S/Sponza/Sponza.gltf,$S/GasStation/GasStation.gltf,$S/ToyCar/ToyCar.gltf,cornell-box,atrium,glossy,thin-wall,open-world,dynamic
for r in 1 2; do
  for v in old new; do
    B=gi-bench; [ $v = old ] && B=gi-bench-old
    timeout 140 $B pc --scenes $SC --frames 64 --settle-s 1 --json $R/pc-$v-$r.json > $R/pc-$v-$r.md 2>&1
    echo "== $v round $r"; grep -E '^\| [A-Za-z-]+ \|' $R/pc-$v-$r.md | tr -s ' '
  done
done 2>&1 | tee $R/cost.txt
cd $R && tar cJf $OUT/cost.tar.xz .
