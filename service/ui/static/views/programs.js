// Program compensation: a robot program and its companion files (a KRL .src with its .dat and $config.dat, RAPID
// modules, a URScript file, a CSV of poses) dropped or picked, compensated for one of the robot's parameter
// versions (POST …/programs/compensate, as a job when asked or when the service says the work needs one), each
// target's correction or why it was kept, whatever else the service answers (rendered generically: the API grows),
// the lines that changed, and the compensated files to download in the encoding each came in.
import { api, fieldErrors, query } from "../api.js";
import { download, errorBox, field, fill, h, link, muted, table, when } from "../dom.js";
import { watchJob } from "./jobs.js";

const FORMATS = {
  src: "krl", dat: "krl", sub: "krl", mod: "rapid", modx: "rapid", prg: "rapid", sys: "rapid", sysx: "rapid",
  script: "urscript", urscript: "urscript", csv: "csv",
};
const SHOWN_LINES = 500;
// The answer's members laid out by name; any other is shown generically below them.
const KNOWN = new Set(["format", "version", "program", "files", "targets", "base", "pendant", "warnings"]);
const TARGET_KNOWN = new Set(["file", "line", "column", "name", "base_frame", "tool_frame", "reached", "correction_mm", "correction_deg", "reason"]);

const extension = (name) => (name.match(/\.([^.]+)$/) || ["", ""])[1].toLowerCase();
export const formatOf = (name) => FORMATS[extension(name)] || null;

// ---------------------------------------------------------------- files and their encodings
// The JSON body carries text, the controller wants its bytes back: a file is decoded as UTF-16 after its mark,
// UTF-8 when its bytes are (a mark kept aside), and Windows-1252 otherwise (KUKA's controllers write it; the
// Encoding Standard's windows-1252 maps all 256 bytes, so the bytes come back exactly).
const CP1252 = new TextDecoder("windows-1252").decode(Uint8Array.from({ length: 256 }, (_, b) => b));
const CP1252_BYTES = new Map([...CP1252].map((c, b) => [c, b]));

export function decodeFile(name, buffer) {
  const bytes = new Uint8Array(buffer);
  const starts = (...mark) => mark.every((b, i) => bytes[i] === b);
  if (starts(0xFF, 0xFE)) return { name, encoding: "utf-16le", bom: true, text: new TextDecoder("utf-16le").decode(bytes.subarray(2)) };
  if (starts(0xFE, 0xFF)) return { name, encoding: "utf-16be", bom: true, text: new TextDecoder("utf-16be").decode(bytes.subarray(2)) };
  const bom = starts(0xEF, 0xBB, 0xBF);
  try {
    return { name, encoding: "utf-8", bom, text: new TextDecoder("utf-8", { fatal: true, ignoreBOM: true }).decode(bytes.subarray(bom ? 3 : 0)) };
  } catch (_) {
    return { name, encoding: "windows-1252", bom: false, text: new TextDecoder("windows-1252").decode(bytes) };
  }
}

export function encodeText(file, text) {
  if (file.encoding === "windows-1252") {
    return Uint8Array.from(text, (c) => {
      const b = CP1252_BYTES.get(c);
      if (b === undefined) throw new Error(`${file.name}: ${JSON.stringify(c)} has no Windows-1252 byte`);
      return b;
    });
  }
  if (file.encoding.startsWith("utf-16")) {
    const little = file.encoding === "utf-16le";
    const out = new Uint8Array(2 * text.length + 2);
    const view = new DataView(out.buffer);
    view.setUint16(0, 0xFEFF, little);
    for (let i = 0; i < text.length; i++) view.setUint16(2 + 2 * i, text.charCodeAt(i), little);
    return file.bom ? out : out.subarray(2);
  }
  const body = new TextEncoder().encode(text);
  if (!file.bom) return body;
  const out = new Uint8Array(body.length + 3);
  out.set([0xEF, 0xBB, 0xBF]);
  out.set(body, 3);
  return out;
}

