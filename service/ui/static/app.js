// The calibration service's web page: robots, their calibration history and parameter drift, reports, pose
// designs drawn in the workspace, jobs with progress. Everything comes from the public /v1 API, so the page
// shows exactly what a client sees; the API key (if the service has keys) stays in this browser's storage.
"use strict";

const view = document.getElementById("view");
const keyInput = document.getElementById("api-key");
keyInput.value = localStorage.getItem("iwr-api-key") || "";
keyInput.addEventListener("change", () => { localStorage.setItem("iwr-api-key", keyInput.value); route(); });

async function api(path, options = {}) {
  const headers = { Accept: "application/json", ...(options.headers || {}) };
  if (keyInput.value) headers["X-API-Key"] = keyInput.value;
  const response = await fetch(path, { ...options, headers });
  if (!response.ok) {
    let detail = response.statusText;
    try { detail = (await response.json()).detail || detail; } catch (_) { /* not a problem document */ }
    throw new Error(`${response.status}: ${detail}`);
  }
  return options.raw ? response : response.json();
}

function h(tag, attrs = {}, ...children) {
  const node = document.createElement(tag);
  for (const [k, v] of Object.entries(attrs)) {
    if (k === "onclick") node.addEventListener("click", v);
    else if (v !== null && v !== undefined) node.setAttribute(k, String(v));
  }
  for (const c of children.flat()) node.append(c instanceof Node ? c : document.createTextNode(c ?? "—"));
  return node;
}

const num = (v, digits = 4) => (v === null || v === undefined ? "—"
  : Number.isInteger(v) ? String(v) : Number(v).toPrecision(digits));  // counts and versions stay integers
const when = (iso) => (iso ? new Date(iso).toLocaleString() : "—");

function table(headers, rows, id) {
  return h("table", { id }, h("thead", {}, h("tr", {}, headers.map((x) => h("th", {}, x)))),
    h("tbody", {}, rows.map((r) => h("tr", {}, r.map((c) => (c instanceof Node && c.tagName === "TD" ? c : h("td", {}, c)))))));
}

function numCell(v, digits) { return h("td", { class: "num" }, num(v, digits)); }

// ---------------------------------------------------------------- pages
async function robotsPage() {
  const robots = await api("/v1/robots");
  view.replaceChildren(h("h1", {}, "Robots"),
    robots.length === 0 ? h("p", { class: "muted" }, "No robot yet: POST /v1/robots creates one.") :
      table(["name", "model", "current version", "created"], robots.map((r) => [
        h("a", { href: `#/robots/${r.id}` }, r.name), r.model, numCell(r.parameter_version, 3), when(r.created_at)]),
      "robots"));
}

async function robotPage(id) {
  const [robot, calibrations, versions, designs, validations] = await Promise.all([
    api(`/v1/robots/${id}`), api(`/v1/robots/${id}/calibrations`), api(`/v1/robots/${id}/parameter-versions`),
    api(`/v1/robots/${id}/pose-designs`), api(`/v1/robots/${id}/validations`)]);
  // One row per (validation, version): the same campaign judged against each version it was asked for.
  const validationRows = validations.flatMap((v) => v.results.map((r) => [when(v.created_at), numCell(r.version, 3),
    numCell(v.measurements, 3), numCell(r.position_mm.rms), numCell(r.position_mm.max),
    r.iso9283 ? r.iso9283.poses.map((p) => num(p.AP_mm, 3)).join(" · ") : "—", r.registered ? "yes" : "no"]));
  const drift = h("div", { id: "drift" });
  const choose = h("select", { id: "drift-parameter" });
  const first = await api(`/v1/robots/${id}/parameters?version=1`);
  for (const p of first.parameters) choose.append(h("option", { value: p.name }, p.name));
  choose.addEventListener("change", () => drawDrift(id, versions, choose.value, drift));
  const designView = h("div", { id: "design-view" });
  view.replaceChildren(
    h("h1", {}, robot.name), h("p", { class: "muted" }, `${robot.model} · version ${robot.parameter_version} · ${robot.id}`),
    h("h2", {}, "Calibrations"),
    calibrations.length === 0 ? h("p", { class: "muted" }, "No calibration yet.") :
      table(["when", "status", "applied", "from → to", "RMS before (mm)", "RMS after (mm)", "report"],
        calibrations.map((c) => [when(c.created_at), h("span", { class: `status-${c.status}` }, c.status),
          c.applied ? "yes" : "no", `${c.start_version ?? "—"} → ${c.parameter_version ?? "—"}`,
          numCell(c.residuals.before.rms_mm), numCell(c.residuals.after.rms_mm),
          h("span", {}, h("a", { href: `#/calibrations/${c.id}/report` }, "HTML"), " · ",
            h("a", { href: "#", onclick: (e) => { e.preventDefault(); openPdf(c.id); } }, "PDF"))]), "calibrations"),
    h("h2", {}, "Parameter versions"),
    table(["version", "provenance", "from", "by", "when", ""], versions.map((v) => [numCell(v.version, 3), v.provenance,
      v.calibration_id ? h("a", { href: `#/calibrations/${v.calibration_id}/report` }, "calibration") :
        (v.restored_from ? `version ${v.restored_from}` : "—"),
      v.actor || "—", when(v.created_at), v.current ? h("b", {}, "current") : ""]), "versions"),
    h("h2", {}, "Validations"),
    validationRows.length === 0 ? h("p", { class: "muted" }, "No validation yet.") :
      table(["when", "version", "poses", "RMS (mm)", "max (mm)", "ISO 9283 AP per pose (mm)", "registered"],
        validationRows, "validations"),
    h("h2", {}, "Parameter drift over versions"), h("div", { class: "row" }, choose), drift,
    h("h2", {}, "Pose designs"),
    designs.length === 0 ? h("p", { class: "muted" }, "No pose design yet.") :
      table(["when", "criterion", "poses", "measurement", ""], designs.map((d) => [when(d.created_at), d.criterion,
        numCell(d.count, 3), d.measurement,
        h("a", { href: "#", onclick: (e) => { e.preventDefault(); drawDesign(id, d.id, designView); } }, "draw")]),
      "designs"),
    designView);
  const estimated = first.parameters.find((p) => p.name === "leg1.offset") || first.parameters[0];
  choose.value = estimated.name;
  await drawDrift(id, versions, choose.value, drift);
}

