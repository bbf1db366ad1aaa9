// One calibration's result: its status first (for a failed or refused one the reason and diagnoses, prominent),
// the numbers, the residuals before and after, the parameters with σ and what moved, outliers, the acceptance
// checks, the not-applied reason and how to apply anyway, and the reports and parameter exports.
import { api } from "../api.js";
import { download, errorBox, fill, h, link, muted, num, numCell, statusBadge, table, when } from "../dom.js";

// A change larger than twice its standard error is unlikely to be the noise of this campaign: call it moved.
const MOVED_SIGMAS = 2;

export async function calibrationView(view, id) {
  const calibration = await api(`/v1/calibrations/${id}`);
  const robot = await api(`/v1/robots/${calibration.robot_id}`);
  const fitted = calibration.status !== "failed";  // a failed one ran no fit: no "after", no estimates
  const sections = [
    h("p", {}, link(`#/robots/${robot.id}`, `← ${robot.name}`)),
    h("h1", {}, "Calibration ", statusBadge(calibration.status)),
    muted(`${when(calibration.created_at)} · ${calibration.measurements} ${calibration.measurement} records · ${calibration.id}`),
    verdict(calibration, robot),
    fitted ? summary(calibration) : null,
    residualSection(calibration, fitted),
    checksSection(calibration),
    fitted ? parametersSection(calibration) : null,
    fitted ? outliersSection(calibration) : null,
    notesSection(calibration),
    exportsSection(calibration, robot)];
  fill(view, ...sections);
}

// ---------------------------------------------------------------- the verdict
function verdict(c, robot) {
  if (c.status === "failed") {
    return h("section", { class: "verdict failed", id: "verdict", role: "alert" },
      h("h2", {}, "The calibration failed: nothing was applied"),
      h("p", { id: "failure-reason" }, c.reason || "no reason recorded"), diagnosesList(c.diagnoses));
  }
  if (c.applied) {
    return h("section", { class: "verdict applied", id: "verdict" }, h("h2", {}, "Applied"),
      h("p", {}, `It became version ${c.parameter_version} of ${robot.name}${c.forced ? ", forced although a check failed" : ""}.`),
      robot.parameter_version !== c.parameter_version ? restoreButton(robot, c.parameter_version) : null);
  }
  const body = h("section", { class: "verdict not-applied", id: "verdict", role: c.not_applied_reason ? "alert" : null },
    h("h2", {}, "Not applied"),
    h("p", { id: "not-applied-reason" }, c.not_applied_reason || "The request asked not to apply it (apply: false)."));
  body.append(applyControls(c));
  return body;
}

export function diagnosesList(diagnoses) {
  if (!diagnoses || diagnoses.length === 0) return null;
  return h("ul", { id: "diagnoses", class: "diagnoses" }, diagnoses.map((d) => h("li", {},
    h("b", {}, `${d.finding}${d.blocking ? " (blocking)" : ""}: `), d.message,
    d.records && d.records.length ? ` — records ${d.records.slice(0, 20).join(", ")}${d.records.length > 20 ? " …" : ""}` : "")));
}

// Applying a stored, unapplied result: the API applies only at fit time, so the stored campaign is fitted again
// with the same noise and start version and `apply` (plus `force_apply` when a check failed, recorded as forced).
function applyControls(c) {
  const message = h("div", { id: "apply-message" });
  if (c.record_kinds) {
    return h("div", {}, muted("This campaign has reference records (ballbar, points, planes): send it again with its "
      + "anchors and force_apply to apply it."), message);
  }
  const force = Boolean(c.not_applied_reason);
  const button = h("button", { type: "button", id: force ? "force-apply" : "apply-now" }, force ? "Force apply" : "Apply");
  button.addEventListener("click", async () => {
    button.disabled = true;
    try {
      const campaign = await api(`/v1/campaigns/${c.campaign_id}`);
      const body = { measurements: campaign.measurements, apply: true, force_apply: force, start_version: c.start_version,
        notes: `applied from the browser, refit of calibration ${c.id}` };
      if (c.noise) body.noise = c.noise;
      if (c.instrument) body.instrument = c.instrument;
      const again = await api(`/v1/robots/${c.robot_id}/calibrations`, { method: "POST", json: body });
      location.hash = `#/calibrations/${again.id}`;
    } catch (error) {
      fill(message, errorBox(error, "apply-error"));
      button.disabled = false;
    }
  });
  return h("div", {}, h("p", {}, force
    ? "Force apply fits the same campaign again from the same start version and applies it although the check above failed; the new calibration records that it was forced."
    : "Apply fits the same campaign again from the same start version and applies it if its checks pass."), button, message);
}

