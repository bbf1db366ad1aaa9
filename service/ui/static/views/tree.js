// Robots of several chains (#/trees, #/trees/{id}): the list and a new tree (a JSON document or a URDF with its tip
// links); a tree's branches as a diagram (base → branches → tools), the tree drawn at a pose in the cell view's
// orthographic views, its tools' poses, and the accuracy of its last calibration, each tool and each pair of tools
// (the relative accuracy). Every place drawn is the API's: POST …/kinematics answers every frame by name. Below, a
// record design over the tree (its records, a CSV to take them by), compensated joints for targets in the world
// or in another tool's frame, and the calibrated tree's exports (URDF, DH tables).
import { api } from "../api.js";
import { drawCell } from "../cellplot.js";
import { download, errorBox, field, fill, h, link, muted, num, numCell, table, when } from "../dom.js";

const NS = "http://www.w3.org/2000/svg";

const EXAMPLE = {
  name: "arm-and-positioner",
  branches: [
    { name: "arm", stages: [{ kind: "serial", convention: "dh", links: [
      { joint: "revolute", a: 0, alpha: 90, d: 89.159, theta: 0, range: [-360, 360] },
      { joint: "revolute", a: -425, alpha: 0, d: 0, theta: 0, range: [-360, 360] },
      { joint: "revolute", a: -392.25, alpha: 0, d: 0, theta: 0, range: [-360, 360] },
      { joint: "revolute", a: 0, alpha: 90, d: 109.15, theta: 0, range: [-360, 360] },
      { joint: "revolute", a: 0, alpha: -90, d: 94.65, theta: 0, range: [-360, 360] },
      { joint: "revolute", a: 0, alpha: 0, d: 82.3, theta: 0, range: [-360, 360] }] }],
    tool: { position: [60, -40, 120], orientation: [1, 0, 0, 0] } },
    { name: "positioner", mount: { position: [1200, 0, 600], orientation: [0.7071068, 0.7071068, 0, 0] },
      stages: [{ kind: "serial", convention: "dh", links: [
        { joint: "revolute", a: 0, alpha: -90, d: 0, theta: 0, range: [-90, 90] },
        { joint: "revolute", a: 0, alpha: 0, d: 200, theta: 0, range: [-180, 180] }] }],
      tool: { position: [150, 80, 40], orientation: [1, 0, 0, 0] } },
  ],
};

// ---------------------------------------------------------------- the list and a new tree
export async function treesView(view) {
  const trees = await api("/v1/robot-trees?limit=1000");
  const rows = trees.map((t) => [link(`#/trees/${t.id}`, t.name), t.branches.map((b) => b.name).join(", "), t.tools.join(", "),
    numCell(t.joint_names.length), numCell(t.revision), t.calibration_id ? "calibrated" : "nominal", when(t.created_at)]);
  fill(view, h("h1", {}, "Robot trees"),
    muted("Robots of several chains: a dual-arm torso on one waist, an arm and the positioner that holds its part. Each branch hangs from another or from the base; each tip carries a tool."),
    trees.length ? table(["name", "branches", "tools", "joints", "revision", "parameters", "created"], rows, "trees") : muted("No tree yet.", "trees"),
    h("h2", {}, "Add a tree"), createSection());
}

function createSection() {
  const text = h("textarea", { id: "tree-document", rows: 16, cols: 100, spellcheck: "false" }, JSON.stringify(EXAMPLE, null, 1));
  const urdf = h("input", { type: "file", id: "tree-urdf", accept: ".urdf,.xml,.xacro,application/xml,text/xml" });
  const baseLink = h("input", { type: "text", id: "tree-base-link", size: 16, placeholder: "world" });
  const tips = h("input", { type: "text", id: "tree-tips", size: 40, placeholder: "gripper_l, gripper_r" });
  const message = h("div", { id: "tree-message" });
  const send = h("button", { type: "button", id: "tree-create" }, "Create the tree");
  send.addEventListener("click", async () => {
    message.replaceChildren();
    try {
      let body;
      if (urdf.files[0]) {
        const name = (urdf.files[0].name || "urdf-tree").replace(/\.[^.]*$/, "");
        body = { name, urdf: await urdf.files[0].text(), base_link: baseLink.value.trim(),
          tip_links: tips.value.split(/[,\s]+/).filter(Boolean) };
      } else {
        try { body = JSON.parse(text.value); } catch (error) { throw new Error(`the tree document is not valid JSON: ${error.message}`); }
      }
      const made = await api("/v1/robot-trees", { method: "POST", json: body });
      location.hash = `#/trees/${made.id}`;
    } catch (error) {
      fill(message, errorBox(error, "tree-error"));
    }
  });
  return h("section", {}, muted("A tree document (docs/api.md, \"Robots of several chains\"): name, base, branches with name, parent, mount, stages (robots.md, mm and degrees), tool, joint_names. Or a URDF with the links its chains start from and end at (a xacro must be expanded first)."),
    text, h("div", { class: "row" }, field("Or a URDF file", urdf), field("base link", baseLink), field("tip links", tips)), h("p", {}, send), message);
}

