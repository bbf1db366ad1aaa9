// A robot's cell (#/robots/{id}/cell): the obstacles, the tracker with its range and the robot's links at a pose,
// drawn from above, the side and the front; its versions; a new version uploaded as JSON (PUT with If-Match)
// or the cell ended; a list of poses checked against it, each verdict drawable. Every shape's place is the
// API's: the document's obstacles, GET …/cell's geometry on the frames of POST …/forward-kinematics.
import { api, ApiError, query } from "../api.js";
import { drawCell, sceneOf } from "../cellplot.js";
import { readJointVectors } from "../csv.js";
import { errorBox, field, fill, h, link, muted, num, numCell, table, when } from "../dom.js";
import { jointRanges } from "./design.js";

const EXAMPLE = { obstacles: [{ name: "table", kind: "box", size_mm: [1500, 1500, 40], position_mm: [0, 0, -21] }],
  tracker: { position_mm: [2500, 0, 600], acceptance_deg: 60 }, clearance_mm: 10 };

// The stored cell (a past version with `version`), or null where the robot has none (404).
export async function readCell(robotId, version) {
  try {
    return await api(`/v1/robots/${robotId}/cell${query({ version })}`);
  } catch (error) {
    if (error instanceof ApiError && error.status === 404) return null;
    throw error;
  }
}

// Every frame of each joint vector (mm, degrees), from the API: name → {position, orientation} per vector.
export async function framesOf(robotId, joints) {
  return (await api(`/v1/robots/${robotId}/forward-kinematics`, { method: "POST", json: { joints, frames: true } })).frames;
}

export async function cellView(view, robotId, params) {
  const version = params.get("version") ? Number(params.get("version")) : null;
  const [response, versions, stored] = await Promise.all([api(`/v1/robots/${robotId}`, { raw: true }),
    api(`/v1/robots/${robotId}/cell/versions?limit=1000`), readCell(robotId, version)]);
  const robot = await response.json();
  const etag = response.headers.get("ETag");
  const drawing = h("div", { id: "cell-drawing" });
  fill(view, h("p", {}, link(`#/robots/${robotId}`, `← ${robot.name}`)), h("h1", {}, `The cell of ${robot.name}`),
    statusLine(stored, versions, version),
    stored ? drawing : muted("Nothing to draw: upload a cell document below.", "cell-empty"),
    h("h2", {}, "Versions"), versionsTable(robotId, versions),
    h("h2", {}, "Edit the cell"), editSection(robot, stored, etag),
    stored && !version ? checkSection(robot, stored, drawing) : null);
  if (stored) await drawingSection(drawing, robot, stored);
}

function statusLine(stored, versions, asked) {
  const last = versions[versions.length - 1];
  if (!stored && last && last.ended && !asked) return muted(`Version ${last.version} ended the cell (${when(last.created_at)}): designs and checks have none.`, "cell-status");
  if (!stored) return muted("This robot has no cell yet.", "cell-status");
  const what = `${stored.cell.obstacles.length} obstacles; instruments: ${instrumentNames(stored.cell).join(", ") || "none"}`;
  const current = asked ? ` (a past version: the current one is ${last ? last.version : "—"})` : " (current)";
  return h("p", { id: "cell-status" }, `Version ${stored.version}${current}, stored ${when(stored.created_at)} by ${stored.actor || "—"}: ${what}; `,
    `clearance ${num(stored.cell.clearance_mm)} mm; the links' shapes from ${stored.geometry_source === "urdf" ? "the URDF" : "the link lengths"}.`);
}

const instrumentNames = (cell) => ["tracker", "camera", "ballbar"].filter((k) => cell[k]);

function versionsTable(robotId, versions) {
  if (versions.length === 0) return muted("No version yet.", "cell-versions");
  return table(["version", "when", "by", "obstacles", "instruments", ""], versions.map((v) => [numCell(v.version), when(v.created_at), v.actor || "—",
    v.ended ? "—" : numCell(v.obstacles), v.ended ? "ended the cell" : v.instruments.join(", ") || "none",
    v.ended ? "" : link(`#/robots/${robotId}/cell?version=${v.version}`, "draw")]), "cell-versions");
}

// Mid-range joints (degrees and mm, the API's units): something to draw before any pose is checked; the page
// does not claim the cell allows it (the check does).
function middlePose(robot) { return jointRanges(robot).map(([lo, hi]) => (lo + hi) / 2); }

