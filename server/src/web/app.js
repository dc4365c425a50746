// The render service's web page: submit a job, follow it, compare its images with the
// reference, browse past jobs. Talks only to the JSON API; text from the API is always set with
// textContent, never as HTML (scene names come from uploads).
"use strict";

const $ = (id) => document.getElementById(id);
let currentJob = null;
let pollTimer = null;
let oldestShown = null;

// A service started with --api-token answers 401 until the page sends the token: the page asks
// for it once and keeps it for this tab only (sessionStorage), sent as a bearer header.
const TOKEN_KEY = "gi-server.api-token";

function withToken(headers) {
  const token = sessionStorage.getItem(TOKEN_KEY);
  return token ? { ...headers, Authorization: `Bearer ${token}` } : { ...headers };
}

async function api(path, options = {}) {
  const response = await fetch(path, { ...options, headers: withToken(options.headers) });
  if (response.status === 401) $("token-form").hidden = false;
  const body = await response.json().catch(() => null);
  if (!response.ok) {
    const message = body && body.error ? `${body.error.message} (${body.error.code})` : `HTTP ${response.status}`;
    throw new Error(message);
  }
  return body;
}

function option(select, value, text) {
  const element = document.createElement("option");
  element.value = value;
  element.textContent = text;
  select.appendChild(element);
}

async function loadChoices() {
  const [scenes, openapi, health] = await Promise.all([
    api("/v1/scenes"), api("/openapi.json"), api("/healthz"),
  ]);
  for (const scene of scenes.scenes) {
    option($("scene"), scene.name, scene.source === "uploaded" ? `${scene.name} (${scene.description})` : scene.name);
  }
  // The tiers come from the API's own schema, so new tiers appear without changing this page.
  const request = openapi.components.schemas.JobRequest.properties;
  for (const tier of request.tier.enum) option($("tier"), tier, tier);
  $("width").max = request.width.maximum;
  $("height").max = request.height.maximum;
  $("spp").max = request.spp.maximum;
  showHealth(health);
}

// The service's state in the header; in the scale-out mode also its workers.
function showHealth(health) {
  let where;
  if (health.mode === "scale-out") {
    const gpus = health.workers.filter((w) => w.gpu).length;
    where = `${health.workers.length} worker(s), ${gpus} with a GPU`;
  } else {
    where = health.gpu ? `GPU: ${health.gpu.name}${health.gpu.hardware ? "" : " (software)"}` : "no GPU: the auto, reference and direct tiers run on the CPU";
  }
  $("health").textContent = `version ${health.version} · ${where} · ${health.queue_depth} queued`;
  $("workers-panel").hidden = !health.workers;
  if (!health.workers) return;
  const body = $("workers").tBodies[0];
  body.replaceChildren();
  for (const worker of health.workers) {
    const tr = document.createElement("tr");
    tr.dataset.name = worker.name;
    for (const text of [worker.name, worker.gpu || "none (CPU tiers)", worker.job || "idle", `${fixed(worker.silent_s, 1)} s ago`]) {
      const td = document.createElement("td");
      td.textContent = text;
      tr.appendChild(td);
    }
    body.appendChild(tr);
  }
}

async function upload(event) {
  event.preventDefault();
  const file = $("upload-file").files[0];
  if (!file) return;
  $("upload").disabled = true;
  $("upload-status").textContent = `uploading ${file.name}…`;
  try {
    const answer = await api(`/v1/scenes?name=${encodeURIComponent(file.name)}`, {
      method: "POST",
      headers: { "Content-Type": "model/gltf-binary" },
      body: file,
    });
    const scene = answer.scene;
    if (!$("scene").querySelector(`option[value="${scene.id}"]`)) {
      option($("scene"), scene.id, `${scene.id} (${scene.name}, ${scene.triangles} triangles)`);
    }
    $("scene").value = scene.id;
    const warnings = scene.warnings.length ? ` Warnings: ${scene.warnings.join("; ")}` : "";
    $("upload-status").textContent = `${scene.name}: ${scene.triangles} triangles, selected as ${scene.id}.${warnings}`;
  } catch (error) {
    $("upload-status").textContent = error.message;
  } finally {
    $("upload").disabled = false;
  }
}