// ---------------------------------------------------------------- one tree
export async function treeView(view, treeId) {
  const [tree, calibrations, criteria] = await Promise.all([api(`/v1/robot-trees/${treeId}`),
    api(`/v1/robot-trees/${treeId}/calibrations?limit=1000`), api("/v1/design-criteria")]);
  const drawing = h("div", { id: "tree-drawing" });
  const last = calibrations[calibrations.length - 1];
  fill(view, h("p", {}, link("#/trees", "← Robot trees")), h("h1", {}, tree.name),
    h("p", { id: "tree-status" }, `Revision ${tree.revision}; ${tree.branches.length} branches, tools ${tree.tools.join(", ")}, ${tree.joint_names.length} joints, `
      + `${tree.parameter_count} parameters (${tree.calibration_id ? "calibrated" : "nominal"}); from ${tree.source === "urdf" ? `a URDF (${tree.base_link} → ${tree.tip_links.join(", ")})` : "a tree document"}.`),
    h("h2", {}, "Branches"), diagram(tree), branchesTable(tree),
    drawing,
    h("h2", {}, "Calibration"), last ? calibrationSection(treeId, last, calibrations.length) : muted("Not calibrated: POST …/calibrations with records of its tools (docs/api.md).", "tree-accuracy"),
    h("h2", {}, "Which records to take"), designSection(tree, criteria),
    h("h2", {}, "Compensated joints"), compensationSection(tree),
    h("h2", {}, "Exports"), exportsSection(tree));
  await drawingSection(drawing, tree);
}

// ---------------------------------------------------------------- a design, a compensation, the exports
function designSection(tree, criteria) {
  const count = h("input", { id: "tree-design-count", type: "number", min: 1, value: 30, size: 6 });
  const criterion = h("select", { id: "tree-design-criterion" }, ...criteria.map((c) => h("option", { value: c.name, title: c.summary }, c.name)));
  const candidates = h("input", { id: "tree-design-candidates", type: "number", min: 1, value: 300, size: 6 });
  const measurement = h("select", { id: "tree-design-measurement" }, h("option", { value: "position" }, "position"), h("option", { value: "pose" }, "pose"));
  const relative = h("input", { id: "tree-design-relative", type: "checkbox" });
  const seed = h("input", { id: "tree-design-seed", type: "number", min: 0, value: 0, size: 6 });
  const out = h("div", { id: "tree-design" });
  const send = h("button", { type: "button", id: "tree-design-run" }, "Design");
  send.addEventListener("click", async () => {
    out.replaceChildren(muted("Designing…"));
    const kind = measurement.value;
    const measure = tree.tools.map((tool) => ({ tool, measurement: kind }));
    if (relative.checked) {
      for (const [i, a] of tree.tools.entries()) for (const b of tree.tools.slice(i + 1)) measure.push({ tool: a, frame: b, measurement: kind });
    }
    const body = { count: Number(count.value), criterion: criterion.value, candidate_count: Number(candidates.value), seed: Number(seed.value), measure };
    try {
      showDesign(out, tree, await api(`/v1/robot-trees/${tree.id}/designs`, { method: "POST", json: body }));
    } catch (error) {
      fill(out, errorBox(error, "tree-design-error"));
    }
  });
  return h("section", {}, muted("Records of the tools chosen among joint vectors drawn inside the ranges, against random selections of as many (POST …/designs)."),
    h("div", { class: "row" }, field("Records", count), field("Criterion", criterion), field("Candidate joint vectors", candidates),
      field("Measured", measurement), field("Also each tool in another's frame", relative), field("Seed", seed), send), out);
}

