// Pose design: which poses to measure. A count or a target accuracy, the criterion and the measurement kind go
// to POST …/pose-designs as a job; the chosen poses come back as a table, a plot of their joint-space coverage
// and their TCP positions, and a CSV for the pendant (the robot's joint names as header).
import { api, query } from "../api.js";
import { jointsCsv } from "../csv.js";
import { drawCell, sceneOf } from "../cellplot.js";
import { download, errorBox, field, fill, h, link, muted, num, numCell, table, when } from "../dom.js";
import { fleetOrNull, fleetRefusal, priorSentence } from "./fleet.js";
import { framesOf, readCell } from "./cell.js";
import { watchJob } from "./jobs.js";

const FRAMES_MAX = 1000;
const PRIOR_OPTION = "Design for a calibration with the fleet's prior";

export async function designView(view, robotId, params) {
  // The criteria as the service lists them (GET /v1/design-criteria), never a copy kept here.
  const [robot, designs, fleet, criteria] = await Promise.all([api(`/v1/robots/${robotId}`), api(`/v1/robots/${robotId}/pose-designs`),
    fleetOrNull(robotId), api("/v1/design-criteria")]);
  const result = h("div", { id: "design-result" });
  fill(view, h("p", {}, link(`#/robots/${robotId}`, `← ${robot.name}`)), h("h1", {}, `Pose design for ${robot.name}`),
    designForm(robot, result, priorSentence(fleet, robotId), criteria),
    designs.length === 0 ? null : h("section", {}, h("h2", {}, "Earlier designs"),
      table(["when", "criterion", "poses", "measurement", ""], designs.map((d) => [when(d.created_at), d.criterion, numCell(d.count, 3), d.measurement,
        link(`#/robots/${robotId}/design?design=${d.id}`, "open")]), "earlier-designs")),
    result);
  if (params.get("design")) await showDesign(robot, await api(`/v1/pose-designs/${params.get("design")}`), result);
}

// `fleetNote`: whether the robot's fleet can give it a prior (docs/fleet.md); the service decides either way.
function designForm(robot, result, fleetNote, criteria) {
  const mode = h("select", { id: "design-mode" }, h("option", { value: "count" }, "a number of poses"), h("option", { value: "target" }, "a target accuracy"));
  const count = h("input", { id: "design-count", type: "number", min: 1, step: 1, value: 30 });
  const target = h("input", { id: "design-target", type: "number", min: 0, step: "any", value: 0.05 });
  const criterion = h("select", { id: "design-criterion" },
    criteria.map((c) => h("option", { value: c.name }, `${c.name}: ${c.summary}`)));
  const measurement = h("select", { id: "design-measurement" },
    [["pose", "full pose (tracker with 6-DoF probe)"], ["position", "position only (tracker reflector)"]].map(([v, t]) => h("option", { value: v }, t)));
  const candidates = h("input", { id: "design-candidates", type: "number", min: 10, step: 1, value: 2000 });
  const seed = h("input", { id: "design-seed", type: "number", step: 1, value: 0 });
  const prior = h("input", { type: "checkbox", id: "design-prior" });
  const inCell = h("input", { type: "checkbox", id: "design-cell" });
  const message = h("div", { id: "design-message" });
  const form = h("form", { id: "design-form" }, h("fieldset", {}, h("legend", {}, "Design"),
    h("div", { class: "row" }, field("Choose", mode), field("Poses", count), field("Predicted TCP error, RMS (mm)", target, "target mode"),
      field("Criterion", criterion), field("Measurement", measurement), field("Candidate poses sampled", candidates), field("Seed", seed)),
    h("label", {}, prior, ` ${PRIOR_OPTION} (its information joins the poses': a target counts the poses that calibration needs)`),
    muted(fleetNote, "design-prior-note"),
    h("label", {}, inCell, " In the robot's cell: only poses it can measure, collision-free and seen by its tracker (",
      link(`#/robots/${robot.id}/cell`, "the cell"), "; each check costs: a large design runs as a job)")),
  muted("Ballbar, point and plane designs need their anchors, points or planes: send those through the API (/docs)."),
  h("p", {}, h("button", { type: "submit", id: "design-submit" }, "Design the poses")), message);
  form.addEventListener("submit", async (event) => {
    event.preventDefault();
    message.replaceChildren();
    const body = { criterion: criterion.value, measurement: measurement.value, candidate_count: Number(candidates.value), seed: Number(seed.value) };
    if (mode.value === "count") body.count = Number(count.value);
    else body.target = { rms_tcp_mm: Number(target.value) };
    if (prior.checked) body.prior = "fleet";
    if (inCell.checked) body.cell = "stored";
    try {
      const accepted = await api(`/v1/robots/${robot.id}/pose-designs${query({ async: true })}`, { method: "POST", json: body });
      const job = await watchJob(accepted.job_id, message);
      if (job.status === "succeeded") await showDesign(robot, job.result, result);
      else if (job.status === "cancelled") message.append(h("p", { id: "job-cancelled" }, "The design was cancelled: nothing was stored."));
      else message.append(errorBox({ message: `${job.error.status}: ${job.error.detail}`, problem: job.error }, "design-error"), fleetRefusal(job.error, PRIOR_OPTION) || "");
    } catch (error) {
      fill(message, errorBox(error, "design-error"), fleetRefusal(error.problem, PRIOR_OPTION));
    }
  });
  return form;
}

