// Robots: the list, and a form that creates one: the IWR (the service's built-in structure), a DH/MDH table
// typed or pasted from a spreadsheet, or a URDF file whose chain runs from a chosen base link to a tip link.
import { api } from "../api.js";
import { errorBox, field, fill, h, link, muted, numCell, table, when } from "../dom.js";

const LINK_KEYS = ["theta", "d", "a", "alpha"];

export async function robotsView(view) {
  const robots = await api("/v1/robots");
  fill(view, h("h1", {}, "Robots"),
    robots.length === 0 ? muted("No robot yet: add one below.", "no-robots") :
      table(["name", "model", "current version", "created"], robots.map((r) => [
        link(`#/robots/${r.id}`, r.name), r.model, numCell(r.parameter_version, 3), when(r.created_at)]), "robots"),
    createForm());
}

function createForm() {
  const name = h("input", { id: "robot-name", name: "name", required: true, autocomplete: "off" });
  const kinds = [["iwr", "The IWR (built in)"], ["dh", "A DH / MDH table"], ["urdf", "A URDF file"]];
  const kind = h("fieldset", { class: "choices" }, h("legend", {}, "Structure"),
    kinds.map(([value, text], i) => h("label", {}, h("input", { type: "radio", name: "structure-kind", value, checked: i === 0 }), ` ${text}`)));
  const dh = dhEditor(), urdf = urdfPicker();
  const panes = { iwr: muted("The intersector welding robot of the service's model: four serial joints and a hexapod."), dh: dh.node, urdf: urdf.node };
  const pane = h("div", { id: "structure-pane" }, panes.iwr);
  kind.addEventListener("change", (e) => fill(pane, panes[e.target.value]));
  const message = h("div", { id: "create-message" });
  const form = h("form", { id: "create-robot", "aria-labelledby": "create-heading" },
    h("h2", { id: "create-heading" }, "Add a robot"), field("Name", name), kind, pane,
    h("p", {}, h("button", { type: "submit", id: "create-submit" }, "Create the robot")), message);
  form.addEventListener("submit", async (event) => {
    event.preventDefault();
    message.replaceChildren();
    try {
      const choice = form.querySelector("input[name=structure-kind]:checked").value;
      const body = { name: name.value.trim() };
      if (choice === "dh") body.structure = dh.structure();
      if (choice === "urdf") Object.assign(body, urdf.fields());
      const robot = await api("/v1/robots", { method: "POST", json: body });
      location.hash = `#/robots/${robot.id}`;
    } catch (error) {
      fill(message, errorBox(error, "create-error"));
    }
  });
  return form;
}

// ---------------------------------------------------------------- DH / MDH table
function dhEditor() {
  const convention = h("select", { id: "dh-convention" }, h("option", { value: "dh" }, "DH: Rz(θ) Tz(d) Tx(a) Rx(α)"),
    h("option", { value: "mdh" }, "MDH: Rx(α) Tx(a) Rz(θ) Tz(d)"));
  const body = h("tbody");
  const grid = h("table", { id: "dh-table", class: "editable" },
    h("caption", {}, "One row a link: the joint's reading adds to θ (revolute) or d (prismatic); mm and degrees"),
    h("thead", {}, h("tr", {}, ["joint", "θ (deg)", "d (mm)", "a (mm)", "α (deg)", "range from", "range to", ""].map((t) => h("th", { scope: "col" }, t)))),
    body);
  const paste = h("textarea", { id: "dh-paste", rows: 4, cols: 60,
    placeholder: "revolute\t0\t400\t25\t-90\t-170\t170\n(one link a line: joint θ d a α from to; tabs, commas, ; or spaces)" });
  const fillFromPaste = () => { const rows = parseRows(paste.value); if (rows.length) { fill(body, ...rows.map(linkRow)); paste.value = ""; } };
  // A paste of several cells into any cell of the table fills the table from there, as in a spreadsheet.
  grid.addEventListener("paste", (e) => {
    const text = e.clipboardData.getData("text");
    if (/[\t\n;,]/.test(text.trim())) { e.preventDefault(); paste.value = text; fillFromPaste(); }
  });
  for (let i = 0; i < 3; i++) body.append(linkRow({ joint: "revolute", theta: 0, d: 0, a: 0, alpha: 0, range: [-170, 170] }));
  const base = poseFields("base", "Base: world ← robot base"), tool = poseFields("tool", "Tool: last link → TCP");
  const node = h("div", { id: "dh-editor" }, field("Convention", convention), grid,
    h("p", {}, h("button", { type: "button", id: "dh-add", onclick: () => body.append(linkRow({ joint: "revolute", range: [-170, 170] })) }, "Add a link")),
    field("Or paste rows from a spreadsheet", paste),
    h("p", {}, h("button", { type: "button", id: "dh-fill", onclick: fillFromPaste }, "Fill the table from the pasted rows")),
    muted("The table ends at the last joint's frame (the flange). What the instrument measures beyond it, a tracker's "
      + "reflector on the tool, is the tool below, not the last link: a calibration then identifies the tool apart from the arm."),
    h("div", { class: "row" }, base.node, tool.node));
  const structure = () => {
    const doc = { stages: [{ kind: "serial", convention: convention.value, links: [...body.rows].map(readRow) }] };
    const b = base.pose(), t = tool.pose();
    if (b) doc.base = b;
    if (t) doc.tool = t;
    return doc;
  };
  return { node, structure };
}

