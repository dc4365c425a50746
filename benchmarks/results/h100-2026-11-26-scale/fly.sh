# Brick cache flying through Sponza tiled 1, 4 and 16 times: the build before (old) and after
# (new) the world-space binning grids, scan budget and chunked voxelization; budget variants.
. .gpu/setup.sh 2>/dev/null
R=/tmp/res; mkdir -p $R; S=.gpu/scenes/Sponza
xz -dc .gpu/gi-bench-old.xz > /tmp/bin/gi-bench-old; chmod +x /tmp/bin/gi-bench-old
for n in 1 4 16; do python3 benchmarks/scale/tile_gltf.py $S/Sponza.gltf --copies $n --step 60 --fly 15 --out $S/Sponza-x$n.gltf; done
summary() { python3 - "$@" <<'PY'
import json, sys, statistics as st
for p in sys.argv[1:]:
    try: d = json.load(open(p))
    except Exception as e: print(p, 'missing', e); continue
    f = d['per_frame'][1:]
    g = [x['cache_gpu_ms'] for x in f]; c = [x['cpu_update_ms'] for x in f]
    vox = [x['passes_ms'].get('cache/voxelize') or 0 for x in f]
    full = next((i for i, x in enumerate(d['per_frame']) if x['queued_remaining'] == 0), None)
    print(f"{p.split('/')[-1]}: tris {d['triangles']} fill cpu {d['fill']['cpu_update_ms']:.1f} ms | after: gpu med {st.median(g):.2f} p99 {sorted(g)[int(.99*len(g))]:.2f} max {max(g):.2f} | voxelize max {max(vox):.2f} | cpu med {st.median(c):.2f} p99 {sorted(c)[int(.99*len(c))]:.2f} max {max(c):.2f} | queue empty at frame {full} | bricks {d['bricks']['allocated']} dropped {d['bricks']['dropped_for_pool']}")
PY
}
for n in 1 4 16; do for b in old new; do
  bin=gi-bench; [ $b = old ] && bin=gi-bench-old
  timeout 150 $bin cache-update --scene $S/Sponza-x$n.gltf --frames 240 --screen-inject --json $R/fly-$b-x$n.json > $R/fly-$b-x$n.md 2>&1
  summary $R/fly-$b-x$n.json
done; done 2>&1 | tee $R/fly-summary.txt
for scan in 16384 262144; do
  timeout 100 gi-bench cache-update --scene $S/Sponza-x4.gltf --frames 240 --screen-inject --voxelize-scan $scan --json $R/fly-new-x4-scan$scan.json > $R/fly-new-x4-scan$scan.md 2>&1
  summary $R/fly-new-x4-scan$scan.json
done 2>&1 | tee -a $R/fly-summary.txt
cd /tmp/res && tar cJf $OUT/fly.tar.xz .