function restoreButton(robot, version) {
  const message = h("div");
  const button = h("button", { type: "button", id: "restore-version" }, `Make version ${version} current again (restore)`);
  button.addEventListener("click", async () => {
    try {
      await api(`/v1/robots/${robot.id}/parameter-versions/${version}/restore`, { method: "POST" });
      location.hash = `#/robots/${robot.id}`;
    } catch (error) { fill(message, errorBox(error)); }
  });
  return h("div", {}, muted(`The robot's current version is ${robot.parameter_version} now.`), button, message);
}

// ---------------------------------------------------------------- numbers
// Each value carries data-key/data-value with the API's own number, so a test (or a user's copy) gets it unrounded.
function figure(key, label, value, unit = "") {
  return h("div", { class: "figure" }, h("dt", {}, label),
    h("dd", { "data-key": key, "data-value": value ?? "", id: `fig-${key.replace(/\W+/g, "-")}` }, `${num(value)} ${value === null || value === undefined ? "" : unit}`));
}

function summary(c) {
  const r = c.residuals || { before: {}, after: {} };
  const p = c.predicted_accuracy || {};
  return h("section", {}, h("h2", {}, "Numbers"), h("dl", { class: "figures", id: "figures" },
    figure("residuals.before.rms_mm", "RMS before", r.before.rms_mm, "mm"),
    figure("residuals.after.rms_mm", "RMS after", r.after.rms_mm, "mm"),
    figure("residuals.before.max_mm", "max before", r.before.max_mm, "mm"),
    figure("residuals.after.max_mm", "max after", r.after.max_mm, "mm"),
    r.after.rms_deg !== undefined && r.after.rms_deg !== null ? figure("residuals.after.rms_deg", "RMS after, orientation", r.after.rms_deg, "°") : null,
    figure("variance_factor", "variance factor", c.variance_factor),
    figure("rank", "rank (identified parameters)", c.rank),
    figure("degrees_of_freedom", "degrees of freedom", c.degrees_of_freedom),
    figure("condition_number", "condition number", c.condition_number),
    figure("predicted_accuracy.rms_position_mm", "predicted TCP accuracy, RMS", p.rms_position_mm, "mm"),
    figure("predicted_accuracy.max_position_mm", "predicted TCP accuracy, max", p.max_position_mm, "mm"),
    figure("seconds", "time", c.seconds, "s")));
}

function residualSection(c, fitted) {
  const before = (c.residuals && c.residuals.before.per_pose_mm) || [];
  const after = (c.residuals && c.residuals.after.per_pose_mm) || [];
  const series = [{ name: "before (start version)", values: before }];
  if (fitted) series.push({ name: "after", values: after });
  const section = h("section", {}, h("h2", {}, fitted ? "Residuals per record, before and after" : "Errors per record at the start version"));
  if (before.length === 0) { section.append(muted("No residuals recorded.")); return section; }
  Plot.bars(section, { id: "residual-plot", title: "TCP position error per record (mm)", xlabel: "record", ylabel: "mm", series });
  return section;
}

function checksSection(c) {
  const checks = c.checks || [];
  return h("section", {}, h("h2", {}, "Acceptance checks"), checks.length === 0 ? muted("No checks recorded.") :
    table(["check", "passed", "detail"], checks.map((k) => [k.name,
      h("td", { class: k.passed ? "status-succeeded" : "status-failed" }, k.passed ? "passed" : "failed"), k.detail]), "checks"));
}

function moved(p) {
  if (p.start === null || p.start === undefined || !p.std_error) return false;
  return Math.abs(p.value - p.start) > MOVED_SIGMAS * p.std_error;
}

