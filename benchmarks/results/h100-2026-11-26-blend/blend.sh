# Alpha-BLEND surfaces in pc and mobile, same call: the build before the blend layer (211ee0d, a
# fixed hashed dither) against the build with it, on GasStation (blended windows) and on
# Sponza (no blended materials: what the change costs a scene without them).
. .gpu/setup.sh
mkdir -p /tmp/old
for b in gi gi-bench; do xz -dc .gpu/$b-prev.xz > /tmp/old/$b; chmod +x /tmp/old/$b; done
S=.gpu/scenes/GasStation/GasStation.gltf,.gpu/scenes/Sponza/Sponza.gltf
for b in old new; do
  bin=gi-bench; [ $b = old ] && bin=/tmp/old/gi-bench
  $bin --scenes $S --tiers pc,mobile --size 1920x1080 --repeats 2 --frames 16 --reference-engine gpu --out /tmp/gs-$b > $OUT/suite-$b.log 2>&1
  cp /tmp/gs-$b/results.md $OUT/results-$b.md
  for f in /tmp/gs-$b/contact_*GasStation*.png; do cp $f $OUT/contact-$b.png; done
done
grep "gltf | \(pc\|mobile\)" $OUT/results-*.md