function showDesign(out, tree, design) {
  const random = Object.fromEntries(design.random_accuracy.map((a) => [a.label, a]));
  const acc = design.accuracy.map((a) => [a.label, numCell(a.rms_position_mm), numCell(random[a.label].rms_position_mm), numCell(a.max_position_mm)]);
  const rows = design.records.map((r, i) => [numCell(i + 1), r.tool, r.frame || "", r.measurement, ...tree.joint_names.map((n) => numCell(r.joints[n]))]);
  const sheet = [["tool", "frame", "measurement", ...tree.joint_names].join(","),
    ...design.records.map((r) => [r.tool, r.frame || "", r.measurement, ...tree.joint_names.map((n) => r.joints[n])].join(","))].join("\n") + "\n";
  const save = h("button", { type: "button", id: "tree-design-csv" }, "Download the records (CSV)");
  save.addEventListener("click", () => download(`${tree.name}-design.csv`, sheet));
  fill(out, h("p", { id: "tree-design-summary" }, `${design.count} of ${design.candidates} candidate records by ${design.criterion}: value ${num(design.value)} `
      + `(random: ${num(design.random_baseline.value)}), efficiency ${num(design.efficiency)}, at revision ${design.revision}.`),
    table(["tool (or tool/frame)", "predicted RMS (mm)", "random RMS (mm)", "predicted max (mm)"], acc, "tree-design-accuracy",
      "Predicted accuracy after calibrating from the chosen records, and from random ones"),
    h("p", {}, save),
    table(["#", "tool", "frame", "measured", ...tree.joint_names], rows, "tree-design-records", "The chosen records"));
}

function compensationSection(tree) {
  const tool = h("select", { id: "tree-comp-tool" }, ...tree.tools.map((t) => h("option", { value: t }, t)));
  const frame = h("select", { id: "tree-comp-frame" }, h("option", { value: "" }, "the world"), ...tree.tools.map((t) => h("option", { value: t }, t)));
  const position = h("input", { id: "tree-comp-position", type: "text", size: 28, placeholder: "x, y, z mm" });
  const orientation = h("input", { id: "tree-comp-orientation", type: "text", size: 28, value: "1, 0, 0, 0" });
  const joints = h("input", { id: "tree-comp-joints", type: "text", size: 72, value: middlePose(tree).map((v) => +v.toFixed(3)).join(", ") });
  const out = h("div", { id: "tree-comp" });
  const numbers = (input) => input.value.split(/[,;\s]+/).filter(Boolean).map(Number);
  const send = h("button", { type: "button", id: "tree-comp-run" }, "Compensate");
  send.addEventListener("click", async () => {
    out.replaceChildren();
    const target = { tool: tool.value, frame: frame.value || null, position: numbers(position), orientation: numbers(orientation), joints: numbers(joints) };
    try {
      const found = await api(`/v1/robot-trees/${tree.id}/compensations`, { method: "POST", json: { targets: [target] } });
      const t = found.targets[0];
      fill(out, h("p", { id: "tree-comp-status" }, t.reached ? `Reached on revision ${found.revision} (${found.calibration_id ? "calibrated" : "nominal"}).` : `Not reached: ${t.reason}`),
        table(["joint", "program", "compensated", "change"], tree.joint_names.map((n, i) => [n, numCell(target.joints[i]), numCell(t.joints[n]), numCell(t.change[n] ?? 0)]),
          "tree-comp-joints-table", "The program's joints and the compensated ones (deg, mm)"));
    } catch (error) {
      fill(out, errorBox(error, "tree-comp-error"));
    }
  });
  return h("section", {}, muted("A target of a tool in the world (the instrument's frame) or in another tool's frame, with the program's joints (the tree's order): the joints that reach it on the tree's current parameters."),
    h("div", { class: "row" }, field("Tool", tool), field("In the frame of", frame), field("Position", position), field("Orientation [w, x, y, z]", orientation)),
    h("div", { class: "row" }, field("Program's joints", joints), send), out);
}

function exportsSection(tree) {
  // Saved through the API (its key sent), as the calibration page saves a robot's exports.
  const message = h("div", { id: "tree-export-message" });
  const base = `/v1/robot-trees/${tree.id}/exports`;
  const saving = (text, path, accept, name, id) => h("button", { type: "button", class: "link", id, onclick: async () => {
    try {
      const response = await api(path, { raw: true, accept });
      download(name, await response.blob(), accept);
    } catch (error) {
      fill(message, errorBox(error, "tree-export-error"));
    }
  } }, text);
  const items = [saving("DH tables (JSON)", `${base}/dh?format=json`, "application/json", `${tree.name}-dh.json`, "tree-export-dh"),
    saving("DH tables (CSV)", `${base}/dh?format=csv`, "text/csv", `${tree.name}-dh.csv`, "tree-export-dh-csv")];
  if (tree.source === "urdf") {
    items.push(saving("calibrated URDF", `${base}/urdf?format=urdf`, "application/xml", `${tree.name}.urdf`, "tree-export-urdf"),
      saving("URDF with its frames (JSON)", `${base}/urdf?format=json`, "application/json", `${tree.name}-urdf.json`, "tree-export-urdf-json"));
  }
  return h("section", { id: "tree-exports" }, muted(`The tree at revision ${tree.revision}${tree.source === "urdf" ? "" : " (given as a document: no URDF to write into, its DH tables only)"}.`),
    h("p", {}, ...items.flatMap((a, i) => (i ? [" · ", a] : [a]))), message);
}

