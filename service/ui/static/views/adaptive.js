// Adaptive campaigns (docs/pose-design.md "Adaptive campaigns"): one pose at a time until the predicted accuracy
// reaches the target. The start form (from the robot's page) posts the settings; the campaign's page, drawn from
// GET …/adaptive-campaigns/{id} alone so a reload resumes it, shows the poses to measure now (a CSV in the
// calibration upload's layout, measurement columns empty), takes the records measured at them (that CSV filled
// in, or JSON), and shows every step: the predicted accuracy against the target, the blunders flagged and why,
// done and why. Finishing stores a calibration through the calibration path and opens it.
import { api } from "../api.js";
import { normalise, readCsv, trackerRecords } from "../csv.js";
import { download, errorBox, field, fill, h, link, muted, num, numCell, statusBadge, table, when } from "../dom.js";
import { readCell } from "./cell.js";

const TARGETS = [["rms_tcp_mm", "RMS over the workspace"], ["max_tcp_mm", "at the worst workspace pose"]];
const TARGET_WORDS = Object.fromEntries(TARGETS);
const QUATERNION = ["qw", "qx", "qy", "qz"];

const base = (robotId) => `/v1/robots/${robotId}/adaptive-campaigns`;
const pageOf = (robotId, id) => `#/robots/${robotId}/adaptive/${id}`;
// The page numbers records from 1 in the order posted; the API's `record` indexes count from 0.
const recordNo = (index) => index + 1;

// The robot's campaigns, oldest first, each where it stands (the robot's page and the start page).
export function campaignsTable(robotId, campaigns) {
  if (campaigns.length === 0) return muted("No adaptive campaign yet.", "adaptive-none");
  return table(["started", "status", "target (mm)", "records / budget", "predicted now (mm)", "why it stopped", ""],
    campaigns.map((c) => [when(c.created_at), statusBadge(c.status), `${c.target_mm} (${c.target === "rms_tcp_mm" ? "RMS" : "max"})`,
      `${c.records} / ${c.budget}`, numCell(c.predicted && c.predicted[c.target]), c.reason || "—",
      h("span", {}, link(pageOf(robotId, c.id), "open"),
        c.calibration_id ? h("span", {}, " · ", link(`#/calibrations/${c.calibration_id}`, "calibration")) : null)]),
    "adaptive-campaigns");
}

export async function adaptiveStartView(view, robotId) {
  // The criteria as the service lists them (GET /v1/adaptive-criteria), never a copy kept here.
  const [robot, campaigns, cellSchema, cell, criteria] = await Promise.all([api(`/v1/robots/${robotId}`),
    api(base(robotId)), createTakesCell(), readCell(robotId), api("/v1/adaptive-criteria")]);
  fill(view, h("p", {}, link(`#/robots/${robotId}`, `← ${robot.name}`)), h("h1", {}, `Adaptive campaign for ${robot.name}`),
    muted("The campaign asks for a few poses, re-identifies the robot from each record posted, and asks for the pose "
      + "that improves the predicted accuracy most, until it reaches the target or the pose budget is spent. A record "
      + "far off the others is flagged as a blunder, left out, and its pose asked for again."),
    startForm(robot, cellSchema, cell, criteria), h("h2", {}, "Campaigns"), campaignsTable(robotId, campaigns));
}

// Whether this service's create body takes `cell` (its OpenAPI document says): the box is offered only then.
async function createTakesCell() {
  try {
    const doc = await api("/openapi.json");
    return ((doc.components.schemas.AdaptiveCampaignCreate || {}).properties || {}).cell || null;
  } catch (_) {
    return null;  // no document (or none readable): no cell option, the campaign works without it
  }
}

// The value that asks for the robot's stored cell: "stored", as a pose design takes it, unless the declared schema
// is a plain boolean.
function storedCellValue(schema) {
  return schema.type === "boolean" ? true : "stored";
}

