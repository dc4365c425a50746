# One call: the PC tier per pass, the build before the memory work (old, fdfe4f8), the memory
# work (mem, 8ac8487) and it with the deferred push in the BVH traversal (defer), two rounds
# alternating on Sponza, GasStation and cornell-box; then, with `defer`, mobile and PC on the
# two real scenes and the six bundled ones, 1080p. Everything into one archive.
. .gpu/setup.sh 2>/dev/null
for b in old defer; do xz -dc .gpu/gi-bench-$b.xz > /tmp/bin/gi-bench-$b && chmod +x /tmp/bin/gi-bench-$b; done

R=/tmp/res; mkdir -p $R; S=.gpu/scenes
SP=$S/Sponza/glTF/Sponza.gltf; GS=$S/GasStation/glTF/GasStation.gltf
ALL=$SP,$GS,cornell-box,atrium,glossy,thin-wall,dynamic,open-world
for r in 1 2; do for v in old defer; do
  timeout 80 gi-bench-$v pc --scenes $SP,$GS,cornell-box --frames 64 --settle-s 1 --json $R/pc-$v-$r.json > $R/pc-$v-$r.md 2>&1
  echo "$v $r: $(awk '/^[A-Za-z-]+ 1920x1080/{s=$1} /\*\*GI/{printf "%s %s; ", s, $(NF-1)}' $R/pc-$v-$r.md)"
done; done 2>&1 | tee $R/pc.txt
for r in 1 2; do
  timeout 150 gi-bench-defer mobile --scenes $ALL --frames 64 --settle-s 1 --json $R/mobile-$r.json > $R/mobile-$r.md 2>&1
  echo "mobile $r: $(awk '/^[A-Za-z-]+ 1920x1080/{s=$1} /\*\*GI/{printf "%s %s; ", s, $(NF-1)}' $R/mobile-$r.md)"
done 2>&1 | tee $R/mobile.txt
timeout 150 gi-bench-defer pc --scenes $ALL --frames 64 --settle-s 1 --json $R/pc-all.json > $R/pc-all.md 2>&1
echo "pc all: $(awk '/^[A-Za-z-]+ 1920x1080/{s=$1} /\*\*GI/{printf "%s %s; ", s, $(NF-1)}' $R/pc-all.md)" | tee $R/pcall.txt
tar czf $OUT/res.tgz -C $R .