function parametersSection(c) {
  const params = c.parameters || [];
  if (params.length === 0) return h("section", {}, h("h2", {}, "Parameters"), muted("No parameters: no fit was run."));
  const onlyMoved = h("input", { type: "checkbox", id: "only-moved" });
  const count = params.filter(moved).length;
  const rows = () => params.filter((p) => !onlyMoved.checked || moved(p)).map((p) => {
    const change = p.start === null || p.start === undefined ? null : p.value - p.start;
    const row = [p.name, numCell(p.start, 6), numCell(p.value, 6), numCell(change, 3), numCell(p.std_error, 2), p.unit,
      p.identifiable ? "yes" : "no", moved(p) ? h("td", { class: "moved" }, "moved") : ""];
    return row;
  });
  const holder = h("div", { class: "scroll" }, table(["parameter", "start", "value", "change", "σ", "unit", "identifiable", ""], rows(), "parameters"));
  onlyMoved.addEventListener("change", () => fill(holder, table(["parameter", "start", "value", "change", "σ", "unit", "identifiable", ""], rows(), "parameters")));
  return h("section", {}, h("h2", {}, "Parameters"),
    h("p", {}, `${count} of ${params.length} moved by more than ${MOVED_SIGMAS} σ from the start version. `,
      h("label", {}, onlyMoved, " show only those")), holder,
    c.unidentifiable && c.unidentifiable.length ? muted(`Not identifiable from this campaign (kept at the start version): ${c.unidentifiable.join(", ")}.`) : null);
}

function outliersSection(c) {
  const outliers = c.outliers || [];
  return h("section", {}, h("h2", {}, "Outliers"), outliers.length === 0 ? muted("No record flagged.", "no-outliers") :
    table(["record", "position error (mm)", "orientation (deg)", "statistic", "threshold", "excluded from the fit"],
      outliers.map((o) => [numCell(o.pose, 3), numCell(o.position_mm), numCell(o.orientation_deg), numCell(o.statistic),
        numCell(o.threshold), o.excluded ? "excluded" : "kept"]), "outliers"));
}

function notesSection(c) {
  const notes = [...(c.notes || []), ...(c.user_notes ? [`notes sent: ${c.user_notes}`] : [])];
  const nonBlocking = c.status === "failed" ? null : diagnosesList(c.diagnoses);
  if (notes.length === 0 && !nonBlocking) return null;
  return h("section", {}, h("h2", {}, "Notes and diagnoses"), h("ul", {}, notes.map((n) => h("li", {}, n))), nonBlocking);
}

// ---------------------------------------------------------------- reports and exports
async function save(path, accept, name) {
  const response = await api(path, { raw: true, accept });
  download(name, await response.blob(), accept);
}

function exportsSection(c, robot) {
  const message = h("div");
  const saving = (text, path, accept, name, id) => h("button", { type: "button", class: "link", id, onclick: () =>
    save(path, accept, name).catch((error) => fill(message, errorBox(error))) }, text);
  const serial = robot.structure.stages.every((s) => s.kind === "serial");
  const version = c.parameter_version;
  return h("section", {}, h("h2", {}, "Report and exports"), h("ul", { id: "exports" },
    h("li", {}, link(`#/calibrations/${c.id}/report`, "Report (HTML)", { id: "report-html" }), " · ",
      saving("Report (PDF)", `/v1/calibrations/${c.id}/report?format=pdf`, "application/pdf", `calibration-${c.id}.pdf`, "report-pdf")),
    version ? h("li", {}, `Parameters of version ${version}: `,
      saving("JSON", `/v1/robots/${robot.id}/parameters?version=${version}&format=json`, "application/json", `${robot.name}-v${version}.json`, "export-json"), " · ",
      saving("CSV", `/v1/robots/${robot.id}/parameters?version=${version}&format=csv`, "text/csv", `${robot.name}-v${version}.csv`, "export-csv"),
      serial ? [" · ", saving("URDF", `/v1/robots/${robot.id}/parameters?version=${version}&format=urdf`, "application/xml", `${robot.name}-v${version}.urdf`, "export-urdf"),
        " · ", saving("DH table", `/v1/robots/${robot.id}/parameters?version=${version}&format=dh`, "application/vnd.iwr.dh-table+json", `${robot.name}-v${version}-dh.json`, "export-dh"),
        " · ", saving("UR calibration", `/v1/robots/${robot.id}/parameters?version=${version}&format=ur-calibration`, "application/yaml", `${robot.name}-v${version}-calibration.yaml`, "export-ur")] : "")
      : h("li", {}, muted("No parameter version was created, so there is no export of it.")),
    h("li", {}, saving("Campaign (CSV)", `/v1/campaigns/${c.campaign_id}?format=csv`, "text/csv", `campaign-${c.campaign_id}.csv`, "campaign-csv"))),
  message);
}