function cellOption(robot, schema, cell) {
  if (!schema) return { node: null, value: () => undefined };
  if (!cell) {
    return { node: muted(["This robot has no cell: the candidates are not checked against one (", link(`#/robots/${robot.id}/cell`, "the cell"), ")."], "adaptive-no-cell"), value: () => undefined };
  }
  const box = h("input", { type: "checkbox", id: "adaptive-cell", checked: true });
  const node = h("label", {}, box, ` In the robot's cell (version ${cell.version}): only poses it can measure, collision-free and seen by its tracker (`,
    link(`#/robots/${robot.id}/cell`, "the cell"), ")");
  return { node, value: () => (box.checked ? storedCellValue(schema) : undefined) };
}

function startForm(robot, cellSchema, cell, criteria) {
  const input = (id, value, attrs = {}) => h("input", { id, type: "number", step: "any", value, ...attrs });
  const controls = {
    target_mm: input("adaptive-target", 0.05, { min: 0 }), budget: input("adaptive-budget", 60, { min: 1, step: 1 }),
    candidate_count: input("adaptive-candidates", 500, { min: 20, step: 1 }), seed: input("adaptive-seed", 0, { min: 0, step: 1 }),
    position_mm: input("adaptive-sigma-position", 0.025, { min: 0 }), orientation_deg: input("adaptive-sigma-orientation", 0.01, { min: 0 }),
  };
  const target = h("select", { id: "adaptive-target-key" }, TARGETS.map(([v, t]) => h("option", { value: v }, t)));
  const measurement = h("select", { id: "adaptive-measurement" },
    [["pose", "full pose (tracker with 6-DoF probe)"], ["position", "position only (tracker reflector)"]].map(([v, t]) => h("option", { value: v }, t)));
  const criterion = h("select", { id: "adaptive-criterion" }, criteria.map((c) =>
    h("option", { value: c.name, selected: c.default || null }, `${c.name}: ${c.summary}`)));
  const inCell = cellOption(robot, cellSchema, cell);
  const message = h("div", { id: "adaptive-start-message" });
  const submit = h("button", { type: "submit", id: "adaptive-start" }, "Start the campaign");
  const form = h("form", { id: "adaptive-form" }, h("fieldset", {}, h("legend", {}, "Start"),
    h("div", { class: "row" }, field("Predicted TCP error to reach (mm)", controls.target_mm), field("Which error", target),
      field("Pose budget (records)", controls.budget), field("Measurement", measurement), field("Next pose by", criterion)),
    h("div", { class: "row" }, field("Candidate poses sampled", controls.candidate_count), field("Seed", controls.seed),
      field("Instrument σ, position (mm)", controls.position_mm), field("σ, orientation (deg)", controls.orientation_deg)),
    inCell.node), h("p", {}, submit), message);
  form.addEventListener("submit", async (event) => {
    event.preventDefault();
    const n = (k) => Number(controls[k].value);
    const body = { target_mm: n("target_mm"), target: target.value, budget: n("budget"), measurement: measurement.value,
      criterion: criterion.value, candidate_count: n("candidate_count"), seed: n("seed"),
      noise: { position_mm: n("position_mm"), orientation_deg: n("orientation_deg") } };
    if (inCell.value() !== undefined) body.cell = inCell.value();
    submit.disabled = true;
    fill(message, muted("Sampling the candidates and choosing the first poses…"));
    try {
      const made = await api(base(robot.id), { method: "POST", json: body });
      location.hash = pageOf(robot.id, made.id);
    } catch (error) {
      fill(message, errorBox(error, "adaptive-start-error"));
    } finally {
      submit.disabled = false;
    }
  });
  return form;
}

export async function adaptiveCampaignView(view, robotId, campaignId) {
  const [robot, campaign] = await Promise.all([api(`/v1/robots/${robotId}`), api(`${base(robotId)}/${campaignId}`)]);
  const redraw = async (note) => {
    await adaptiveCampaignView(view, robotId, campaignId);
    if (note) view.querySelector("#adaptive-posted").replaceChildren(note);
  };
  fill(view, h("p", {}, link(`#/robots/${robotId}`, `← ${robot.name}`), " · ", link(`#/robots/${robotId}/adaptive`, "all adaptive campaigns")),
    h("h1", {}, `Adaptive campaign ${campaign.id.slice(0, 8)} for ${robot.name}`),
    h("div", { id: "adaptive-state", "data-steps": campaign.steps.length, "data-status": campaign.status },
      summary(campaign), h("div", { id: "adaptive-posted" }), outcome(campaign),
      campaign.status === "measuring" ? measureSection(robot, campaign, redraw) : null,
      h("h2", {}, "Predicted accuracy against the target"), chart(campaign),
      h("h2", {}, "Blunders"), blundersTable(campaign),
      h("h2", {}, "Every step"), stepsTable(campaign),
      finishSection(robot, campaign, redraw)));
}