// The branches as a tree diagram: the base on the left, each branch a box one column further than its parent,
// the tools as dots right of their branch. Leaves take one row each; a parent sits at the middle of its children.
export function diagram(tree) {
  const children = { base: tree.branches.filter((b) => !b.parent).map((b) => b.name) };
  for (const b of tree.branches) children[b.name] = b.children;
  const depth = { base: 0 }, row = {};
  let next = 0;
  const place = (name, d) => {
    depth[name] = d;
    const kids = children[name] || [];
    kids.forEach((k) => place(k, d + 1));
    row[name] = kids.length ? (row[kids[0]] + row[kids[kids.length - 1]]) / 2 : next++;
  };
  place("base", 0);
  const W = 150, H = 46, BOX = { w: 112, h: 28 };
  const columns = Math.max(...Object.values(depth)) + 2;
  const svg = document.createElementNS(NS, "svg");
  const width = columns * W + 40, height = Math.max(next, 1) * H + 20;
  Object.entries({ id: "tree-diagram", class: "plot tree-diagram", viewBox: `0 0 ${width} ${height}`, width, height, role: "img" }).forEach(([k, v]) => svg.setAttribute(k, v));
  const el = (name, attrs, text) => {
    const node = document.createElementNS(NS, name);
    for (const [k, v] of Object.entries(attrs)) node.setAttribute(k, String(v));
    if (text !== undefined) node.textContent = text;
    svg.appendChild(node);
    return node;
  };
  el("title", {}, `${tree.name}: its branches`);
  const at = (name) => ({ x: 10 + depth[name] * W, y: 10 + row[name] * H });
  for (const [parent, kids] of Object.entries(children)) {
    for (const kid of kids) {
      const a = at(parent), b = at(kid);
      el("line", { class: "tree-edge", "data-from": parent, "data-to": kid, x1: a.x + BOX.w, y1: a.y + BOX.h / 2, x2: b.x, y2: b.y + BOX.h / 2 });
    }
  }
  for (const name of ["base", ...tree.branches.map((b) => b.name)]) {
    const p = at(name);
    const branch = tree.branches.find((b) => b.name === name);
    el("rect", { class: name === "base" ? "tree-node tree-base" : "tree-node", "data-branch": name, x: p.x, y: p.y, width: BOX.w, height: BOX.h, rx: 4 });
    el("text", { x: p.x + 6, y: p.y + 12, class: "tree-label" }, name);
    if (branch) el("text", { x: p.x + 6, y: p.y + 24, class: "tree-sub" }, `${branch.joint_names.length} joints${branch.mount ? ", mount" : ""}`);
    if (branch && branch.tool) {
      el("line", { class: "tree-edge tool-edge", x1: p.x + BOX.w, y1: p.y + BOX.h / 2, x2: p.x + BOX.w + 24, y2: p.y + BOX.h / 2 });
      el("circle", { class: "tree-tool", "data-tool": name, cx: p.x + BOX.w + 30, cy: p.y + BOX.h / 2, r: 6 });
      el("text", { x: p.x + BOX.w + 40, y: p.y + BOX.h / 2 + 4, class: "tree-label" }, `tool ${name}`);
    }
  }
  return svg;
}

function branchesTable(tree) {
  const pos = (p) => (p ? p.position.map((v) => num(v, 5)).join(", ") : "—");
  return table(["branch", "hangs from", "children", "joints", "links", "mount (mm)", "tool (mm)"], tree.branches.map((b) => [b.name, b.parent || "base",
    b.children.join(", ") || "—", b.joint_names.join(", ") || "—", numCell(b.links), pos(b.mount), pos(b.tool)]), "tree-branches");
}

// Mid-range joints in the API's units (degrees, mm): something to draw before anyone types a pose.
function middlePose(tree) {
  return tree.branches.flatMap((b) => b.joint_ranges.map(([lo, hi]) => (lo + hi) / 2));
}