async function drawingSection(container, robot, stored) {
  const pose = h("input", { id: "cell-pose", type: "text", size: 48, value: middlePose(robot).map((v) => +v.toFixed(3)).join(", ") });
  const views = h("div", { class: "row", id: "cell-views" });
  const caption = h("p", { id: "cell-drawn", class: "muted" });
  const message = h("div", { id: "cell-pose-message" });
  const draw = async (joints, verdict) => {
    pose.value = joints.join(", ");
    await drawPose(views, caption, robot, stored, joints, verdict);
  };
  container.drawPose = draw;  // the check's rows draw their pose here
  const button = h("button", { type: "button", id: "cell-draw" }, "Draw the robot at these joints");
  button.addEventListener("click", async () => {
    message.replaceChildren();
    try { await draw(readJointVectors(pose.value, robot.joint_names)[0]); } catch (error) { fill(message, errorBox(error, "cell-pose-error")); }
  });
  fill(container, h("h2", {}, "The cell drawn"), h("div", { class: "row" }, field(`Joints (${robot.joint_units.join(", ")})`, pose), button), message,
    views, caption, h("h2", {}, "Obstacles and instruments"), obstaclesTable(stored.cell), instrumentsTable(stored.cell),
    h("h2", {}, "The robot's shapes"), geometryTable(stored));
  await draw(readJointVectors(pose.value, robot.joint_names)[0]);
}

async function drawPose(views, caption, robot, stored, joints, verdict) {
  const [frames] = await framesOf(robot.id, [joints]);
  const beamClass = verdict ? (verdict.feasible ? "feasible" : "refused") : "";
  drawCell(views, sceneOf(stored, frames, { beamClass }), `cell version ${stored.version}`);
  const said = verdict ? ` — ${verdict.feasible ? "feasible" : `refused: ${verdict.reason} (${verdict.detail})`}` : "";
  caption.textContent = `The robot at ${joints.map((v) => +Number(v).toFixed(3)).join(", ")} (TCP at ${frames.tcp.position.map((v) => v.toFixed(1)).join(", ")} mm)${said}. `
    + "Dashed circles: the tracker's range (least and most); the line: its beam to the reflector.";
  views.dataset.pose = JSON.stringify(joints);
}

const vec = (v) => (v ? v.map((x) => num(x, 5)).join(", ") : "—");

function sizeOf(o) {
  if (o.kind === "box") return `${vec(o.size_mm)} mm`;
  if (o.kind === "mesh") return `${o.faces.length} triangles`;
  return `r ${num(o.radius_mm)} mm${o.length_mm ? `, length ${num(o.length_mm)} mm` : ""}`;
}

function obstaclesTable(cell) {
  if (cell.obstacles.length === 0) return muted("No obstacle.", "cell-obstacles");
  return table(["name", "kind", "centre (mm)", "rotation vector (°)", "size"], cell.obstacles.map((o) => [o.name, o.kind,
    vec(o.position_mm), vec(o.rotation_vector_deg), sizeOf(o)]), "cell-obstacles");
}

function instrumentsTable(cell) {
  const rows = [];
  const t = cell.tracker;
  if (t) rows.push(["tracker", vec(t.position_mm), `range ${num(t.range_min_mm)}–${num(t.range_max_mm)} mm, reflector cone ±${num(t.acceptance_deg)}°, facing ${vec(t.reflector.facing)} at ${vec(t.reflector.offset_mm)} mm on the TCP, beam clearance ${num(t.beam_clearance_mm)} mm`]);
  const c = cell.camera;
  if (c) rows.push(["camera", vec(c.position_mm), `field ±${num(c.half_width_deg)}° × ±${num(c.half_height_deg)}°, depth ${num(c.range_min_mm)}–${num(c.range_max_mm)} mm`]);
  const b = cell.ballbar;
  if (b) rows.push(["ballbar", vec(b.pivot_mm), `length ${num(b.length_min_mm)}–${num(b.length_max_mm)} mm`]);
  return rows.length ? table(["instrument", "at (mm)", "what it sees"], rows, "cell-instruments") : muted("No instrument.", "cell-instruments");
}

function geometryTable(stored) {
  return table(["body", "from", "kind", "radius (mm)", "between frames, or in frame"], stored.geometry.map((g) => [g.body, g.origin, g.kind,
    g.radius_mm == null ? (g.size_mm ? `box ${vec(g.size_mm)}` : "—") : numCell(g.radius_mm), g.from_frame ? `${g.from_frame} → ${g.to_frame}` : g.frame]), "cell-geometry");
}