function figure(label, value, id) {
  return h("div", { class: "figure" }, h("dt", {}, label), h("dd", { id }, value));
}

function summary(c) {
  const predicted = c.predicted ? c.predicted[c.target] : null;
  return h("dl", { class: "figures", id: "adaptive-summary" },
    figure("status", statusBadge(c.status), "adaptive-status"),
    figure(`target, ${TARGET_WORDS[c.target]}`, `${c.target_mm} mm`, "adaptive-target-value"),
    figure("predicted now", predicted == null ? "— (nothing identified yet)" : `${num(predicted)} mm`, "adaptive-predicted"),
    figure("records / budget", `${c.records} / ${c.budget}`, "adaptive-count"),
    figure("reachable with every candidate", `${num(c.reachable_mm)} mm`),
    figure("measurement · next pose by", `${c.measurement} · ${c.criterion}`),
    figure("candidates · started from version", `${c.candidates} · ${c.version}`));
}

// Done and why; finished with its calibration; ended without one.
function outcome(c) {
  if (c.status === "measuring") return null;
  const calibration = c.calibration_id ? h("p", {}, link(`#/calibrations/${c.calibration_id}`, "The calibration it stored", { id: "adaptive-calibration" })) : null;
  const words = { done: "Done", finished: "Finished", ended: "Ended without a calibration" }[c.status];
  return h("div", { class: "verdict applied", id: "adaptive-done" }, h("h2", {}, words),
    h("p", { id: "adaptive-reason" }, c.reason || "ended before the campaign was done"), calibration);
}

// The poses to measure now: a table, a copy button and the CSV to fill in (the calibration upload's layout).
function measureSection(robot, c, redraw) {
  const names = robot.joint_names;
  const csv = posesCsv(names, c.next, c.measurement);
  const said = h("span", { id: "adaptive-copied", class: "muted" });
  const copy = h("button", { type: "button", id: "adaptive-copy", onclick: () => copyText(csv, said, c.next.length) }, "Copy the poses (CSV)");
  const save = h("button", { type: "button", id: "adaptive-download",
    onclick: () => download(`adaptive-${robot.name}-${c.id.slice(0, 8)}-step-${c.steps.length + 1}.csv`, csv) }, "Download them as CSV to fill in");
  return h("section", { id: "adaptive-measure" }, h("h2", {}, `Measure now: ${c.next.length} pose${c.next.length === 1 ? "" : "s"}`),
    h("div", { class: "scroll" }, table(["#", ...names.map((n, i) => `${n} (${robot.joint_units[i]})`), "why this pose"],
      c.next.map((p, k) => [numCell(k + 1), ...p.joints.map((v) => numCell(v, 6)),
        p.replaces == null ? `candidate ${p.candidate}` : `again: record ${recordNo(p.replaces)} was a blunder`]), "adaptive-next")),
    h("p", {}, copy, " ", save, " ", said),
    muted(`Measure each pose, fill its ${c.measurement === "pose" ? "x, y, z (mm) and qw, qx, qy, qz" : "x, y, z (mm)"} in, and post the file below.`),
    recordsForm(robot, c, redraw));
}

// The joints in the API's units with the measurement columns left empty: the layout a calibration upload reads.
function posesCsv(names, poses, measurement) {
  const columns = [...names, "x", "y", "z", ...(measurement === "pose" ? QUATERNION : [])];
  const empty = columns.length - names.length;
  const rows = poses.map((p) => [...p.joints.map((v) => Number(v).toFixed(6)), ...Array(empty).fill("")].join(","));
  return [columns.join(","), ...rows].join("\n") + "\n";
}