// Each joint's reading range from the structure document: the serial links' `range`, a hexapod's strokes.
export function jointRanges(robot) {
  return robot.structure.stages.flatMap((stage) => {
    if (stage.kind === "serial") return stage.links.filter((l) => l.joint !== "fixed").map((l) => l.range);
    const strokes = Array.isArray(stage.strokes[0]) ? stage.strokes : Array(6).fill(stage.strokes);
    return strokes;
  });
}

export async function showDesign(robot, design, container) {
  const names = robot.joint_names;
  const m = design.metrics || {};
  fill(container, h("h2", { id: "design-heading" }, `${design.count} poses, ${design.criterion}-optimal, ${design.measurement} records`),
    h("dl", { class: "figures" },
      h("div", { class: "figure" }, h("dt", {}, "predicted TCP error, RMS"), h("dd", { id: "design-rms" }, `${num(m.predicted_rms_tcp_mm)} mm`)),
      h("div", { class: "figure" }, h("dt", {}, "predicted TCP error, max"), h("dd", {}, `${num(m.predicted_max_tcp_mm)} mm`)),
      h("div", { class: "figure" }, h("dt", {}, "random poses of the same count, RMS"), h("dd", {}, `${num(design.random_baseline && design.random_baseline.predicted_rms_tcp_mm)} mm`)),
      h("div", { class: "figure" }, h("dt", {}, "efficiency against the bound"), h("dd", {}, num(design.efficiency, 3))),
      h("div", { class: "figure" }, h("dt", {}, "identifiable parameters"), h("dd", {}, String((design.identifiable || []).length)))),
    (design.notes || []).length ? h("ul", {}, design.notes.map((n) => h("li", {}, n))) : null,
    h("p", {}, h("button", { type: "button", id: "design-download", onclick: () => download(`pose-design-${robot.name}-${design.id.slice(0, 8)}.csv`, jointsCsv(names, design.poses)) },
      "Download the poses as CSV (for the pendant)")));
  const plots = h("div", { class: "row", id: "design-plots" });
  container.append(plots);
  coveragePlot(plots, robot, design.poses);
  await tcpPlots(plots, robot, design.poses);
  if (design.cell) await cellSection(container, robot, design);
  container.append(h("div", { class: "scroll" }, table(["#", ...names.map((n, i) => `${n} (${robot.joint_units[i]})`)],
    design.poses.map((q, i) => [numCell(i + 1), ...q.map((v) => numCell(v, 6))]), "design-poses")));
}

// Joint-space coverage: every chosen reading as a share of its joint's range, one column per joint.
function coveragePlot(container, robot, poses) {
  const ranges = jointRanges(robot);
  const x = [], y = [];
  poses.forEach((q) => q.forEach((v, j) => {
    const [lo, hi] = ranges[j] || [0, 1];
    x.push(j + 1);
    y.push((100 * (v - lo)) / (hi - lo || 1));
  }));
  Plot.scatter(container, { id: "design-coverage", title: `joint-space coverage (1 = ${robot.joint_names[0]} … ${ranges.length} = ${robot.joint_names[ranges.length - 1]})`,
    xlabel: "joint", ylabel: "% of the joint's range", x, y });
}

async function tcpPlots(container, robot, poses) {
  const fk = await api(`/v1/robots/${robot.id}/forward-kinematics`, { method: "POST", json: { joints: poses } });
  const p = fk.poses.map((q) => q.position);
  Plot.scatter(container, { id: "design-top", title: "TCP seen from above", xlabel: "x (mm)", ylabel: "y (mm)", x: p.map((v) => v[0]), y: p.map((v) => v[1]) });
  Plot.scatter(container, { id: "design-side", title: "TCP seen from the side", xlabel: "x (mm)", ylabel: "z (mm)", x: p.map((v) => v[0]), y: p.map((v) => v[2]) });
}


// A design in the robot's cell: what the cell refused (counts by reason) among the candidates it checked, and the
// designed poses drawn in the cell (every TCP; the robot at the pose chosen).
async function cellSection(container, robot, design) {
  const c = design.cell;
  const refused = Object.entries(c.refused).sort((a, b) => b[1] - a[1]);
  const section = h("section", { id: "design-cell-result" }, h("h2", {}, "In the cell"),
    h("p", { id: "design-cell-summary" }, `${c.checked} candidates checked against ${c.version == null ? "the cell sent with the request" : `cell version ${c.version}`}: `
      + `${c.feasible} it can measure, ${c.checked - c.feasible} refused; the design chose among the feasible ones.`),
    refused.length ? table(["reason", "candidates refused"], refused.map(([r, n]) => [r, numCell(n)]), "design-refused", "Refused, by the first check each candidate fails") : null);
  container.append(section);
  const stored = c.version == null ? null : await readCell(robot.id, c.version);
  if (!stored) return section.append(muted("The cell was sent with the request, not stored: it is not drawn here.", "design-cell-undrawn"));
  const frames = await framesOf(robot.id, design.poses.slice(0, FRAMES_MAX));  // the API's bound on frames
  const choose = h("select", { id: "design-cell-pose", "aria-label": "pose drawn" }, frames.map((_, k) => h("option", { value: k }, `pose ${k + 1}`)));
  const views = h("div", { class: "row", id: "design-cell-views" });
  const points = frames.map((f) => f.tcp.position);
  const draw = () => drawCell(views, sceneOf(stored, frames[Number(choose.value)], { points, beamClass: "feasible" }), `design in cell version ${c.version}`);
  choose.addEventListener("change", draw);
  section.append(h("div", { class: "row" }, field("The robot drawn at", choose)), views,
    muted("Red dots: the TCP of every designed pose; the robot and the tracker's beam at the pose chosen."));
  draw();
}
