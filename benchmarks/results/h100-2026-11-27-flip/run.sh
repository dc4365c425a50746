# FLIP beside rmse_srgb8 on the H100: the suite (path at 16 spp, mobile, pc) on the six bundled
# scenes and three real ones at 1920x1080 against 256-spp GPU references, one repeat; results.md,
# results.json and the contact sheets (render, reference, error, FLIP map).
. .gpu/setup.sh 2>/dev/null
S=.gpu/scenes
timeout 560 gi-bench --scenes cornell-box,atrium,thin-wall,glossy,open-world,dynamic,$S/Sponza/Sponza.gltf,$S/GasStation/GasStation.gltf,$S/ToyCar/ToyCar.gltf \
  --tiers path,mobile,pc --size 1920x1080 --frames 16 --repeats 1 --reference-spp 256 \
  --reference-engine gpu --out /tmp/suite > /tmp/suite.log 2>&1
echo "rc $?"; tail -5 /tmp/suite.log
grep -E '^\|' /tmp/suite/results.md | head -60
cd /tmp/suite && ls && tar cJf $OUT/suite.tar.xz results.md results.json $(ls *.png 2>/dev/null | grep -i contact | head -12)