async function copyText(text, said, count) {
  try {
    await navigator.clipboard.writeText(text);
  } catch (_) {
    // Without a secure context (http to a plant host) the clipboard API is absent: copy a selected text instead.
    const area = h("textarea", { style: "position:fixed;opacity:0" }, text);
    document.body.append(area);
    area.select();
    document.execCommand("copy");
    area.remove();
  }
  said.textContent = `${count} pose${count === 1 ? "" : "s"} copied`;
}

function recordsForm(robot, c, redraw) {
  const text = h("textarea", { id: "adaptive-records", rows: 8, spellcheck: "false",
    placeholder: `${robot.joint_names.join(",")},x,y,z${c.measurement === "pose" ? ",qw,qx,qy,qz" : ""}\n… one row per pose measured, or JSON: [{"joints": […], "position": […]${c.measurement === "pose" ? ', "orientation": […]' : ""}}]` });
  const file = h("input", { type: "file", id: "adaptive-file", accept: ".csv,.txt,.json,text/csv,application/json" });
  file.addEventListener("change", async () => { if (file.files[0]) text.value = await file.files[0].text(); });
  const message = h("div", { id: "adaptive-post-message" });
  const submit = h("button", { type: "submit", id: "adaptive-post" }, "Post the records");
  const form = h("form", { id: "adaptive-records-form" }, h("fieldset", {}, h("legend", {}, "The records measured"),
    field("A CSV or JSON file", file, "its text goes in the box below"), h("br"),
    field("Or paste them: CSV (a header, one row per pose) or JSON", text)), h("p", {}, submit), message);
  form.addEventListener("submit", async (event) => {
    event.preventDefault();
    submit.disabled = true;
    try {
      const measurements = recordsOf(text.value, robot);
      fill(message, muted(`Identifying the robot from ${c.records + measurements.length} records…`));
      const step = await postRecords(robot.id, c, measurements);
      await redraw(stepNote(step));
    } catch (error) {
      fill(message, errorBox(error, "adaptive-post-error"));
    } finally {
      submit.disabled = false;
    }
  });
  return form;
}

