#!/usr/bin/env python3
"""What a job costs the embedded gi-server with job processes and with --in-process: 20 jobs
of each kind submitted at once, timed until the last is done (median of three runs), printed
per job as Markdown table rows.

    python3 server/load/job_cost.py target/release/gi-server
"""
import json, subprocess, sys, tempfile, time, urllib.request, statistics

def run(binary, extra, jobs, body):
    with tempfile.TemporaryDirectory() as d:
        p = subprocess.Popen([binary, "--bind", "127.0.0.1:0", "--data-dir", d + "/data",
                              "--cache-dir", d + "/cache"] + extra,
                             stdout=subprocess.PIPE, stderr=subprocess.DEVNULL, text=True)
        addr = p.stdout.readline().split("http://")[1].strip()
        def req(method, path, data=None):
            r = urllib.request.Request(f"http://{addr}{path}", method=method,
                                       data=None if data is None else json.dumps(data).encode(),
                                       headers={"content-type": "application/json"})
            with urllib.request.urlopen(r) as resp:
                return json.load(resp)
        start = time.monotonic()
        ids = [req("POST", "/v1/jobs", body)["id"] for _ in range(jobs)]
        seconds = []
        for i in ids:
            while True:
                job = req("GET", f"/v1/jobs/{i}")
                if job["state"] in ("done", "failed", "cancelled"):
                    assert job["state"] == "done", job
                    break
                time.sleep(0.02)
        total = time.monotonic() - start
        p.terminate(); p.wait()
        return total

binary = sys.argv[1]
for name, body in [("reference 16x12 1 spp", {"scene": "cornell-box", "tier": "reference", "width": 16, "height": 12, "spp": 1, "compare": False}),
                   ("path 16x12 1 spp", {"scene": "cornell-box", "tier": "path", "width": 16, "height": 12, "spp": 1, "compare": False}),
                   ("pc 640x360", {"scene": "cornell-box", "tier": "pc", "width": 640, "height": 360, "compare": False}),
                   ("reference 16x12 1 spp, compared at 16 spp", {"scene": "cornell-box", "tier": "reference", "width": 16, "height": 12, "spp": 1, "compare": True, "reference_spp": 16})]:
    for mode, extra in [("job processes", []), ("--in-process", ["--in-process"])]:
        runs = [run(binary, extra, 20, body) for _ in range(3)]
        print(f"| {name} | {mode} | {statistics.median(runs) / 20 * 1000:.0f} ms |", flush=True)