// The file most likely to be the program: a .src before its .dat, a RAPID module with main before the others,
// never $config.dat.
function programScore(file) {
  const ext = extension(file.name);
  if (file.name.toLowerCase() === "$config.dat") return 0;
  if (ext === "src") return 5;
  if (["mod", "modx", "prg"].includes(ext)) return /\bPROC\s+main\s*\(/i.test(file.text) ? 5 : 4;
  if (["script", "urscript"].includes(ext)) return 4;
  if (ext === "csv") return 3;
  return FORMATS[ext] ? 1 : 0;
}

// ---------------------------------------------------------------- the pages
export async function programsIndex(view) {
  const robots = await api("/v1/robots");
  fill(view, h("h1", {}, "Compensate a program"),
    muted("Choose the robot the program runs on: its program is compensated for one of its parameter versions."),
    robots.length === 0 ? muted("No robot yet.") :
      table(["robot", "model", "version", ""], robots.map((r) => [r.name, r.model, String(r.parameter_version),
        link(`#/robots/${r.id}/programs`, "compensate a program")]), "program-robots"));
}

export async function programsView(view, robotId) {
  const [robot, versions] = await Promise.all([api(`/v1/robots/${robotId}`), api(`/v1/robots/${robotId}/parameter-versions`)]);
  const state = { files: [], program: null };
  const list = h("div", { id: "program-files-list" });
  const redraw = () => drawFiles(list, state, redraw);
  const input = h("input", { type: "file", id: "program-files", multiple: true, accept: Object.keys(FORMATS).map((e) => `.${e}`).join(",") + ",.txt" });
  const zone = h("div", { class: "drop-zone", id: "program-files-zone" },
    field("Program and its files (.src with its .dat and $config.dat, RAPID modules, a URScript file, a CSV)", input),
    h("span", { class: "muted" }, "or drop the files here"));
  const add = async (picked) => { await addFiles(state, picked); redraw(); };
  input.addEventListener("change", () => add([...input.files]));
  zone.addEventListener("dragover", (e) => { e.preventDefault(); zone.classList.add("over"); });
  zone.addEventListener("dragleave", () => zone.classList.remove("over"));
  zone.addEventListener("drop", (e) => { e.preventDefault(); zone.classList.remove("over"); add([...e.dataTransfer.files]); });

  const options = optionsForm(robot, versions);
  const outcome = h("div", { id: "program-outcome" });
  const run = h("button", { type: "submit", id: "compensate" }, "Compensate");
  const form = h("form", { id: "program-form" }, zone, list, options.node, h("p", {}, run), outcome);
  form.addEventListener("submit", async (event) => {
    event.preventDefault();
    run.disabled = true;
    try {
      await compensate(robotId, state, options, outcome);
    } catch (error) {
      fill(outcome, errorBox(error, "program-error"));
    } finally {
      run.disabled = false;
    }
  });
  redraw();
  fill(view, h("p", {}, link(`#/robots/${robotId}`, `← ${robot.name}`)),
    h("h1", {}, `Compensate a program for ${robot.name}`),
    muted("Every Cartesian target is moved so that the calibrated robot's TCP lands where the nominal controller's "
      + "would have; every other byte of the files stays as it was. Joint targets are kept. Send the files that "
      + "declare the program's bases and tools (KRL $config.dat, the RAPID modules with its tooldata and wobjdata)."),
    form);
}

async function addFiles(state, picked) {
  for (const file of picked) {
    const read = decodeFile(file.name, await file.arrayBuffer());
    state.files = state.files.filter((f) => f.name !== read.name).concat([{ ...read, size: file.size }]);
  }
  if (!state.files.some((f) => f.name === state.program)) {
    const best = [...state.files].sort((a, b) => programScore(b) - programScore(a))[0];
    state.program = best ? best.name : null;
  }
}

function drawFiles(container, state, redraw) {
  if (state.files.length === 0) { fill(container, muted("No file yet.", "no-program-files")); return; }
  fill(container, table(["program", "file", "format", "encoding", "bytes", ""], state.files.map((f) => {
    const choose = h("input", { type: "radio", name: "program-choice", value: f.name, checked: f.name === state.program, "aria-label": `${f.name} is the program` });
    choose.addEventListener("change", () => { state.program = f.name; redraw(); });
    const remove = h("button", { type: "button", class: "link", "aria-label": `remove ${f.name}` }, "remove");
    remove.addEventListener("click", () => {
      state.files = state.files.filter((g) => g !== f);
      if (state.program === f.name) state.program = null;
      addFiles(state, []).then(redraw);
    });
    return [choose, f.name, formatOf(f.name) || "?", f.encoding + (f.bom ? " (BOM)" : ""), String(f.size), remove];
  }), "program-files-table", "The program (chosen) and its companion files, sent by their names"));
}

function optionsForm(robot, versions) {
  const format = h("select", { id: "program-format" }, h("option", { value: "" }, "from the program's extension"),
    ["krl", "rapid", "urscript", "csv"].map((f) => h("option", { value: f }, f)));
  const version = h("select", { id: "program-version" }, versions.map((v) => h("option",
    { value: v.version, selected: v.current }, `version ${v.version} · ${v.provenance} · ${when(v.created_at)}${v.current ? " (current)" : ""}`)));
  const seed = h("input", { id: "program-seed", type: "text", size: 40, placeholder: robot.joint_names.join(", ") });
  const job = h("input", { type: "checkbox", id: "program-async" });
  const node = h("fieldset", { id: "program-options" }, h("legend", {}, "Options"),
    h("div", { class: "row" },
      field("Format", format), field("Parameter version", version),
      field(`Seed joints (${robot.joint_units.join(", ")}), optional`, seed, "the joints the controller's solutions are sought near")),
    h("label", {}, job, " Run as a job (large programs; also chosen when the service says the work needs one)"));
  const values = () => {
    const text = seed.value.trim();
    const joints = text ? text.split(/[\s,;]+/).filter(Boolean).map(Number) : null;
    if (joints && (joints.length !== robot.joint_names.length || joints.some((v) => !Number.isFinite(v)))) {
      throw new Error(`the seed needs ${robot.joint_names.length} numbers (${robot.joint_names.join(", ")}), got "${text}"`);
    }
    return { format: format.value || null, version: Number(version.value), seed: joints, async: job.checked };
  };
  return { node, values };
}

// ---------------------------------------------------------------- the request
async function compensate(robotId, state, options, outcome) {
  const program = state.files.find((f) => f.name === state.program);
  if (!program) { fill(outcome, errorBox(new Error("choose or drop the program's files first"), "program-error")); return; }
  const chosen = options.values();
  const format = chosen.format || formatOf(program.name);
  if (!format) { fill(outcome, errorBox(new Error(`the format of ${program.name} is not known from its name: choose it`), "program-error")); return; }
  const companions = state.files.filter((f) => f !== program);
  const body = { format, program: program.text, version: chosen.version, files: Object.fromEntries(companions.map((f) => [f.name, f.text])) };
  if (chosen.seed) body.seed = chosen.seed;
  const path = `/v1/robots/${robotId}/programs/compensate`;
  const notes = [];
  fill(outcome, muted(`Compensating ${program.name}…`));
  let answer;
  try {
    answer = await send(path, body, chosen.async);
  } catch (error) {
    if (chosen.async || !(error.problem && error.problem.use_async)) { fill(outcome, refusal(error)); return; }
    notes.push(muted(`Over the service's budget for one request (${error.message}): sent again as a job.`, "program-as-job"));
    fill(outcome, notes);
    try { answer = await send(path, body, true); } catch (again) { fill(outcome, notes, refusal(again)); return; }
  }
  if (answer.job_id && !("program" in answer)) {
    const box = h("div");
    fill(outcome, notes, box);
    const job = await watchJob(answer.job_id, box);
    notes.push(box);
    if (job.status === "cancelled") { outcome.append(h("p", { id: "job-cancelled" }, "The compensation was cancelled.")); return; }
    if (job.status !== "succeeded" || !job.result) {
      outcome.append(refusal({ message: `${job.error ? job.error.status : ""}: ${job.error ? job.error.detail : "the job failed"}`, problem: job.error }));
      return;
    }
    answer = job.result;
  }
  fill(outcome, notes, result(answer, program, companions));
}

// A job (202) when asked; a service without the job form ignores ?async and answers at once.
async function send(path, body, asJob) {
  const response = await api(path + query({ async: asJob ? true : null }), { method: "POST", json: body, raw: true });
  return response.json();
}

// A refusal: the problem's detail, where in which file, each invalid field.
function refusal(error) {
  const problem = error.problem || {};
  const where = problem.line != null ? `${problem.file || "the program"}, line ${problem.line}${problem.column != null ? `, column ${problem.column}` : ""}` : null;
  const fields = fieldErrors(problem);
  return h("div", { class: "error refusal", id: "program-refused", role: "alert" },
    h("h3", {}, "The service refused the program"), h("p", {}, String(error.message || error)),
    where ? h("p", { id: "program-refused-where" }, `At ${where}${problem.reason ? ` (${problem.reason})` : ""}.`) : null,
    fields.length ? h("ul", {}, fields.map((f) => h("li", {}, f))) : null);
}

// ---------------------------------------------------------------- the answer
const norm = (v) => (Array.isArray(v) && v.every((x) => typeof x === "number") ? Math.hypot(...v) : null);
const fixed = (v, digits) => (typeof v === "number" ? v.toFixed(digits) : "—");
const numberCell = (v, digits) => h("td", { class: "num" }, fixed(v, digits));
const title = (key) => key.replace(/_/g, " ").replace(/^./, (c) => c.toUpperCase());

// Anything the service says (a message, a warning object, a list) as text, never as markup.
export function said(value) {
  if (value === null || value === undefined) return "—";
  if (Array.isArray(value)) return value.map(said).join("; ");
  if (typeof value === "object") {
    for (const key of ["message", "reason", "detail"]) if (typeof value[key] === "string") return value[key];
    return Object.entries(value).map(([k, v]) => `${k} ${said(v)}`).join(", ");
  }
  return String(value);
}

function targetNotes(t) {
  const notes = t.reason ? [h("span", { class: t.reached ? "" : "error" }, String(t.reason))] : [];
  for (const [k, v] of Object.entries(t)) {
    if (TARGET_KNOWN.has(k) || v === null || v === undefined || (Array.isArray(v) && v.length === 0)) continue;
    notes.push(h("span", { class: `note note-${k}` }, `${title(k)}: ${said(v)}`));
  }
  return h("td", { class: "notes" }, notes.flatMap((n, i) => (i ? [h("br"), n] : [n])));
}

function result(answer, program, companions) {
  const targets = Array.isArray(answer.targets) ? answer.targets : [];
  const corrected = targets.filter((t) => t.reached);
  const largest = (key) => Math.max(0, ...corrected.map((t) => norm(t[key]) || 0));
  const summaryText = `${corrected.length} of ${targets.length} targets corrected for version ${answer.version}, `
    + `${targets.length - corrected.length} kept as written`
    + (corrected.length ? `; the largest correction ${largest("correction_mm").toFixed(3)} mm, ${largest("correction_deg").toFixed(4)} deg.` : ".");
  const onlyKept = h("input", { type: "checkbox", id: "program-only-kept" });
  const rows = targets.map((t) => [
    t.file || program.name, String(t.line ?? "—"), t.name || "—", t.base_frame || "robot base", t.tool_frame || "model tool",
    h("td", { class: t.reached ? "status-succeeded" : "status-failed" }, t.reached ? "corrected" : "kept"),
    ...[0, 1, 2].map((k) => numberCell(Array.isArray(t.correction_mm) ? t.correction_mm[k] : null, 3)), numberCell(norm(t.correction_mm), 3),
    ...[0, 1, 2].map((k) => numberCell(Array.isArray(t.correction_deg) ? t.correction_deg[k] : null, 4)), numberCell(norm(t.correction_deg), 4),
    targetNotes(t)]);
  const targetTable = table(["file", "line", "name", "base", "tool", "status", "Δx (mm)", "Δy (mm)", "Δz (mm)", "|Δ| (mm)",
    "rx (deg)", "ry (deg)", "rz (deg)", "|r| (deg)", "reason, warnings"], rows, "program-targets",
  "Each target: the correction (new − old) in the target's base frame, the rotation as a rotation vector; or why it was kept");
  targetTable.querySelectorAll("tbody tr").forEach((tr, i) => { if (!targets[i].reached) tr.classList.add("kept"); });
  onlyKept.addEventListener("change", () => targetTable.querySelectorAll("tbody tr").forEach((tr) => {
    tr.hidden = onlyKept.checked && !tr.classList.contains("kept");
  }));
  return h("section", { id: "program-result" },
    h("h2", {}, "Result"), h("p", { id: "program-summary" }, summaryText),
    answer.base ? muted(answer.base, "program-frame") : null,
    facts(answer), pendantLine(answer.pendant), warningsList(answer.warnings),
    downloads(answer, program, companions),
    h("h3", {}, "Targets"), h("label", {}, onlyKept, " Only the targets kept as written"),
    h("div", { class: "scroll" }, targetTable),
    extras(answer, program),
    changedLines(answer, program, companions));
}

function pendantLine(pendant) {
  if (!pendant) return null;
  return h("p", { id: "program-pendant" }, `Pendant check: ${pendant.readings} readings, the model within ${fixed(pendant.max_position_mm, 3)} mm`
    + (pendant.max_orientation_deg != null ? ` and ${fixed(pendant.max_orientation_deg, 4)} deg` : "") + ".");
}

function warningsList(warnings) {
  if (!Array.isArray(warnings) || warnings.length === 0) return null;
  return h("div", { class: "verdict not-applied", id: "program-warnings" }, h("h3", {}, "Warnings"),
    h("ul", {}, warnings.map((w) => h("li", {}, said(w)))));
}

// The members this page does not know by name: values as text (a frame's name) under the summary, lists after the
// targets, a list of objects as a table (a "left alone" list: where, what, why).
const unknown = (answer) => Object.entries(answer).filter(([key, value]) => !KNOWN.has(key) && value !== null && value !== undefined);

function facts(answer) {
  const items = unknown(answer).filter(([, value]) => !Array.isArray(value));
  if (items.length === 0) return null;
  return h("dl", { id: "program-facts" }, items.flatMap(([key, value]) => [h("dt", {}, title(key)), h("dd", { "data-key": key }, said(value))]));
}

function extras(answer, program) {
  const parts = [];
  for (const [key, value] of unknown(answer).filter(([, v]) => Array.isArray(v))) {
    const id = `program-${key.replace(/_/g, "-")}`;
    parts.push(h("h3", {}, `${title(key)} (${value.length})`));
    if (value.length === 0) {
      parts.push(muted("None.", id));
    } else if (value.every((v) => v && typeof v === "object" && !Array.isArray(v))) {
      const columns = [...new Set(value.flatMap(Object.keys))];
      const lead = ["file", "line", "column", "name", "reason"].filter((c) => columns.includes(c) || c === "file");
      const all = [...lead, ...columns.filter((c) => !lead.includes(c))];
      parts.push(h("div", { class: "scroll" }, table(all, value.map((item) => all.map((c) =>
        (c === "file" ? item.file || program.name : said(item[c])))), id)));
    } else {
      parts.push(h("ul", { id }, value.map((v) => h("li", {}, said(v)))));
    }
  }
  return h("div", { id: "program-extras" }, parts);
}

function downloads(answer, program, companions) {
  const rewritten = answer.files && typeof answer.files === "object" ? answer.files : {};
  const texts = [[program, answer.program], ...companions.filter((f) => f.name in rewritten).map((f) => [f, rewritten[f.name]])];
  const message = h("div");
  const buttons = texts.map(([file, text], i) => h("button", { type: "button", id: `program-download-${i}`, onclick: () => {
    try {
      download(file.name, encodeText(file, String(text)), "application/octet-stream");
    } catch (error) { fill(message, errorBox(error)); }
  } }, `Download ${file.name}`));
  const untouched = companions.filter((f) => !(f.name in rewritten)).map((f) => f.name);
  return h("div", { id: "program-downloads" }, h("h3", {}, "Compensated files"), h("p", { class: "row" }, buttons),
    untouched.length ? muted(`Unchanged (no target in them): ${untouched.join(", ")}.`) : null, message);
}

// The lines whose text changed, file by file (a compensation rewrites numbers in place: lines keep their places).
function changedLines(answer, program, companions) {
  const rewritten = answer.files && typeof answer.files === "object" ? answer.files : {};
  const rows = [];
  for (const [file, text] of [[program, answer.program], ...companions.map((f) => [f, rewritten[f.name]])]) {
    if (typeof text !== "string") continue;
    const before = file.text.split("\n");
    const after = text.split("\n");
    for (let i = 0; i < Math.max(before.length, after.length); i++) {
      if (before[i] !== after[i]) rows.push([file.name, String(i + 1), (before[i] ?? "").trimEnd(), (after[i] ?? "").trimEnd()]);
    }
  }
  return h("details", { id: "program-changes" }, h("summary", {}, `The lines that changed (${rows.length})`),
    h("div", { class: "scroll" }, table(["file", "line", "before", "after"], rows.slice(0, SHOWN_LINES).map((r) =>
      [r[0], r[1], h("td", {}, h("code", {}, r[2])), h("td", {}, h("code", {}, r[3]))]), "program-changes-table",
    rows.length > SHOWN_LINES ? `The first ${SHOWN_LINES} of ${rows.length}` : null)));
}
