// A campaign to calibrate from: a CSV dropped or picked, a preview of its first rows with the columns the
// service will read, the noise, apply and fleet-prior options, then the calibration as a job with live progress and cancel.
// The file itself is sent (text/csv): the service's tolerant reader is the one that decides.
import { api, fieldErrors, query } from "../api.js";
import { readCsv } from "../csv.js";
import { errorBox, field, fill, h, link, muted, table } from "../dom.js";
import { watchJob } from "./jobs.js";
import { diagnosesList } from "./calibration.js";
import { fleetOrNull, fleetRefusal, priorSentence } from "./fleet.js";

const PREVIEW_ROWS = 8;

export async function campaignView(view, robotId) {
  const [robot, fleet] = await Promise.all([api(`/v1/robots/${robotId}`), fleetOrNull(robotId)]);
  const state = { text: null, name: null, bytes: null };
  const preview = h("div", { id: "campaign-preview" });
  const picker = filePicker("campaign-file", "Campaign CSV", async (file) => {
    state.bytes = await file.arrayBuffer();  // sent as they are: the service decodes Windows-1252 and UTF-16 too
    state.text = decoded(state.bytes);
    state.name = file.name;
    showPreview(preview, state, robot);
  });
  const options = optionsForm(priorSentence(fleet, robotId));
  const outcome = h("div", { id: "calibration-outcome" });
  const run = h("button", { type: "submit", id: "calibrate" }, "Calibrate");
  const form = h("form", { id: "campaign-form" }, picker, preview, options.node, h("p", {}, run), outcome);
  form.addEventListener("submit", async (event) => {
    event.preventDefault();
    if (!state.text) { fill(outcome, errorBox(new Error("choose or drop a campaign CSV first"))); return; }
    run.disabled = true;
    try {
      await calibrate(robotId, state.bytes, options.values(), outcome);
    } catch (error) {
      fill(outcome, errorBox(error, "calibration-error"));  // the job could not be followed (the API stopped answering)
    } finally {
      run.disabled = false;
    }
  });
  fill(view, h("p", {}, link(`#/robots/${robotId}`, `← ${robot.name}`)),
    h("h1", {}, `Calibrate ${robot.name}`),
    muted(`Joint columns this robot reads, in order: ${robot.joint_names.join(", ")} (${robot.joint_units.join(", ")}), `
      + "then x, y, z in mm and, for a full pose, qw, qx, qy, qz; optional sigma_mm or u95, temperature_c. "
      + "A robot from a URDF also reads its URDF's joint names; any other header, say which column is which below. "
      + "Rows of several points (x1, y1, z1, x2 …, a mocap body's markers) give the TCP's records (point 1) and a reflector record per other point."),
    form);
}

// The file's text for the preview, decoded as the service will: UTF-16 by its byte-order mark, UTF-8 when valid,
// else Windows-1252 (what tracker software on Windows writes).
function decoded(bytes) {
  const head = new Uint8Array(bytes.slice(0, 2));
  if ((head[0] === 0xff && head[1] === 0xfe) || (head[0] === 0xfe && head[1] === 0xff)) {
    return new TextDecoder(head[0] === 0xff ? "utf-16le" : "utf-16be").decode(bytes);
  }
  try { return new TextDecoder("utf-8", { fatal: true }).decode(bytes); } catch { return new TextDecoder("windows-1252").decode(bytes); }
}

// A drop zone around a file input: a file dropped on it is handled as one picked.
export function filePicker(id, label, onFile) {
  const input = h("input", { type: "file", id, accept: ".csv,.txt,text/csv" });
  const zone = h("div", { class: "drop-zone", id: `${id}-zone` }, field(label, input), h("span", { class: "muted" }, "or drop the file here"));
  input.addEventListener("change", () => input.files[0] && onFile(input.files[0]));
  zone.addEventListener("dragover", (e) => { e.preventDefault(); zone.classList.add("over"); });
  zone.addEventListener("dragleave", () => zone.classList.remove("over"));
  zone.addEventListener("drop", (e) => {
    e.preventDefault();
    zone.classList.remove("over");
    if (e.dataTransfer.files[0]) onFile(e.dataTransfer.files[0]);
  });
  return zone;
}

