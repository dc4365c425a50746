-- wrk script: POST /v1/jobs with a tiny CPU job. Each accepted job is also rendered and stored
-- while the load runs, so this measures submission with the service doing its work. wrk reports
-- any answer other than 2xx/3xx ("Non-2xx or 3xx responses").
wrk.method = "POST"
wrk.headers["Content-Type"] = "application/json"
wrk.body = '{"scene": "cornell-box", "tier": "reference", "width": 8, "height": 6, "spp": 1}'