function formRequest() {
  const number = (id) => $(id).value === "" ? undefined : Number($(id).value);
  const request = {
    scene: $("scene").value,
    tier: $("tier").value,
    width: number("width"),
    height: number("height"),
    spp: number("spp"),
    frames: number("frames"),
    warmup: number("warmup"),
    compare: $("compare").checked,
    priority: number("priority"),
  };
  if (request.compare) request.reference_spp = number("reference_spp");
  return request;
}

async function submit(event) {
  event.preventDefault();
  $("form-error").textContent = "";
  $("submit").disabled = true;
  try {
    const accepted = await api("/v1/jobs", {
      method: "POST",
      headers: { "Content-Type": "application/json" },
      body: JSON.stringify(formRequest()),
    });
    showJob(accepted.id);
    refreshJobs();
  } catch (error) {
    $("form-error").textContent = error.message;
  } finally {
    $("submit").disabled = false;
  }
}

function showJob(id) {
  currentJob = id;
  clearTimeout(pollTimer);
  for (const img of ["img-tier", "img-reference", "img-error", "img-flip"]) $(img).removeAttribute("src");
  $("metrics").tBodies[0].replaceChildren();
  $("passes").tBodies[0].replaceChildren();
  $("job").hidden = false;
  poll();
}

function fixed(value, digits) {
  return value === null || value === undefined ? "–" : Number(value).toFixed(digits);
}

function row(table, name, value, key) {
  const tr = document.createElement("tr");
  const th = document.createElement("th");
  th.textContent = name;
  const td = document.createElement("td");
  td.className = "num";
  td.textContent = value;
  if (key) td.dataset.metric = key;
  tr.append(th, td);
  table.tBodies[0].appendChild(tr);
}

function render(job) {
  const section = $("job");
  section.dataset.state = job.state;
  $("job-id").textContent = job.id;
  $("job-state").textContent = job.state;
  $("job-state").className = `state ${job.state}`;
  const r = job.request;
  // A job whose record cannot be read has no request; its error says why.
  $("job-summary").textContent = !r ? "" : `${r.scene} · tier ${r.tier} · ${r.width}×${r.height} · ${r.spp} spp · ${r.frames} frame(s)` +
    (r.compare ? ` · reference ${r.reference_spp} spp` : "") + (r.priority ? ` · priority ${r.priority}` : "") +
    (job.worker ? ` · on ${job.worker}` : "");
  const progress = job.state === "done" ? 1 : job.progress ? job.progress.fraction : 0;
  $("job-progress").value = progress;
  $("job-stage").textContent = job.progress ? `${job.progress.stage} ${job.progress.done}/${job.progress.total}` : "";
  $("cancel").hidden = job.state !== "queued" && job.state !== "running";
  $("delete").hidden = !$("cancel").hidden;
  $("job-error").textContent = job.error ? `${job.error.message} (${job.error.code})` : "";
  if (job.state !== "done") return;

  showImage($("img-tier"), job.images.image_png);
  $("img-reference").closest("figure").hidden = !job.images.reference_png;
  $("img-error").closest("figure").hidden = !job.images.error_png;
  $("img-flip").closest("figure").hidden = !job.images.flip_png;
  if (job.images.reference_png) showImage($("img-reference"), job.images.reference_png);
  if (job.images.error_png) showImage($("img-error"), job.images.error_png);
  if (job.images.flip_png) showImage($("img-flip"), job.images.flip_png);

  const result = job.result;
  const metrics = $("metrics");
  metrics.tBodies[0].replaceChildren();
  row(metrics, "tier used", `${result.tier} on ${result.device}`, "tier");
  const c = result.comparison;
  if (c) {
    row(metrics, "rmse_srgb8", fixed(c.rmse_srgb8, 2), "rmse_srgb8");
    row(metrics, "flip", fixed(c.flip, 4), "flip");
    row(metrics, "rmse_linear", fixed(c.rmse_linear, 4), "rmse_linear");
    row(metrics, "gain_vs_direct", fixed(c.gain_vs_direct, 3), "gain_vs_direct");
    row(metrics, "reference", `${c.reference_spp} spp${c.reference_cached ? " (cached)" : ""}, ${fixed(c.reference_seconds, 2)} s on ${c.reference_engine}`, "reference_spp");
  }
  row(metrics, "ms per frame", fixed(result.ms_per_frame, 2), "ms_per_frame");
  if (result.gi_ms !== null) row(metrics, "GI ms", fixed(result.gi_ms, 2), "gi_ms");
  row(metrics, "memory", `${fixed(result.memory_bytes / 1048576, 2)} MiB`, "memory");
  row(metrics, "frames", `${result.frames} after ${result.warmup} warm-up`, "frames");
  row(metrics, "render time", `${fixed(result.render_seconds, 2)} s`, "render_seconds");
  const passes = $("passes");
  passes.tBodies[0].replaceChildren();
  for (const [name, ms] of Object.entries(result.passes)) row(passes, name, `${fixed(ms, 3)} ms`);
}