// The first rows as the service will read them: each header cell says what its column is read as.
export function showPreview(container, state, robot) {
  let csv;
  try { csv = readCsv(state.text); } catch (error) { fill(container, errorBox(error, "preview-error")); return null; }
  const described = (c) => h("span", {}, c, csv.units[c] ? ` [${csv.units[c]}]` : "", h("br"), h("small", { class: `role role-${csv.roles[c] === "ignored" ? "ignored" : "read"}` }, csv.roles[c]));
  const ignored = csv.columns.filter((c) => csv.roles[c] === "ignored");
  const notes = [`${csv.rows.length} records in ${state.name}; delimiter ${JSON.stringify(csv.delimiter)}${csv.decimalComma ? ", decimal commas" : ""}.`];
  if (csv.joints.length && csv.joints.length !== robot.joint_names.length) {
    notes.push(`The file has ${csv.joints.length} joint columns (${csv.joints.join(", ")}); ${robot.name} has ${robot.joint_names.length}: the service will refuse it.`);
  }
  if (ignored.length) notes.push(`Not read: ${ignored.join(", ")}.`);
  fill(container, h("h2", {}, "Preview"), h("ul", { id: "preview-notes" }, notes.map((n) => h("li", {}, n))),
    h("div", { class: "scroll" }, table(csv.columns.map(described), csv.rows.slice(0, PREVIEW_ROWS).map((r) => r.cells), "preview-table",
      `The first ${Math.min(PREVIEW_ROWS, csv.rows.length)} of ${csv.rows.length} rows`)));
  return csv;
}

// `fleetNote`: whether the fleet can give this robot a prior; the option is offered either way and the service decides.
function optionsForm(fleetNote) {
  const position = h("input", { id: "noise-position", type: "number", step: "any", min: 0, value: 0.025 });
  const orientation = h("input", { id: "noise-orientation", type: "number", step: "any", min: 0, value: 0.01 });
  const unit = h("select", { id: "length-unit" }, ["mm", "m", "cm", "um", "in"].map((u) => h("option", { value: u }, u)));
  const order = h("select", { id: "quaternion-order" }, ["wxyz", "xyzw"].map((u) => h("option", { value: u }, u)));
  const columns = h("input", { id: "column-map", size: 50, autocomplete: "off", placeholder: "Achse 1=joint_1, Achse 2=joint_2, X_m=x" });
  const jointUnit = h("select", { id: "joint-unit" }, [["", "as the header says (default degrees)"], ["deg", "degrees"], ["rad", "radians"]]
    .map(([value, text]) => h("option", { value }, text)));
  const apply = h("input", { type: "checkbox", id: "apply", checked: true });
  const prior = h("input", { type: "checkbox", id: "fleet-prior-option" });
  const node = h("fieldset", { id: "calibration-options" }, h("legend", {}, "Options"),
    h("div", { class: "row" },
      field("Instrument σ, position (mm)", position), field("σ, orientation (deg)", orientation),
      field("Length unit where the header states none (points, σ, prismatic joints)", unit), field("Order of q0…q3 columns", order)),
    h("div", { class: "row" },
      field("Column map (file column = joint or coordinate)", columns, "joints: this robot's names; coordinates: x, y, z, qw…, pose_id, sigma_mm, u95, temperature_c, time; x2, y2, z2 … a row's further points (reflector records)"),
      field("Revolute joints' unit where the header states none", jointUnit)),
    h("label", {}, apply, " Apply the result as the robot's new version when its checks pass"), h("br"),
    h("label", {}, prior, " Calibrate with the fleet's prior (the population of the other calibrated robots of this structure: fewer poses for the same accuracy)"),
    muted(fleetNote, "fleet-prior-note"));
  const values = () => ({
    noise_position_mm: position.value, noise_orientation_deg: orientation.value,
    length_unit: unit.value, quaternion_order: order.value, apply: apply.checked, prior: prior.checked ? "fleet" : null,
    columns: columns.value.trim() || null, joint_unit: jointUnit.value || null,
  });
  return { node, values };
}

// Submits the CSV (its bytes) as a job, follows it, and opens the stored result; a refusal before any fit stays here.
async function calibrate(robotId, text, options, outcome) {
  fill(outcome, muted("Sending the campaign…"));
  let accepted;
  try {
    accepted = await api(`/v1/robots/${robotId}/calibrations${query({ async: true, ...options })}`,
      { method: "POST", body: text, type: "text/csv" });
  } catch (error) {
    fill(outcome, refusal(error.message, error.problem));
    return;
  }
  const job = await watchJob(accepted.job_id, outcome);
  if (job.status === "succeeded") { location.hash = `#/calibrations/${job.result.id}`; return; }
  if (job.status === "failed" && job.error && job.error.calibration_id) { location.hash = `#/calibrations/${job.error.calibration_id}`; return; }
  outcome.append(job.status === "cancelled" ? h("p", { id: "job-cancelled" }, "The calibration was cancelled: nothing was stored.")
    : refusal(`${job.error ? job.error.status : ""}: ${job.error ? job.error.detail : "the job failed"}`, job.error));
}

// A refusal in words: the problem's detail, each invalid field, and the diagnoses the service found.
function refusal(text, problem) {
  const fields = fieldErrors(problem);
  return h("div", { class: "error refusal", id: "calibration-refused", role: "alert" },
    h("h3", {}, "The service refused the campaign"), h("p", {}, text),
    fields.length ? h("ul", {}, fields.map((f) => h("li", {}, f))) : null, fleetRefusal(problem), diagnosesList(problem && problem.diagnoses));
}