// A pose as robots.md's document takes it: a position (mm) and a unit quaternion [w, x, y, z], typed as x, y, z and
// Z-Y-X Euler angles rz, ry, rx in degrees (R = Rz·Ry·Rx, the convention of the hexapod's workspace). Null when
// all six are zero: the document's default, identity.
const POSE_KEYS = [["x", "mm"], ["y", "mm"], ["z", "mm"], ["rz", "deg"], ["ry", "deg"], ["rx", "deg"]];

function poseFields(prefix, legend) {
  const inputs = Object.fromEntries(POSE_KEYS.map(([k]) => [k, h("input", { id: `${prefix}-${k}`, inputmode: "decimal", size: 7, value: 0 })]));
  const what = prefix[0].toUpperCase() + prefix.slice(1);
  const node = h("fieldset", { id: `${prefix}-pose`, class: "pose" }, h("legend", {}, legend),
    POSE_KEYS.map(([k, unit]) => field(`${what} ${k} (${unit})`, inputs[k])));
  const pose = () => {
    const v = Object.fromEntries(POSE_KEYS.map(([k]) => [k, inputs[k].value.trim().replace(",", ".")]));
    for (const [k] of POSE_KEYS) {
      if (v[k] === "" || !Number.isFinite(Number(v[k]))) throw new Error(`${prefix} ${k}: ${JSON.stringify(v[k])} is not a number`);
    }
    const n = Object.fromEntries(POSE_KEYS.map(([k]) => [k, Number(v[k])]));
    if (POSE_KEYS.every(([k]) => n[k] === 0)) return null;
    return { position: [n.x, n.y, n.z], orientation: quaternionZYX(n.rz, n.ry, n.rx) };
  };
  return { node, pose };
}

// q = q_z(rz) · q_y(ry) · q_x(rx), [w, x, y, z].
function quaternionZYX(rz, ry, rx) {
  const half = (deg) => (deg * Math.PI) / 360;
  const [cz, sz, cy, sy, cx, sx] = [Math.cos(half(rz)), Math.sin(half(rz)), Math.cos(half(ry)), Math.sin(half(ry)), Math.cos(half(rx)), Math.sin(half(rx))];
  return [cz * cy * cx + sz * sy * sx, cz * cy * sx - sz * sy * cx, cz * sy * cx + sz * cy * sx, sz * cy * cx - cz * sy * sx];
}

function linkRow(linkData) {
  const cell = (key, value) => h("td", {}, h("input", { "data-key": key, "aria-label": key, inputmode: "decimal", size: 7, value: value ?? 0 }));
  const joint = h("select", { "data-key": "joint", "aria-label": "joint type" },
    ["revolute", "prismatic", "fixed"].map((j) => h("option", { value: j, selected: j === linkData.joint }, j)));
  const range = linkData.range || ["", ""];
  const row = h("tr", {}, h("td", {}, joint), LINK_KEYS.map((k) => cell(k, linkData[k])), cell("lo", range[0]), cell("hi", range[1]),
    h("td", {}, h("button", { type: "button", class: "link", "aria-label": "remove this link", onclick: () => row.remove() }, "remove")));
  return row;
}

