// The cell drawn in orthographic views (from above, from the side, from the front): its obstacles, the tracker
// with its range, the robot's links at a pose and designed TCP positions, one scale for both axes of a view so
// that a box looks like a box. Every position comes from the API: the obstacles from the cell document, the
// links' shapes from GET …/cell's geometry hung on the frames POST …/forward-kinematics (frames: true) answers.
// Only rigid placements are computed here (a shape in its frame), never the robot's kinematics.

const NS = "http://www.w3.org/2000/svg";
const SIZE = 380, M = { left: 62, right: 14, top: 26, bottom: 42 };
const PLOT = SIZE - M.left - M.right;  // a square drawing area: one scale for both axes

// Each view: the title and the two world axes it shows (index into x, y, z) and their names.
export const VIEWS = [
  { id: "cell-top", title: "from above", u: 0, v: 1 },
  { id: "cell-side", title: "from the side", u: 0, v: 2 },
  { id: "cell-front", title: "from the front", u: 1, v: 2 },
];
const AXES = ["x", "y", "z"];

function el(name, attrs, parent) {
  const node = document.createElementNS(NS, name);
  for (const [k, v] of Object.entries(attrs || {})) if (v !== undefined && v !== null) node.setAttribute(k, String(v));
  if (parent) parent.appendChild(node);
  return node;
}

// ---------------------------------------------------------------- rigid placements (rotations, not kinematics)
const DEG = Math.PI / 180;