// A new version from a JSON document (typed or a file), PUT with the robot's ETag as read; or the cell ended.
function editSection(robot, stored, etag) {
  const text = h("textarea", { id: "cell-document", rows: 14, cols: 100, spellcheck: "false" }, documentText(stored ? stored.cell : EXAMPLE));
  const file = h("input", { type: "file", id: "cell-file", accept: ".json,application/json" });
  file.addEventListener("change", async () => { if (file.files[0]) text.value = await file.files[0].text(); });
  const message = h("div", { id: "cell-message" });
  const save = h("button", { type: "button", id: "cell-save" }, "Store as a new version");
  save.addEventListener("click", () => write(robot.id, message, () => {
    let doc;
    try { doc = JSON.parse(text.value); } catch (error) { throw new Error(`the cell document is not valid JSON: ${error.message}`); }
    return api(`/v1/robots/${robot.id}/cell`, { method: "PUT", json: doc, raw: true, headers: ifMatch(etag) });
  }));
  return h("section", {}, muted("The cell document in mm and degrees (docs/pose-design.md, \"The cell over HTTP\"): obstacles, tracker, camera, ballbar, links, clearance_mm, allowed. "
    + "Storing it makes a new version; the robot must not have changed since this page read it."),
  h("div", { class: "row" }, field("Or load a JSON file", file)), text, h("p", {}, save, " ", stored ? endButton(robot, etag, message) : null), message);
}

// Indented JSON with each vector of numbers on one line ("size_mm": [1500, 1500, 40]): a person edits it.
function documentText(doc) {
  return JSON.stringify(doc, null, 2).replace(/\[\s*(-?[\d.e+-]+(?:,\s*-?[\d.e+-]+)*)\s*\]/g, (_, inner) => `[${inner.split(/,\s*/).join(", ")}]`);
}

const ifMatch = (etag) => (etag ? { "If-Match": etag } : {});

// Two clicks end the cell: the first asks, the second does it (no blocking dialog).
function endButton(robot, etag, message) {
  const end = h("button", { type: "button", id: "cell-end" }, "End the cell…");
  end.addEventListener("click", () => {
    if (end.dataset.armed) return write(robot.id, message, () => api(`/v1/robots/${robot.id}/cell`, { method: "DELETE", raw: true, headers: ifMatch(etag) }));
    end.dataset.armed = "yes";
    end.textContent = "End it: designs and checks will have no cell (its versions stay)";
  });
  return end;
}

// After a write the page reads everything again (the new version, the robot's new ETag), at the current version.
async function write(robotId, message, send) {
  message.replaceChildren();
  try {
    await send();
    const current = `#/robots/${robotId}/cell`;
    if (location.hash !== current) location.hash = current;
    else window.dispatchEvent(new HashChangeEvent("hashchange"));
  } catch (error) {
    fill(message, errorBox(error, "cell-error"));
  }
}

function checkSection(robot, stored, drawing) {
  const joints = h("textarea", { id: "check-joints", rows: 6, cols: 80, spellcheck: "false", placeholder: `${robot.joint_names.join(",")}\n0,-90,80,-90,90,0` });
  const file = h("input", { type: "file", id: "check-file", accept: ".csv,.json,.txt,text/csv,application/json" });
  file.addEventListener("change", async () => { if (file.files[0]) joints.value = await file.files[0].text(); });
  const result = h("div", { id: "check-result" });
  const go = h("button", { type: "button", id: "check-submit" }, "Check the poses");
  go.addEventListener("click", async () => {
    result.replaceChildren();
    try {
      const poses = readJointVectors(joints.value, robot.joint_names);
      const found = await api(`/v1/robots/${robot.id}/cell/check`, { method: "POST", json: { poses, cell: "stored" } });
      showCheck(result, robot, poses, found, drawing);
    } catch (error) {
      fill(result, errorBox(error, "check-error"));
    }
  });
  return h("section", {}, h("h2", {}, "Check poses against the cell"),
    muted(`Joints in ${robot.joint_units.join(", ")}: one vector a line (a header of joint names may come first; , ; or tab between them), or a JSON array of vectors.`),
    h("div", { class: "row" }, field("Or load a CSV or JSON file", file)), joints, h("p", {}, go), result);
}

function showCheck(result, robot, poses, found, drawing) {
  const refused = Object.entries(found.refused).sort((a, b) => b[1] - a[1]);
  const rows = found.poses.map((v, k) => {
    const draw = h("button", { type: "button", class: "link", "data-pose": k + 1 }, "draw");
    draw.addEventListener("click", () => drawing.drawPose(poses[k], v));
    return [numCell(k + 1), ...poses[k].map((q) => numCell(q, 6)), h("td", { class: v.feasible ? "status-succeeded" : "status-failed" }, v.feasible ? "feasible" : "refused"),
      v.reason || "", v.detail || "", draw];
  });
  fill(result, h("p", { id: "check-summary" }, `${found.feasible} of ${found.poses.length} poses feasible in cell version ${found.cell_version}.`),
    refused.length ? table(["reason", "poses refused"], refused.map(([r, n]) => [r, numCell(n)]), "check-counts", "Refused, by the first check each pose fails") : null,
    h("div", { class: "scroll" }, table(["#", ...robot.joint_names.map((n, i) => `${n} (${robot.joint_units[i]})`), "verdict", "reason", "detail", ""], rows, "check-poses")));
}
