//! The web UI: one static page over the engine API (hosts, services, submit, live progress).
//! The page itself is open; it takes the API token from the address (`#token=…`, as
//! `meshflow up` prints it; then kept in the browser's localStorage and dropped from the
//! address) or asks for it, and sends it as a bearer header (as `?token=` for the event
//! stream, which `EventSource` cannot give headers).

pub const PAGE: &str = r##"<!doctype html>
<html lang="en"><head><meta charset="utf-8"><title>meshflow engine</title>
<style>
body{font:14px system-ui,sans-serif;margin:2em;max-width:70em}
textarea{width:100%;height:14em;font:13px monospace}
table{border-collapse:collapse}td,th{border:1px solid #ccc;padding:2px 6px;text-align:left}
.down{color:#a00}.ok{color:#070}pre{background:#f6f6f6;padding:.5em;overflow:auto}
</style></head><body>
<h1>meshflow engine</h1>
<h2>Hosts</h2><table id="hosts"></table>
<h2>Services</h2><table id="services"></table>
<h2>Run a workflow</h2>
<p>Input mesh: <input type="file" id="file"> or URL <input id="url" size="50"></p>
<textarea id="workflow">{"steps": [
  {"run": "remove-smallest-components"},
  {"run": "laplacian-smoothing", "params": {"iterations": 1}},
  {"run": "fill-holes"},
  {"run": "remove-degenerate-triangles"}
], "transfer": "auto"}</textarea>
<p><button id="go">Run</button> <span id="state"></span></p>
<table id="steps"></table><p id="result"></p>
<script>
const $ = id => document.getElementById(id);
const esc = s => String(s ?? "").replace(/[&<>]/g, c => ({"&":"&amp;","<":"&lt;",">":"&gt;"})[c]);
const fromUrl = new URLSearchParams(location.hash.slice(1)).get("token");
if (fromUrl) { localStorage.setItem("meshflow-token", fromUrl); history.replaceState(null, "", location.pathname); }
let token = localStorage.getItem("meshflow-token") || "", asked = false;
async function api(path, options = {}) {
  const answer = await fetch(path, {...options, headers: {...(options.headers || {}), ...(token ? {authorization: "Bearer " + token} : {})}});
  if (answer.status === 401 && !asked) {
    asked = true;
    token = prompt("The engine's API token (meshflow up prints it):") || "";
    localStorage.setItem("meshflow-token", token);
  }
  return answer;
}
async function refresh() {
  const hosts = await (await api("/hosts")).json();
  $("hosts").innerHTML = "<tr><th>host</th><th>state</th><th>running</th><th>services</th></tr>" +
    hosts.map(h => `<tr><td>${esc(h.url)}</td><td class="${h.up?"ok":"down"}">${h.up?"up":"down"}</td>` +
      `<td>${h.running}</td><td>${esc(h.services.join(", "))}</td></tr>`).join("");
  const services = await (await api("/services")).json();
  $("services").innerHTML = "<tr><th>service</th><th>kind</th><th>parameters</th><th>hosts</th></tr>" +
    services.map(s => `<tr><td title="${esc(s.doc)}">${esc(s.name)}</td><td>${esc(s.kind)}</td>` +
      `<td>${esc(s.params.map(p => p.name).join(", "))}</td><td>${s.hosts.length}</td></tr>`).join("");
}
function showStep(s) {
  const row = document.createElement("tr");
  const size = s.correction_bytes == null ? "" : `${(s.correction_bytes/1024).toFixed(1)} KB`;
  row.innerHTML = `<td>${s.index}</td><td>${esc(s.path)}</td><td>${esc(s.service)}</td>` +
    `<td>${esc(s.host)}</td><td>${s.compute_ms.toFixed(1)} ms</td><td>${size}</td>` +
    `<td>${esc(s.value == null ? "" : JSON.stringify(s.value))}</td>`;
  $("steps").appendChild(row);
}
$("go").onclick = async () => {
  $("steps").innerHTML = "<tr><th>#</th><th>step</th><th>service</th><th>host</th><th>compute</th><th>correction</th><th>value</th></tr>";
  $("result").textContent = "";
  let input = $("url").value || null;
  const file = $("file").files[0];
  if (file) {
    const up = await api("/inputs?name=" + encodeURIComponent(file.name), {method: "POST", body: file});
    const body = await up.json();
    if (!up.ok) { $("state").textContent = body.error.message; return; }
    input = body.url;
  }
  let workflow;
  try { workflow = JSON.parse($("workflow").value); } catch (e) { $("state").textContent = "workflow: " + e; return; }
  const answer = await api("/runs", {method: "POST", headers: {"content-type": "application/json"},
    body: JSON.stringify({workflow, input})});
  const run = await answer.json();
  if (!answer.ok) { $("state").textContent = run.error.message; return; }
  $("state").textContent = "run " + run.id + ": running";
  const events = new EventSource(`/runs/${run.id}/events?token=${encodeURIComponent(token)}`);
  events.addEventListener("step", e => showStep(JSON.parse(e.data)));
  events.addEventListener("status", e => {
    const s = JSON.parse(e.data);
    $("state").textContent = `run ${run.id}: ${s.status}` + (s.error ? ` — ${s.error}` : "") +
      (s.total_ms ? ` in ${(s.total_ms/1000).toFixed(2)} s` : "");
    if (s.status === "completed") {
      $("result").innerHTML = `<a href="#">download the result (.mfm)</a>`;
      $("result").firstChild.onclick = async e => {
        e.preventDefault();
        const link = document.createElement("a");
        link.href = URL.createObjectURL(await (await api(`/runs/${run.id}/result`)).blob());
        link.download = `${run.id}.mfm`; link.click();
      };
    }
    if (s.status === "completed" || s.status === "failed") events.close();
  });
};
refresh(); setInterval(refresh, 3000);
</script></body></html>
"##;