// An <img> cannot send the token: with one, the image is fetched and shown from a blob.
async function showImage(img, url) {
  if (!sessionStorage.getItem(TOKEN_KEY)) {
    img.src = url;
    return;
  }
  const response = await fetch(url, { headers: withToken() });
  if (!response.ok) return;
  if (img.src.startsWith("blob:")) URL.revokeObjectURL(img.src);
  img.src = URL.createObjectURL(await response.blob());
}

async function poll() {
  const id = currentJob;
  try {
    const job = await api(`/v1/jobs/${id}`);
    if (id !== currentJob) return;
    render(job);
    if (job.state === "queued" || job.state === "running") {
      pollTimer = setTimeout(poll, 400);
    } else {
      refreshJobs();
    }
  } catch (error) {
    $("job-error").textContent = error.message;
    pollTimer = setTimeout(poll, 2000);
  }
}

function jobRow(job) {
  const tr = document.createElement("tr");
  tr.dataset.id = job.id;
  // A job whose record cannot be read shows only its id and state.
  const r = job.request || { scene: "", tier: "", width: "", height: "" };
  const c = job.result && job.result.comparison;
  const tier = job.result && job.result.tier !== r.tier ? `${r.tier} → ${job.result.tier}` : r.tier;
  const cells = [job.id, r.scene, tier, job.request ? `${r.width}×${r.height}` : "", job.state,
    c ? fixed(c.rmse_srgb8, 2) : "", c ? fixed(c.flip, 4) : "", c ? fixed(c.gain_vs_direct, 3) : "",
    job.submitted_at ? new Date(job.submitted_at).toLocaleString() : ""];
  for (const text of cells) {
    const td = document.createElement("td");
    td.textContent = text;
    tr.appendChild(td);
  }
  tr.addEventListener("click", () => showJob(job.id));
  return tr;
}

async function refreshJobs(older) {
  const before = older && oldestShown ? `&before=${oldestShown}` : "";
  try {
    const page = await api(`/v1/jobs?limit=20${before}`);
    const body = $("jobs").tBodies[0];
    if (!older) body.replaceChildren();
    for (const job of page.jobs) body.appendChild(jobRow(job));
    if (page.jobs.length) oldestShown = page.jobs[page.jobs.length - 1].id;
    $("older").hidden = !page.next;
  } catch (error) {
    $("form-error").textContent = error.message;
  }
}

$("token-form").addEventListener("submit", (event) => {
  event.preventDefault();
  sessionStorage.setItem(TOKEN_KEY, $("token").value.trim());
  location.reload();
});
$("job-form").addEventListener("submit", submit);
$("upload-form").addEventListener("submit", upload);
$("cancel").addEventListener("click", async () => {
  try { render(await api(`/v1/jobs/${currentJob}`, { method: "DELETE" })); } catch (error) { $("job-error").textContent = error.message; }
});
$("delete").addEventListener("click", async () => {
  try {
    await api(`/v1/jobs/${currentJob}`, { method: "DELETE" });
    currentJob = null;
    clearTimeout(pollTimer);
    $("job").hidden = true;
    refreshJobs();
  } catch (error) { $("job-error").textContent = error.message; }
});
$("older").addEventListener("click", () => refreshJobs(true));
loadChoices().catch((error) => { $("form-error").textContent = error.message; });
refreshJobs();
setInterval(() => {
  if (document.hidden) return;
  refreshJobs();
  api("/healthz").then(showHealth).catch(() => {});
}, 5000);