async function drawDrift(id, versions, name, container) {
  const values = await Promise.all(versions.map((v) => api(`/v1/robots/${id}/parameters?version=${v.version}`)));
  const rows = values.map((v) => v.parameters.find((p) => p.name === name));
  container.replaceChildren();
  Plot.line(container, {
    id: "drift-plot", title: `${name} (${rows[0].unit}) by version, ± std error`, xlabel: "version", ylabel: rows[0].unit,
    x: versions.map((v) => v.version), y: rows.map((p) => p.value), err: rows.map((p) => p.std_error || 0),
  });
}

async function drawDesign(robotId, designId, container) {
  const design = await api(`/v1/pose-designs/${designId}`);
  const fk = await api(`/v1/robots/${robotId}/forward-kinematics`, {
    method: "POST", headers: { "Content-Type": "application/json" }, body: JSON.stringify({ joints: design.poses }),
  });
  const p = fk.poses.map((q) => q.position);
  container.replaceChildren(h("p", {}, `${design.poses.length} poses of a ${design.criterion}-optimal design (TCP positions, mm)`));
  const row = h("div", { class: "row" });
  container.append(row);
  Plot.scatter(row, { id: "design-top", title: "seen from above", xlabel: "x (mm)", ylabel: "y (mm)", x: p.map((v) => v[0]), y: p.map((v) => v[1]) });
  Plot.scatter(row, { id: "design-side", title: "seen from the side", xlabel: "x (mm)", ylabel: "z (mm)", x: p.map((v) => v[0]), y: p.map((v) => v[2]) });
}

async function reportPage(id) {
  const response = await api(`/v1/calibrations/${id}/report`, { raw: true, headers: { Accept: "text/html" } });
  const frame = h("iframe", { id: "report", title: "calibration report", style: "width:100%;height:80vh;border:1px solid #ddd" });
  frame.srcdoc = await response.text();
  view.replaceChildren(h("p", {}, h("a", { href: "javascript:history.back()" }, "← back")), frame);
}

async function openPdf(id) {
  const response = await api(`/v1/calibrations/${id}/report`, { raw: true, headers: { Accept: "application/pdf" } });
  window.open(URL.createObjectURL(await response.blob()), "_blank");
}

let jobTimer = null;
// The job list (GET /v1/jobs) is newer than this page: ask the service's own contract whether it has it, so an
// older service gets a note instead of a failed request.
let hasJobList = null;
async function jobListAvailable() {
  if (hasJobList === null) {
    const contract = await (await fetch("/openapi.json")).json();
    hasJobList = Boolean(contract.paths && contract.paths["/v1/jobs"] && contract.paths["/v1/jobs"].get);
  }
  return hasJobList;
}

async function jobsPage() {
  if (!(await jobListAvailable())) {
    view.replaceChildren(h("h1", {}, "Jobs"), h("p", { class: "muted", id: "no-job-list" },
      "This service does not list jobs (GET /v1/jobs); each job is still at the status_url its submission returned."));
    return;
  }
  const jobs = await api("/v1/jobs");
  view.replaceChildren(h("h1", {}, "Jobs"),
    jobs.length === 0 ? h("p", { class: "muted" }, "No job yet.") :
      table(["submitted", "kind", "status", "progress", "error"], jobs.map((j) => {
        const fraction = j.status === "succeeded" ? 1 : (j.progress && j.progress.fraction) || 0;
        return [when(j.created_at), j.kind, h("span", { class: `status-${j.status}` }, j.status),
          h("span", {}, h("span", { class: "progress", title: (j.progress && j.progress.stage) || "" },
            h("span", { style: `width:${Math.round(fraction * 100)}%` })), ` ${Math.round(fraction * 100)} %`),
          j.error ? h("span", { class: "error" }, j.error.detail || "") : ""];
      }), "jobs"));
  if (jobs.some((j) => j.status === "queued" || j.status === "running")) jobTimer = setTimeout(route, 2000);
}

// ---------------------------------------------------------------- routing
async function route() {
  clearTimeout(jobTimer);
  const parts = (location.hash.replace(/^#\/?/, "") || "").split("/").filter(Boolean);
  try {
    if (parts[0] === "robots" && parts[1]) await robotPage(parts[1]);
    else if (parts[0] === "calibrations" && parts[2] === "report") await reportPage(parts[1]);
    else if (parts[0] === "jobs") await jobsPage();
    else await robotsPage();
    document.body.dataset.ready = location.hash || "#/";
  } catch (error) {
    view.replaceChildren(h("p", { class: "error", id: "error" }, String(error.message || error)));
    document.body.dataset.ready = "error";
  }
}

window.addEventListener("hashchange", route);
route();
