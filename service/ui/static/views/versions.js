// A robot's parameter versions: the list (restore, CSV export) and the difference of two of them
// (GET …/parameter-versions/{a}/diff/{b}): what moved, by how much and by how many of its σ, the robot's geometry
// apart from the registration (the base: where the instrument stood, which any moved tracker changes by thousands
// of σ without the robot changing), each sorted by |difference / σ|.
import { api } from "../api.js";
import { download, errorBox, fill, h, link, muted, num, numCell, table, when } from "../dom.js";

// As on a calibration's page: a difference beyond twice its σ is unlikely to be the noise of the two campaigns.
const MOVED_SIGMAS = 2;

export function versionsSection(robot, versions) {
  const message = h("div", { id: "versions-message" });
  const diff = h("div", { id: "version-diff" });
  const restore = (v) => h("button", { type: "button", class: "link", "data-version": v.version, onclick: async () => {
    try {
      await api(`/v1/robots/${robot.id}/parameter-versions/${v.version}/restore`, { method: "POST" });
      window.dispatchEvent(new HashChangeEvent("hashchange"));  // redraw this page with the new version
    } catch (error) { fill(message, errorBox(error, "restore-error")); }
  } }, `restore ${v.version}`);
  const exportCsv = (v) => h("button", { type: "button", class: "link", onclick: async () => {
    try {
      const response = await api(`/v1/robots/${robot.id}/parameters?version=${v.version}&format=csv`, { raw: true, accept: "text/csv" });
      download(`${robot.name}-v${v.version}.csv`, await response.text());
    } catch (error) { fill(message, errorBox(error)); }
  } }, "CSV");
  // Two versions ticked, oldest first as a and the newer as b: the difference is b − a.
  const picks = versions.map((v) => h("input", { type: "checkbox", class: "compare", value: v.version, "aria-label": `compare version ${v.version}` }));
  const compare = h("button", { type: "button", id: "compare-versions", disabled: true }, "Compare the two ticked versions");
  const ticked = () => picks.filter((p) => p.checked).map((p) => Number(p.value)).sort((x, y) => x - y);
  for (const p of picks) p.addEventListener("change", () => { compare.disabled = ticked().length !== 2; });
  compare.addEventListener("click", async () => {
    const [a, b] = ticked();
    try {
      fill(diff, diffView(await api(`/v1/robots/${robot.id}/parameter-versions/${a}/diff/${b}`)));
    } catch (error) { fill(diff, errorBox(error, "diff-error")); }
  });
  return h("div", {}, message,
    table(["compare", "version", "provenance", "from", "by", "when", "", "parameters"], versions.map((v, i) => [h("td", {}, picks[i]), numCell(v.version, 3), v.provenance,
      v.calibration_id ? link(`#/calibrations/${v.calibration_id}`, "calibration") : (v.restored_from ? `version ${v.restored_from}` : "—"),
      v.actor || "—", when(v.created_at), v.current ? h("b", {}, "current") : restore(v), exportCsv(v)]), "versions"),
    h("p", { class: "row" }, compare, h("span", { class: "muted" }, "Tick two versions to see what moved between them.")),
    diff);
}

// Largest |difference / σ| first; a difference without σ (neither version estimated it) after them, largest first.
function bySigma(x, y) {
  const sx = x.difference_sigma, sy = y.difference_sigma;
  if (sx !== null && sy !== null) return Math.abs(sy) - Math.abs(sx);
  if (sx !== null || sy !== null) return sx === null ? 1 : -1;
  return Math.abs(y.difference) - Math.abs(x.difference);
}

function diffTable(rows, id, caption) {
  return h("div", { class: "scroll" }, table(["parameter", "version a", "version b", "difference b − a", "σ of the difference", "difference / σ", "unit", ""],
    rows.map((p) => [p.name, numCell(p.a, 6), numCell(p.b, 6), numCell(p.difference, 3), numCell(p.std_error, 2),
      numCell(p.difference_sigma, 3), p.unit,
      p.difference_sigma !== null && Math.abs(p.difference_sigma) > MOVED_SIGMAS ? h("td", { class: "moved" }, "moved") : ""]), id, caption));
}

export function diffView(d) {
  const changed = new Set(d.changed);
  const rows = d.parameters.filter((p) => changed.has(p.name)).sort(bySigma);
  const geometry = rows.filter((p) => !p.registration), registration = rows.filter((p) => p.registration);
  const figure = (key, label, value) => h("div", { class: "figure" }, h("dt", {}, label),
    h("dd", { "data-key": key, "data-value": value ?? "", id: `diff-${key}` }, num(value)));
  return h("section", { id: "diff", "data-a": d.a, "data-b": d.b },
    h("h3", {}, `Version ${d.a} → version ${d.b}`),
    muted(`${rows.length} of ${d.parameters.length} parameters differ; σ is the two versions' standard errors combined `
      + `(a parameter a version did not estimate counts as exact). Marked "moved": beyond ${MOVED_SIGMAS} σ.`),
    h("dl", { class: "figures" },
      figure("geometry_max_abs_sigma", "largest |difference / σ|, robot geometry", d.geometry_max_abs_sigma),
      figure("max_abs_sigma", "largest |difference / σ|, registration included", d.max_abs_sigma)),
    h("h4", {}, "The robot's geometry"),
    geometry.length ? diffTable(geometry, "diff-geometry") : muted("No geometry parameter differs.", "diff-geometry-none"),
    h("h4", {}, "Registration (the base: where the instrument stood, not the robot)"),
    registration.length ? diffTable(registration, "diff-registration") : muted("The registration is the same.", "diff-registration-none"));
}
