# Where `pc/trace`'s time goes on Sponza: the PC tier's passes with parts of the GI rays' work
# left out through GI_SHADER_DIR (diagnostic shaders, not a renderer): `noalpha` (no alpha
# test in any traversal), `noshadow` (no shadow ray at the GI rays' hits), `nocache` (no cache
# lookup at the hits), `noshade` (hits not shaded at all); two rounds alternating.
. .gpu/setup.sh 2>/dev/null
R=/tmp/res; mkdir -p $R; S=.gpu/scenes
for r in 1 2; do
  for v in full noalpha noshadow nocache noshade; do
    E=""; [ $v != full ] && E="GI_SHADER_DIR=.gpu/d/$v"
    env $E timeout 100 gi-bench pc --scenes $S/Sponza/glTF/Sponza.gltf --frames 64 --settle-s 1 > $R/pc-$v-$r.md 2>&1
    echo "$v $r: $(awk '/\*\*GI/{printf "GI %s; ", $(NF-1)} /gbuffer\/primary/{printf "primary %s; ", $(NF-1)} /pc\/trace \|/{printf "trace %s; ", $(NF-1)} /pc\/shadow/{printf "shadow %s; ", $(NF-1)} /pc\/shade \|/{printf "shade %s; ", $(NF-1)}' $R/pc-$v-$r.md)"
  done
done 2>&1 | tee $R/parts.txt
cd $R && tar cJf $OUT/parts.tar.xz .
