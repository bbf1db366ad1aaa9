// One robot: what to do next (design poses, calibrate, validate), its calibrations, parameter versions (restore,
// export, the difference of two: versions.js), its adaptive campaigns (adaptive.js), validations, its fleet (fleet.js), its accuracy over time (history), a parameter's drift over the versions, and its pose designs.
import { api } from "../api.js";
import { campaignsTable } from "./adaptive.js";
import { fill, h, link, muted, numCell, statusBadge, table, when } from "../dom.js";
import { fleetSection } from "./fleet.js";
import { historySection } from "./history.js";
import { validationsTable } from "./validation.js";
import { versionsSection } from "./versions.js";

export async function robotView(view, id) {
  const [robot, calibrations, versions, designs, validations, adaptive] = await Promise.all([
    api(`/v1/robots/${id}`), api(`/v1/robots/${id}/calibrations`), api(`/v1/robots/${id}/parameter-versions`),
    api(`/v1/robots/${id}/pose-designs`), api(`/v1/robots/${id}/validations`), api(`/v1/robots/${id}/adaptive-campaigns`)]);
  const drift = h("div", { id: "drift" });
  const choose = h("select", { id: "drift-parameter", "aria-label": "parameter" });
  const first = await api(`/v1/robots/${id}/parameters?version=1`);
  for (const p of first.parameters) choose.append(h("option", { value: p.name }, p.name));
  choose.addEventListener("change", () => drawDrift(id, versions, choose.value, drift));
  const [history, fleet] = await Promise.all([historySection(robot), fleetSection(robot)]);
  fill(view, 
    h("h1", {}, robot.name), muted(`${robot.model} · version ${robot.parameter_version} · ${robot.joint_names.length} joints · ${robot.id}`),
    buildNote(robot),
    h("nav", { class: "actions", "aria-label": "workflow" },
      link(`#/robots/${id}/design`, "1. Design poses", { id: "go-design" }),
      link(`#/robots/${id}/calibrate`, "2. Calibrate from a campaign", { id: "go-calibrate" }),
      link(`#/robots/${id}/validate`, "3. Validate", { id: "go-validate" }),
      link(`#/robots/${id}/cell`, "The cell: obstacles, tracker, check poses", { id: "go-cell" }),
      link(`#/robots/${id}/adaptive`, "Adaptive campaign: one pose at a time to a target", { id: "go-adaptive" })),
    h("h2", {}, "Calibrations"), calibrationsTable(calibrations),
    h("h2", {}, "Adaptive campaigns"), campaignsTable(id, adaptive),
    h("h2", {}, "Parameter versions"), versionsSection(robot, versions),
    h("h2", {}, "Validations"), validationsTable(validations),
    h("h2", {}, "Fleet"), fleet,
    h("h2", {}, "Accuracy over time"), history,
    h("h2", {}, "Parameter drift over versions"), h("div", { class: "row" }, choose), drift,
    h("h2", {}, "Pose designs"),
    designs.length === 0 ? muted("No pose design yet.") :
      table(["when", "criterion", "poses", "measurement", ""], designs.map((d) => [when(d.created_at), d.criterion,
        numCell(d.count, 3), d.measurement, link(`#/robots/${id}/design?design=${d.id}`, "draw")]), "designs"));
  const estimated = first.parameters.find((p) => p.name === "leg1.offset") || first.parameters[0];
  choose.value = estimated.name;
  await drawDrift(id, versions, choose.value, drift);
}

function calibrationsTable(calibrations) {
  if (calibrations.length === 0) return muted("No calibration yet.");
  return table(["when", "status", "applied", "from → to", "RMS before (mm)", "RMS after (mm)", ""],
    calibrations.map((c) => [when(c.created_at), statusBadge(c.status), c.applied ? (c.forced ? "forced" : "yes") : "no",
      `${c.start_version ?? "—"} → ${c.parameter_version ?? "—"}`,
      numCell(c.residuals.before.rms_mm), numCell(c.residuals.after.rms_mm),
      h("span", {}, link(`#/calibrations/${c.id}`, "result"), " · ", link(`#/calibrations/${c.id}/report`, "report"))]), "calibrations");
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

// The structure's background build (service/compute/builds.py): a first request during it is slower once; code on
// CasADi's virtual machine is slower always, which the engineer should know before timing a cell.
function buildNote(robot) {
  const b = robot.build;
  if (!b) return muted("");
  if (b.state === "building") return muted("Preparing this structure's compiled code in the background…", "build-state");
  if (b.state === "failed") return h("p", { class: "error", id: "build-state" }, `Build failed: ${b.detail}`);
  const took = b.seconds == null ? "at start-up" : `in ${b.seconds.toFixed(1)} s`;
  return muted(b.native === false ? `Runs on CasADi's virtual machine (slower): ${b.detail}` : `Compiled code ready (${took}).`, "build-state");
}