// Records from the text: JSON (an array of records, or an object with `measurements`) or a CSV read by the
// campaign reader's rules (csv.js), whose joint columns may also be the robot's own joint names.
export function recordsOf(text, robot) {
  const trimmed = text.replace(/^\ufeff/, "").trim();
  if (!trimmed) throw new Error("no records: paste or load the measured poses first");
  if (/^[[{]/.test(trimmed)) {
    let data;
    try { data = JSON.parse(trimmed); } catch (error) { throw new Error(`the records are not valid JSON: ${error.message}`); }
    const rows = Array.isArray(data) ? data : data.measurements;
    if (!Array.isArray(rows)) throw new Error("JSON records: an array of records, or an object with `measurements`");
    return rows;
  }
  const csv = readCsv(trimmed);
  const own = robot.joint_names.map(normalise);
  if (own.every((n) => csv.columns.includes(n))) csv.joints = own;
  return trackerRecords(csv);
}

// A retry of the same records at the same step replays the service's answer (Idempotency-Key) instead of posting
// them twice; other records at that step get another key.
function postRecords(robotId, c, measurements) {
  const body = JSON.stringify({ measurements });
  const key = `adaptive-${c.id}-step-${c.steps.length + 1}-${fnv1a(body)}`;
  return api(`${base(robotId)}/${c.id}/records`, { method: "POST", body, type: "application/json", headers: { "Idempotency-Key": key } });
}

// 32-bit FNV-1a of the body: a key per content (crypto.subtle needs a secure context, which a plant host may lack).
function fnv1a(text) {
  let hash = 0x811c9dc5;
  for (let i = 0; i < text.length; i++) hash = Math.imul(hash ^ text.charCodeAt(i), 0x01000193) >>> 0;
  return hash.toString(16).padStart(8, "0");
}

function stepNote(step) {
  const flagged = step.blunders.map((b) => `record ${recordNo(b.record)}`);
  const predicted = step.predicted ? `predicted RMS ${num(step.predicted.rms_tcp_mm)} mm, max ${num(step.predicted.max_tcp_mm)} mm` : "not identified yet";
  return h("p", { id: "adaptive-step-note", class: "muted" }, `Step ${step.number}: ${step.posted} record${step.posted === 1 ? "" : "s"} posted (${step.records} so far), `
    + `${predicted}${flagged.length ? `; flagged as a blunder: ${flagged.join(", ")}` : ""}${step.done ? `; done: ${step.reason}` : ""}.`);
}

// The predicted error (the target's kind) after each identified step, against the target: records on x.
function chart(c) {
  const steps = c.steps.filter((s) => s.predicted);
  const container = h("div", { id: "adaptive-chart" });
  if (steps.length === 0) return muted("Nothing predicted yet: the first records identify the robot.", "adaptive-chart");
  Plot.series(container, {
    id: "adaptive-plot", title: `predicted TCP error (${TARGET_WORDS[c.target]}) after each step, against the target`,
    xlabel: "records measured", ylabel: "mm", x: steps.map((s) => s.records), labels: steps.map((s) => `step ${s.number}`),
    series: [{ name: "predicted (mm)", values: steps.map((s) => s.predicted[c.target]) },
      { name: `target ${c.target_mm} mm`, values: steps.map(() => c.target_mm) }],
  });
  return container;
}

// Each flagged record and why: its studentized residual against the threshold, and how far off it was.
function blundersTable(c) {
  const rows = c.steps.flatMap((s) => s.blunders.map((b) => [numCell(recordNo(b.record)), numCell(s.number), numCell(b.statistic),
    numCell(b.threshold), numCell(b.position_mm),
    `rᵀ(I − H)⁻¹r = ${num(b.statistic)} > ${num(b.threshold)}: ${num(b.position_mm)} mm off the estimate of the other records; left out, its pose asked again`]));
  if (rows.length === 0) return muted("No record flagged.", "adaptive-no-blunders");
  return table(["record no.", "flagged at step", "statistic", "threshold", "off by (mm)", "why"], rows, "adaptive-blunders",
    "Records are numbered from 1 in the order posted; a flagged record is left out of every later fit");
}

function stepsTable(c) {
  if (c.steps.length === 0) return muted("No records posted yet.", "adaptive-no-steps");
  return h("div", { class: "scroll" }, table(["step", "posted", "records", "predicted RMS (mm)", "predicted max (mm)",
    "fit RMS residual (mm)", "blunders", "excluded so far", "next", "done", "s"], c.steps.map((s) => [numCell(s.number), numCell(s.posted), numCell(s.records),
    numCell(s.predicted && s.predicted.rms_tcp_mm), numCell(s.predicted && s.predicted.max_tcp_mm),
    numCell(s.estimate && s.estimate.rms_residual_mm), s.blunders.map((b) => recordNo(b.record)).join(", "),
    s.excluded.map(recordNo).join(", "), numCell(s.next.length), s.done ? `yes: ${s.reason}` : "no", numCell(s.seconds, 2)]), "adaptive-steps"));
}

// Finish: a calibration of the records but the blunders (its checks decide whether it is applied), then its page;
// or end the campaign without one.
function finishSection(robot, c, redraw) {
  if (c.status === "finished" || c.status === "ended") return null;
  const apply = h("input", { type: "checkbox", id: "adaptive-apply", checked: true });
  const message = h("div", { id: "adaptive-finish-message" });
  const finish = async (calibrate) => {
    fill(message, muted(calibrate ? "Calibrating from the campaign's records…" : "Ending the campaign…"));
    try {
      const done = await api(`${base(robot.id)}/${c.id}/finish`, { method: "POST", json: { calibrate, apply: apply.checked } });
      if (done.calibration_id) location.hash = `#/calibrations/${done.calibration_id}`;
      else await redraw(null);
    } catch (error) {
      fill(message, errorBox(error, "adaptive-finish-error"));
    }
  };
  return h("section", { id: "adaptive-finish-section" }, h("h2", {}, "Finish"),
    muted(c.status === "done" ? "The campaign is done: calibrate from its records." : "Finishing now stops the campaign before it is done."),
    h("label", {}, apply, " Apply the result as the robot's new version when its checks pass"),
    h("p", {}, h("button", { type: "button", id: "adaptive-finish", onclick: () => finish(true) }, "Finish: calibrate from these records (blunders left out)"),
      " ", h("button", { type: "button", id: "adaptive-end", onclick: () => finish(false) }, "End without a calibration")), message);
}
