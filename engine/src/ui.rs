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
/* escaping: begin. Every value from a host, a run or the user goes through one of these,
   by the context it lands in; ui.rs's tests run them under node. */
const esc = s => String(s ?? "").replace(/[&<>"']/g,
  c => ({"&": "&amp;", "<": "&lt;", ">": "&gt;", '"': "&quot;", "'": "&#39;"})[c]);
const num = (n, digits = 0) => typeof n === "number" && Number.isFinite(n) ? n.toFixed(digits) : "";
const link = (url, text) => {
  let parsed;
  try { parsed = new URL(String(url), location.href); } catch { return esc(text); }
  if (parsed.protocol !== "http:" && parsed.protocol !== "https:") return esc(text);
  return `<a href="${esc(parsed.href)}" rel="noopener noreferrer">${esc(text)}</a>`;
};
/* escaping: end */
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
    hosts.map(h => `<tr><td>${link(h.url, h.url)}</td>` +
      `<td class="${h.suspect ? "down" : h.up ? "ok" : "down"}" title="${esc(h.suspect ?? h.last_error)}">` +
      `${h.suspect ? "suspect" : h.up ? "up" : "down"}</td>` +
      `<td>${num(h.running)}</td><td>${esc(h.services.join(", "))}</td></tr>`).join("");
  const services = await (await api("/services")).json();
  $("services").innerHTML = "<tr><th>service</th><th>kind</th><th>parameters</th><th>hosts</th></tr>" +
    services.map(s => `<tr><td title="${esc(s.doc)}">${esc(s.name)}</td><td>${esc(s.kind)}</td>` +
      `<td>${esc(s.params.map(p => p.name).join(", "))}</td><td>${num(s.hosts.length)}</td></tr>`).join("");
}
function showStep(s) {
  const row = document.createElement("tr");
  const size = s.correction_bytes == null ? "" : `${num(s.correction_bytes / 1024, 1)} KB`;
  row.innerHTML = `<td>${num(s.index)}</td><td>${esc(s.path)}</td><td>${esc(s.service)}</td>` +
    `<td>${esc(s.host)}</td><td>${num(s.compute_ms, 1)} ms</td><td>${esc(size)}</td>` +
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
  const id = encodeURIComponent(run.id);
  const events = new EventSource(`/runs/${id}/events?token=${encodeURIComponent(token)}`);
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
        link.href = URL.createObjectURL(await (await api(`/runs/${id}/result`)).blob());
        link.download = `${run.id}.mfm`; link.click();
      };
    }
    if (["completed", "failed", "cancelled", "interrupted"].includes(s.status)) events.close();
  });
};
refresh(); setInterval(refresh, 3000);
</script></body></html>
"##;

#[cfg(test)]
mod tests {
    use std::process::Command;

    use super::PAGE;

    /// The page's script, with the browser replaced by stubs: `fetch` answers `hosts` and
    /// `services` as a hostile host registered them; the page's tables are plain objects.
    fn page_under_node(checks: &str) -> String {
        let script = &PAGE[PAGE.find("<script>").unwrap() + 8..PAGE.find("</script>").unwrap()];
        let evil = r#"x" onmouseover="alert(1)" '<img src=x onerror=alert(2)>&"#;
        let stubs = format!(
            r#"
            const evil = {evil:?};
            const elements = {{}};
            globalThis.location = {{href: "http://127.0.0.1:7000/", hash: "", pathname: "/"}};
            globalThis.localStorage = {{getItem: () => null, setItem: () => {{}}}};
            globalThis.history = {{replaceState: () => {{}}}};
            globalThis.document = {{getElementById: id => elements[id] ??= {{innerHTML: ""}}}};
            globalThis.setInterval = () => {{}};
            const answers = {{
              "/hosts": [{{url: "javascript:alert(3)", up: true, suspect: evil, running: evil,
                           assigned: 0, last_error: evil, services: [evil]}},
                         {{url: "http://127.0.0.1:7101", up: true, running: 1, assigned: 0,
                           last_error: null, services: ["fill-holes"]}}],
              "/services": [{{name: evil, kind: evil, doc: evil, params: [{{name: evil}}],
                              hosts: [evil]}}],
            }};
            globalThis.fetch = async url => ({{json: async () => answers[url]}});
            "#
        );
        let program =
            format!("{stubs}\n{script}\n(async () => {{ await refresh(); {checks} }})();");
        let output = Command::new("node")
            .args(["-e", &program])
            .output()
            .expect("node runs the web UI's script (install Node.js to run this test)");
        let stderr = String::from_utf8_lossy(&output.stderr);
        assert!(output.status.success(), "node failed: {stderr}");
        String::from_utf8_lossy(&output.stdout).into_owned()
    }

    #[test]
    fn every_context_escapes_what_hosts_send() {
        let out = page_under_node(
            r#"console.log(JSON.stringify({
                 esc: esc(`<>&"'`),
                 num: [num("1e3"), num(2.5, 1), num(null)],
                 links: [link("javascript:alert(1)", "a"), link("data:text/html,x", "b"),
                         link("http://h/x?a=1&b=\"", "c"), link("/runs/1/result", "d")],
                 hosts: elements.hosts.innerHTML,
                 services: elements.services.innerHTML,
               }));"#,
        );
        let json: serde_json::Value = serde_json::from_str(out.trim()).unwrap();
        assert_eq!(json["esc"], "&lt;&gt;&amp;&quot;&#39;");
        assert_eq!(json["num"], serde_json::json!(["", "2.5", ""]));
        assert_eq!(json["links"][0], "a");
        assert_eq!(json["links"][1], "b");
        assert_eq!(
            json["links"][2],
            r#"<a href="http://h/x?a=1&amp;b=%22" rel="noopener noreferrer">c</a>"#
        );
        assert_eq!(
            json["links"][3],
            r#"<a href="http://127.0.0.1:7000/runs/1/result" rel="noopener noreferrer">d</a>"#
        );
        for table in ["hosts", "services"] {
            let html = json[table].as_str().unwrap();
            // No quote, angle bracket or script URL of the host's text survives raw.
            for raw in [r#"" onmouseover"#, "<img", "'<", r#"href="javascript:"#] {
                assert!(!html.contains(raw), "{table} contains {raw}: {html}");
            }
            assert!(html.contains("&quot; onmouseover=&quot;alert(1)&quot;"), "{html}");
        }
    }
}
