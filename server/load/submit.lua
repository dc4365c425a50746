-- wrk script: POST /v1/jobs with a tiny CPU job (each accepted job is also rendered and stored,
-- so this measures submission with the service doing its work, not an idle queue).
wrk.method = "POST"
wrk.headers["Content-Type"] = "application/json"
wrk.body = '{"scene": "cornell-box", "tier": "reference", "width": 8, "height": 6, "spp": 1}'

local statuses = {}
response = function(status, headers, body)
  statuses[status] = (statuses[status] or 0) + 1
end

done = function(summary, latency, requests)
  for status, count in pairs(statuses) do
    io.write(string.format("status %d: %d\n", status, count))
  end
end
