# A moved object's trail, the build before (fcbfaad, `old`) and this one (`new`: a brick
# voxelized again in place starts with the largest measured change), alternated: atrium's basin
# and thin-wall's cabinet slide away by their width plus 10%, both GPU tiers
# (`gi-bench stability --change move`; figures over the pixels the node left).
. benchmarks/results/h200-2026-12-07-material-edits/common.sh
{
for m in "atrium Basin" "thin-wall Cabinet"; do set -- $m; for t in pc mobile; do for b in old new; do
  run $b $t $1 move --move-node $2
done; done; done
} 2>&1 | tee $R/summary-trail.txt
cd $R && tar cJf $OUT/trail.tar.xz .