function matrixOfQuaternion([w, x, y, z]) {
  return [[1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
    [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
    [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)]];
}

// Rodrigues' formula for a rotation vector in degrees.
function matrixOfRotationVector(deg) {
  const r = (deg || [0, 0, 0]).map((v) => v * DEG);
  const angle = Math.hypot(...r);
  if (angle < 1e-12) return [[1, 0, 0], [0, 1, 0], [0, 0, 1]];
  const [x, y, z] = r.map((v) => v / angle), c = Math.cos(angle), s = Math.sin(angle), t = 1 - c;
  return [[t * x * x + c, t * x * y - s * z, t * x * z + s * y],
    [t * x * y + s * z, t * y * y + c, t * y * z - s * x],
    [t * x * z - s * y, t * y * z + s * x, t * z * z + c]];
}

const apply = (R, p) => R.map((row) => row[0] * p[0] + row[1] * p[1] + row[2] * p[2]);
const add = (a, b) => a.map((v, i) => v + b[i]);
const compose = (A, B) => A.map((row) => [0, 1, 2].map((j) => row[0] * B[0][j] + row[1] * B[1][j] + row[2] * B[2][j]));

// A placement {R, p}: world ← frame for an obstacle's pose, or a link frame's pose composed with its shape's.
function placement(position, rotationDeg) { return { R: matrixOfRotationVector(rotationDeg), p: position || [0, 0, 0] }; }
export function framePlacement(frame) { return { R: matrixOfQuaternion(frame.orientation), p: frame.position }; }
function within(outer, inner) { return { R: compose(outer.R, inner.R), p: add(outer.p, apply(outer.R, inner.p)) }; }
export const pointIn = (place, local) => add(place.p, apply(place.R, local));

// ---------------------------------------------------------------- solids as primitives in world mm
// A primitive: {kind: "hull", points} (a convex solid's corners or outline samples), {kind: "faces", faces}
// (a mesh's triangles), {kind: "ball", centre, r}, {kind: "capsule", a, b, r}; cls and data name it for the page.
function corners(size) {
  const out = [];
  for (const sx of [-1, 1]) for (const sy of [-1, 1]) for (const sz of [-1, 1]) out.push([sx * size[0] / 2, sy * size[1] / 2, sz * size[2] / 2]);
  return out;
}

function rim(radius, z) {
  return Array.from({ length: 32 }, (_, k) => [radius * Math.cos((k * Math.PI) / 16), radius * Math.sin((k * Math.PI) / 16), z]);
}

function solid(shape, place) {
  const at = (local) => pointIn(place, local);
  if (shape.kind === "box") return { kind: "hull", points: corners(shape.size_mm).map(at) };
  if (shape.kind === "cylinder") {
    const half = shape.length_mm / 2;
    return { kind: "hull", points: [...rim(shape.radius_mm, -half), ...rim(shape.radius_mm, half)].map(at) };
  }
  if (shape.kind === "sphere") return { kind: "ball", centre: place.p, r: shape.radius_mm };
  if (shape.kind === "capsule") {
    const half = (shape.length_mm || 0) / 2;
    return { kind: "capsule", a: at([0, 0, -half]), b: at([0, 0, half]), r: shape.radius_mm };
  }
  if (shape.kind === "mesh" && shape.vertices_mm) {
    return { kind: "faces", faces: shape.faces.map((f) => f.map((i) => at(shape.vertices_mm[i]))) };
  }
  return null;  // a URDF mesh the service does not model (listed in `skipped`)
}

export function obstaclePrimitives(cell) {
  return (cell.obstacles || []).map((o) => ({ ...solid(o, placement(o.position_mm, o.rotation_vector_deg)),
    cls: `obstacle obstacle-${o.kind}`, data: { name: o.name, kind: o.kind } }));
}

// The robot's effective shapes at one pose: a default capsule between points of two frames (their origins, or a
// hexapod leg's joints), a rigid solid in its frame. `frames`: name → {position, orientation}, one joint vector's answer of the forward kinematics.
export function linkPrimitives(geometry, frames) {
  return geometry.map((shape, k) => {
    const data = { body: shape.body, shape: k, origin: shape.origin };
    if (shape.from_frame) {
      const a = pointIn(framePlacement(frames[shape.from_frame]), shape.from_point_mm || [0, 0, 0]);
      const b = pointIn(framePlacement(frames[shape.to_frame]), shape.to_point_mm || [0, 0, 0]);
      return { kind: "capsule", a, b, r: shape.radius_mm,
        cls: `link link-${shape.origin}`, data: { ...data, from: shape.from_frame, to: shape.to_frame } };
    }
    const place = within(framePlacement(frames[shape.frame]), placement(shape.position_mm, shape.rotation_vector_deg));
    const drawn = solid(shape, place);
    return drawn && { ...drawn, cls: `link link-${shape.origin}`, data: { ...data, frame: shape.frame } };
  }).filter(Boolean);
}

// Where the tracker's beam ends: the reflector, offset_mm in the TCP frame.
export function reflectorPoint(cell, tcp) {
  const offset = (cell.tracker && cell.tracker.reflector && cell.tracker.reflector.offset_mm) || [0, 0, 0];
  return pointIn(framePlacement(tcp), offset);
}

// ---------------------------------------------------------------- the views
function hull2(points) {
  const p = [...points].sort((a, b) => a[0] - b[0] || a[1] - b[1]);
  if (p.length < 3) return p;
  const cross = (o, a, b) => (a[0] - o[0]) * (b[1] - o[1]) - (a[1] - o[1]) * (b[0] - o[0]);
  const half = (list) => list.reduce((h, q) => {
    while (h.length >= 2 && cross(h[h.length - 2], h[h.length - 1], q) <= 0) h.pop();
    h.push(q);
    return h;
  }, []);
  const lower = half(p), upper = half([...p].reverse());
  return [...lower.slice(0, -1), ...upper.slice(0, -1)];
}

// Every world point a primitive reaches in a view (its extent), for the view's bounds.
function extent(prim, view) {
  const uv = (p) => [p[view.u], p[view.v]];
  if (prim.kind === "hull") return prim.points.map(uv);
  if (prim.kind === "faces") return prim.faces.flat().map(uv);
  const round = (c, r) => [[c[view.u] - r, c[view.v] - r], [c[view.u] + r, c[view.v] + r]];
  if (prim.kind === "ball") return round(prim.centre, prim.r);
  if (prim.kind === "capsule") return [...round(prim.a, prim.r), ...round(prim.b, prim.r)];
  if (prim.kind === "point" || prim.kind === "marker") return [uv(prim.at)];
  if (prim.kind === "beam") return [uv(prim.a), uv(prim.b)];
  return [];
}

function niceStep(span) {
  const raw = span / 5, mag = Math.pow(10, Math.floor(Math.log10(raw)));
  return [1, 2, 2.5, 5, 10].map((f) => f * mag).find((s) => s >= raw);
}

// The view's square window in world mm: every primitive inside, a margin, the longer side for both axes.
function windowOf(prims, view) {
  const pts = prims.flatMap((p) => extent(p, view));
  const us = pts.map((p) => p[0]), vs = pts.map((p) => p[1]);
  const [u0, u1, v0, v1] = pts.length ? [Math.min(...us), Math.max(...us), Math.min(...vs), Math.max(...vs)] : [-500, 500, -500, 500];
  const side = Math.max(u1 - u0, v1 - v0, 100) * 1.1;
  const cu = (u0 + u1) / 2, cv = (v0 + v1) / 2;
  return { u0: cu - side / 2, v1: cv + side / 2, k: PLOT / side, side };
}

function axes(svg, win, view) {
  const sx = (u) => M.left + (u - win.u0) * win.k, sy = (v) => M.top + (win.v1 - v) * win.k;
  const step = niceStep(win.side);
  for (let t = Math.ceil(win.u0 / step) * step; t <= win.u0 + win.side; t += step) {
    el("line", { x1: sx(t), x2: sx(t), y1: M.top, y2: M.top + PLOT, class: "grid" }, svg);
    el("text", { x: sx(t), y: M.top + PLOT + 14, "text-anchor": "middle" }, svg).textContent = +t.toPrecision(6);
  }
  for (let t = Math.ceil((win.v1 - win.side) / step) * step; t <= win.v1; t += step) {
    el("line", { x1: M.left, x2: M.left + PLOT, y1: sy(t), y2: sy(t), class: "grid" }, svg);
    el("text", { x: M.left - 4, y: sy(t) + 4, "text-anchor": "end" }, svg).textContent = +t.toPrecision(6);
  }
  el("rect", { x: M.left, y: M.top, width: PLOT, height: PLOT, class: "axis frame" }, svg);
  el("text", { x: M.left + PLOT / 2, y: SIZE - 8, "text-anchor": "middle", class: "axis-label" }, svg).textContent = `${AXES[view.u]} (mm)`;
  el("text", { x: 12, y: M.top + PLOT / 2, transform: `rotate(-90 12 ${M.top + PLOT / 2})`, "text-anchor": "middle", class: "axis-label" }, svg)
    .textContent = `${AXES[view.v]} (mm)`;
  return { sx, sy };
}

function dataAttrs(prim) {
  return Object.fromEntries(Object.entries(prim.data || {}).map(([k, v]) => [`data-${k}`, v]));
}

function drawPrimitive(g, prim, view, s) {
  const xy = (p) => [s.sx(p[view.u]), s.sy(p[view.v])];
  const attrs = { class: prim.cls, ...dataAttrs(prim) };
  const poly = (points) => points.map((p) => p.join(",")).join(" ");
  if (prim.kind === "hull") return el("polygon", { ...attrs, points: poly(hull2(prim.points.map(xy))) }, g);
  if (prim.kind === "faces") {
    const group = el("g", attrs, g);
    prim.faces.forEach((f) => el("polygon", { points: poly(f.map(xy)) }, group));
    return group;
  }
  if (prim.kind === "ball") return el("circle", { ...attrs, cx: xy(prim.centre)[0], cy: xy(prim.centre)[1], r: prim.r * s.k }, g);
  if (prim.kind === "capsule") {
    const [a, b] = [xy(prim.a), xy(prim.b)];
    return el("line", { ...attrs, x1: a[0], y1: a[1], x2: b[0], y2: b[1], "stroke-width": 2 * prim.r * s.k, "stroke-linecap": "round" }, g);
  }
  if (prim.kind === "beam") {
    const [a, b] = [xy(prim.a), xy(prim.b)];
    return el("line", { ...attrs, x1: a[0], y1: a[1], x2: b[0], y2: b[1] }, g);
  }
  const [x, y] = xy(prim.at);
  return el("circle", { ...attrs, cx: x, cy: y, r: prim.kind === "marker" ? 6 : 3 }, g);
}

// A range (the tracker's, the ballbar's) as circles around a point, clipped by the view: a 20 m range must not
// shrink the cell to a dot, so ranges do not count in the window.
function drawRange(g, range, view, s) {
  for (const [r, cls] of [[range.min, "range range-min"], [range.max, "range range-max"]]) {
    if (!(r > 0)) continue;
    el("circle", { class: cls, cx: s.sx(range.at[view.u]), cy: s.sy(range.at[view.v]), r: r * s.k, "data-radius-mm": r }, g);
  }
}

// scene: {prims: [...], ranges: [{at, min, max}]}; one SVG per view in `container`, each carrying its mapping
// (data-u0, data-v1 in mm, data-scale in px per mm, data-left, data-top) so a reader can measure it.
export function drawCell(container, scene, caption) {
  container.replaceChildren();
  for (const view of VIEWS) {
    const win = windowOf(scene.prims, view);
    const svg = el("svg", { id: view.id, class: "plot cell-view", viewBox: `0 0 ${SIZE} ${SIZE}`, width: SIZE, height: SIZE, role: "img",
      "data-u0": win.u0, "data-v1": win.v1, "data-scale": win.k, "data-left": M.left, "data-top": M.top,
      "data-axes": `${AXES[view.u]}${AXES[view.v]}` });
    el("title", {}, svg).textContent = `${caption}, ${view.title}`;
    const s = { ...axes(svg, win, view), k: win.k };
    el("clipPath", { id: `${view.id}-clip` }, svg).appendChild(el("rect", { x: M.left, y: M.top, width: PLOT, height: PLOT }));
    const g = el("g", { "clip-path": `url(#${view.id}-clip)` }, svg);
    for (const range of scene.ranges || []) drawRange(g, range, view, s);
    for (const prim of scene.prims) drawPrimitive(g, prim, view, s);
    el("text", { x: M.left, y: 16, class: "view-title" }, svg).textContent = `${caption}, ${view.title}`;
    container.appendChild(svg);
  }
}

// The instruments as primitives and ranges: the tracker (a marker, its range, the beam to the reflector when a
// pose is drawn), a camera and a ballbar's pivot as markers.
export function instrumentScene(cell, reflector, beamClass) {
  const prims = [], ranges = [];
  if (cell.tracker) {
    const t = cell.tracker;
    prims.push({ kind: "marker", at: t.position_mm, cls: "instrument tracker", data: { name: "tracker" } });
    ranges.push({ at: t.position_mm, min: t.range_min_mm, max: t.range_max_mm });
    if (reflector) prims.push({ kind: "beam", a: t.position_mm, b: reflector, cls: `beam ${beamClass || ""}`, data: { name: "beam" } });
  }
  if (cell.camera) prims.push({ kind: "marker", at: cell.camera.position_mm, cls: "instrument camera", data: { name: "camera" } });
  if (cell.ballbar) {
    prims.push({ kind: "marker", at: cell.ballbar.pivot_mm, cls: "instrument ballbar", data: { name: "ballbar" } });
    ranges.push({ at: cell.ballbar.pivot_mm, min: cell.ballbar.length_min_mm, max: cell.ballbar.length_max_mm });
  }
  return { prims, ranges };
}

// The whole scene of a stored cell (GET …/cell's answer): obstacles, instruments, the robot's shapes at one
// pose's frames (null: no robot drawn) with the beam to its reflector, and TCP positions (a design's) as points.
export function sceneOf(stored, frames, options = {}) {
  const reflector = frames ? reflectorPoint(stored.cell, frames.tcp) : null;
  const instruments = instrumentScene(stored.cell, reflector, options.beamClass);
  const points = (options.points || []).map((at, k) => ({ kind: "point", at, cls: "tcp-point", data: { pose: k + 1 } }));
  const links = frames ? linkPrimitives(stored.geometry, frames) : [];
  return { prims: [...obstaclePrimitives(stored.cell), ...links, ...points, ...instruments.prims], ranges: instruments.ranges };
}