async function drawingSection(container, tree) {
  const pose = h("input", { id: "tree-pose", type: "text", size: 72, value: middlePose(tree).map((v) => +v.toFixed(3)).join(", ") });
  const views = h("div", { class: "row", id: "tree-views" });
  const caption = h("p", { id: "tree-drawn", class: "muted" });
  const tools = h("div", { id: "tree-tools" });
  const message = h("div", { id: "tree-pose-message" });
  const draw = async () => {
    message.replaceChildren();
    const joints = pose.value.split(/[,;\s]+/).filter(Boolean).map(Number);
    try {
      const answer = await api(`/v1/robot-trees/${tree.id}/kinematics`, { method: "POST", json: { joints: [joints], frames: true } });
      showPose(views, caption, tools, tree, joints, answer.poses[0]);
    } catch (error) {
      fill(message, errorBox(error, "tree-pose-error"));
    }
  };
  const button = h("button", { type: "button", id: "tree-draw" }, "Draw the tree at these joints");
  button.addEventListener("click", draw);
  fill(container, h("h2", {}, "The tree drawn"), muted(`Joints in the tree's order (${tree.joint_names.map((n, i) => `${n} ${tree.joint_units[i]}`).join(", ")}).`),
    h("div", { class: "row" }, field("Joints", pose), button), message, views, caption, tools);
  await draw();
}

// Each tool's chain of frames as segments between consecutive frames (a shared branch drawn once), the tools as
// markers: the cell view's orthographic views, each carrying its mapping to mm.
function showPose(views, caption, tools, tree, joints, found) {
  const frames = Object.fromEntries(found.frames.map((f) => [f.name, f]));
  const prims = [], seen = new Set();
  for (const names of Object.values(found.chains)) {
    for (let k = 1; k < names.length; k++) {
      const key = `${names[k - 1]}>${names[k]}`;
      if (seen.has(key)) continue;
      seen.add(key);
      const to = frames[names[k]];
      prims.push({ kind: "beam", a: frames[names[k - 1]].position, b: to.position, cls: `tree-link branch-${to.branch}`,
        data: { branch: to.branch, from: names[k - 1], to: names[k] } });
    }
  }
  prims.push({ kind: "point", at: frames.base.position, cls: "tree-base-point", data: { name: "base" } });
  for (const tool of tree.tools) prims.push({ kind: "marker", at: found.tools[tool].position, cls: "tool-point", data: { tool } });
  drawCell(views, { prims, ranges: [] }, `${tree.name} at revision ${tree.revision}`);
  views.dataset.pose = JSON.stringify(joints);
  caption.textContent = `The tree at ${joints.map((v) => +Number(v).toFixed(3)).join(", ")}: each branch's links from frame to frame, the tools as rings.`;
  const vec = (v) => v.map((x) => num(x, 6)).join(", ");
  const rows = tree.tools.map((t) => [t, vec(found.tools[t].position), vec(found.tools[t].rotation_vector_deg)]);
  const relative = Object.entries(found.relative).map(([label, p]) => [label, vec(p.position), vec(p.rotation_vector_deg)]);
  fill(tools, table(["tool (or tool/frame)", "position (mm)", "rotation vector (°)"], [...rows, ...relative], "tree-tool-poses",
    "Each tool in the world frame, then each tool in another's frame"));
}

function calibrationSection(treeId, last, count) {
  const acc = last.accuracy.map((a) => [a.label, a.frame ? `${a.tool} in ${a.frame}'s frame` : "in the instrument's frame",
    numCell(a.rms_position_mm), numCell(a.max_position_mm), numCell(a.rms_orientation_deg)]);
  const held = last.held_out.map((e) => [e.label, numCell(e.records), numCell(e.rms_mm), numCell(e.max_mm), numCell(e.before_rms_mm)]);
  const fit = last.fit.map((e) => [e.label, numCell(e.records), numCell(e.rms_mm), numCell(e.max_mm)]);
  return h("section", {},
    h("p", { id: "tree-calibration" }, `The last of ${count} calibrations (${when(last.created_at)}, ${last.records} records): ${last.applied ? `applied as revision ${last.revision}` : "not applied"}; `
      + `${last.estimated.length} parameters estimated, ${last.unidentifiable.length} held; variance factor ${num(last.variance_factor)}.`),
    h("p", {}, link(`#/trees/${treeId}/report/${last.id}`, "Report (HTML)", { id: "tree-report-html" }),
      " — each tool's errors and each pair's relative accuracy over the measured region, as figures and tables"),
    table(["tool", "what", "RMS (mm)", "max (mm)", "RMS orientation (°)"], acc, "tree-accuracy", "Predicted accuracy: each tool, then each pair of tools (relative)"),
    table(["records", "count", "RMS (mm)", "max (mm)"], fit, "tree-fit", "The fit's residuals"),
    held.length ? table(["held out", "count", "RMS (mm)", "max (mm)", "before (mm)"], held, "tree-held-out", "Held-out records: after and before the fit") : null);
}