function readRow(row, index) {
  const value = (key) => row.querySelector(`[data-key=${key}]`).value.trim().replace(",", ".");
  const out = { joint: value("joint") };
  for (const key of LINK_KEYS) out[key] = numberOrText(value(key));
  if (out.joint !== "fixed") {
    if (value("lo") === "" || value("hi") === "") throw new Error(`link ${index + 1}: a moving joint needs its range`);
    out.range = [numberOrText(value("lo")), numberOrText(value("hi"))];
  }
  return out;
}

// A cell that is not a number is sent as typed: the service's 422 then names the field.
const numberOrText = (text) => (text !== "" && Number.isFinite(Number(text)) ? Number(text) : text);

const JOINT_WORDS = { r: "revolute", revolute: "revolute", p: "prismatic", prismatic: "prismatic", f: "fixed", fixed: "fixed" };

// Pasted rows: joint θ d a α from to; a row that starts with a number is a revolute link.
function parseRows(text) {
  return text.split(/\r?\n/).map((l) => l.trim()).filter((l) => l && !l.startsWith("#")).map((line) => {
    const delimiter = ["\t", ";", ","].find((d) => line.includes(d));
    const cells = (delimiter ? line.split(delimiter) : line.split(/\s+/)).map((c) => c.trim()).filter((c) => c !== "");
    const joint = JOINT_WORDS[cells[0].toLowerCase()];
    // With tabs or `;` between cells a comma is a decimal comma (a European spreadsheet's copy).
    const numbers = (joint ? cells.slice(1) : cells).map((c) => (delimiter === "," ? c : c.replace(",", ".")));
    const [theta, d, a, alpha, lo, hi] = numbers;
    return { joint: joint || "revolute", theta, d, a, alpha, range: [lo ?? "", hi ?? ""] };
  }).filter((r) => !/^(joint|theta|θ)/i.test(String(r.theta)));  // a header row copied along
}

// ---------------------------------------------------------------- URDF
function urdfPicker() {
  const file = h("input", { type: "file", id: "urdf-file", accept: ".urdf,.xml,.xacro,application/xml,text/xml" });
  const base = h("select", { id: "urdf-base" }), tip = h("select", { id: "urdf-tip" });
  const info = h("p", { class: "muted", id: "urdf-info" }, "Choose a URDF file: its links are offered as base and tip.");
  let text = null;
  file.addEventListener("change", async () => {
    text = await file.files[0].text();
    // A xacro's links are inside its macros: there is nothing to offer. Its elements or ${…}, outside comments (an
    // expanded URDF keeps the xmlns:xacro declaration and may quote xacro in comments: it is a URDF).
    if (/<xacro:|\$\{/.test(text.replace(/<!--[\s\S]*?-->/g, ""))) {
      fill(base); fill(tip);
      info.textContent = "This is a xacro file, not a URDF: expand it first with `xacro robot.urdf.xacro > robot.urdf` "
        + "(ROS 2: `ros2 run xacro xacro robot.urdf.xacro > robot.urdf`) and choose the URDF it writes.";
      return;
    }
    const { links, root, leaves } = urdfLinks(text);
    if (links.length === 0) { info.textContent = "This file names no <link>: is it a URDF?"; return; }
    const options = (selected) => links.map((l) => h("option", { value: l, selected: l === selected }, l));
    fill(base, ...options(root));
    fill(tip, ...options(leaves[leaves.length - 1] || links[links.length - 1]));
    info.textContent = `${links.length} links; the chain from the base link to the tip link is the robot.`;
  });
  const node = h("div", { id: "urdf-picker" }, field("URDF file", file), info, h("div", { class: "row" }, field("Base link", base), field("Tip link", tip)));
  const fields = () => {
    if (!text) throw new Error("choose a URDF file first");
    return { urdf: text, base_link: base.value, tip_link: tip.value };
  };
  return { node, fields };
}

// The links of a URDF, the root (a parent of no joint's child) first suggested as base, a leaf as tip.
function urdfLinks(text) {
  const doc = new DOMParser().parseFromString(text, "application/xml");
  const links = [...doc.querySelectorAll("robot > link")].map((l) => l.getAttribute("name"));
  const joints = [...doc.querySelectorAll("robot > joint")];
  const children = new Set(joints.map((j) => j.querySelector("child")?.getAttribute("link")));
  const parents = new Set(joints.map((j) => j.querySelector("parent")?.getAttribute("link")));
  return { links, root: links.find((l) => !children.has(l)) || links[0], leaves: links.filter((l) => !parents.has(l)) };
}
