// Reading a campaign CSV in the browser, by the rules of the service's tolerant reader (service/campaign_io):
// a BOM, `#` comments and blank lines dropped; `,` `;` or tab, whichever the header uses most; decimal commas
// with `;` or tab; names lowered, spaces to `_`, a trailing unit `X [m]` read. The preview shows which columns the
// service will read. Calibrations and validations send the file itself: there the service's reader is the one
// that counts; an adaptive campaign's records (a JSON-only route) are the ones built here.

const DELIMITERS = [",", ";", "\t"];
const MM_PER = { mm: 1, m: 1000, cm: 10, um: 1e-3, "µm": 1e-3, in: 25.4, inch: 25.4 };
const DEG_PER = { deg: 1, "°": 1, degree: 1, degrees: 1, rad: 180 / Math.PI };
const ALIASES = {
  pose_id: ["pose_id", "pose", "id", "point_id", "point", "name", "point_name", "feature_name", "feature", "label",
    "nr", "nr.", "no", "no.", "point_no", "point_no."],
  x: ["x", "meas_x", "x_meas", "measured_x", "x_measured", "actual_x", "x_actual"],
  y: ["y", "meas_y", "y_meas", "measured_y", "y_measured", "actual_y", "y_actual"],
  z: ["z", "meas_z", "z_meas", "measured_z", "z_measured", "actual_z", "z_actual"],
  qw: ["qw", "w"], qx: ["qx"], qy: ["qy"], qz: ["qz"],
  sigma_mm: ["sigma_mm", "sigma", "uncertainty", "std", "std_dev", "stdev", "rms", "marker_std", "marker_sigma"], u95: ["u95", "u95_mm", "expanded_uncertainty"],
  temperature_c: ["temperature_c", "temperature", "temp", "temp.", "air_temperature", "air_temp"],
  reflector: ["reflector", "reflector_name", "smr", "probe", "target_type"],
};
const ROLE_WORDS = { x: "position x", y: "position y", z: "position z", qw: "orientation qw", qx: "orientation qx",
  qy: "orientation qy", qz: "orientation qz", sigma_mm: "σ of the record", u95: "U95 (σ = U95 / 2)",
  temperature_c: "temperature (°C)", pose_id: "pose id", reflector: "reflector's name (noted)" };
const IGNORED_KNOWN = ["timestamp", "time", "datetime", "date_time", "date", "collection", "group"];
const JOINT_STYLES = ["q", "a", "j", "axis", "joint"];
const LEGS = ["l1", "l2", "l3", "l4", "l5", "l6"];

// `X [mm]`, `X (mm)` and `x_mm` state a unit (`_rad`, `_deg` too); `U(95)` is a name, not a unit.
const SUFFIX_UNITS = { _rad: "rad", _deg: "deg", _mm: "mm" };
function nameAndUnit(raw) {
  const match = raw.trim().match(/^(.*?)\s*[[(]([^\])]*)[\])]$/);
  if (match && !/^\s*\d+\s*$/.test(match[2])) return [match[1], match[2].trim().toLowerCase()];
  const lowered = raw.trim().toLowerCase();
  for (const [suffix, unit] of Object.entries(SUFFIX_UNITS)) {
    if (lowered.endsWith(suffix) && lowered.length > suffix.length) return [raw.trim().slice(0, -suffix.length), unit];
  }
  return [raw, null];
}
export const normalise = (raw) => nameAndUnit(raw)[0].replace(/[[\]()]/g, "").trim().toLowerCase().replace(/[\s-]+/g, "_");

// One line into cells, with "quoted, cells" as csv writers make them.
function splitLine(line, delimiter) {
  const cells = [];
  let cell = "", quoted = false;
  for (let i = 0; i < line.length; i++) {
    const c = line[i];
    if (quoted && c === '"' && line[i + 1] === '"') { cell += '"'; i++; }
    else if (c === '"') quoted = !quoted;
    else if (c === delimiter && !quoted) { cells.push(cell); cell = ""; }
    else cell += c;
  }
  cells.push(cell);
  return cells;
}

// The joint columns in the robot's order: serial joints 1 … m in one numbering style, then a hexapod's legs.
// The numbering may carry a URDF's prefix and underscore (`joint_1`, `panda_joint1`), as the service reads it.
const NUMBERED = new RegExp(`^((?:[a-z][a-z0-9]*_)*(?:${JOINT_STYLES.join("|")})_?)([1-9][0-9]*)$`);
function jointColumns(columns) {
  if (columns.includes("q0")) return [];  // a Leica q0…q3 quaternion: the service names the clash
  const styles = new Map();
  for (const c of columns) {
    const m = c.match(NUMBERED);
    if (m) styles.set(m[1], [...(styles.get(m[1]) || []), c]);
  }
  for (const [prefix, serial] of styles) {
    serial.sort((a, b) => Number(a.slice(prefix.length)) - Number(b.slice(prefix.length)));
    return [...serial, ...LEGS.filter((l) => columns.includes(l))];
  }
  return LEGS.filter((l) => columns.includes(l));
}

// A report's preamble (PC-DMIS `PART NAME : …`, CAM2's title and `Units: …`): lines of at most two fields above
// the first wider line, the header.
function headerIndex(lines) {
  const width = (t) => Math.max(...DELIMITERS.map((d) => t.split(d).length));
  const k = lines.slice(0, 31).findIndex((l) => width(l.text) > 2);
  return k < 0 ? 0 : k;
}

// columns: normalised names; units: name → unit; rows: arrays of strings; roles: name → what it is read as.
export function readCsv(text) {
  const lines = text.replace(/^\ufeff/, "").split(/\r\n|\r|\n/)
    .map((t, k) => ({ line: k + 1, text: t })).filter((l) => l.text.trim() && !l.text.trim().startsWith("#"));
  if (lines.length === 0) throw new Error("the file has no header and no data (only blank or comment lines)");
  lines.splice(0, headerIndex(lines));
  const header = lines[0].text;
  const delimiter = DELIMITERS.reduce((best, d) => (header.split(d).length > header.split(best).length ? d : best), ",");
  const raw = splitLine(header, delimiter);
  const columns = raw.map(normalise);
  const units = Object.fromEntries(raw.map((r, i) => [columns[i], nameAndUnit(r)[1]]).filter(([, u]) => u));
  const rows = lines.slice(1).map((l) => ({ line: l.line, cells: splitLine(l.text, delimiter) }));
  const decimalComma = delimiter !== "," && rows.slice(0, 50).some((r) => r.cells.some((c) => /^[+-]?\d+,\d+([eE][+-]?\d+)?$/.test(c.trim())));
  return { columns, units, rows, delimiter, decimalComma, roles: roles(columns), joints: jointColumns(columns) };
}

// Column → the canonical name it is read as (x, qw, sigma_mm, …), by the service reader's aliases.
function canonical(columns) {
  const found = {};
  for (const [name, aliases] of Object.entries(ALIASES)) {
    const alias = aliases.find((a) => columns.includes(a));
    if (alias) found[alias] = name;
  }
  if (columns.includes("q0")) for (const [i, q] of ["qw", "qx", "qy", "qz"].entries()) found[`q${i}`] = q;
  // `target`: SpatialAnalyzer's point name, or Leica's reflector; the preview cannot see the rows, the service can.
  if (columns.includes("target") && !Object.values(found).includes("pose_id")) found.target = "pose_id";
  else if (columns.includes("target")) found.target = "reflector";
  return found;
}

// Column → what the preview says it is read as.
function roles(columns) {
  const joints = new Set(jointColumns(columns));
  const found = canonical(columns);
  const order = [...joints];
  return Object.fromEntries(columns.map((c) => {
    if (joints.has(c)) return [c, `joint ${order.indexOf(c) + 1}`];
    if (found[c]) return [c, ROLE_WORDS[found[c]] || found[c]];
    if (c === "kind") return [c, "record kind (distance, point, plane rows: the service reads them)"];
    if (IGNORED_KNOWN.includes(c)) return [c, "known, not used"];
    const point = pointOf(c);
    if (point) return [c, `point ${point.name} ${point.axis} (several points a row: the lowest the TCP's, the others reflector records)`];
    return [c, "ignored"];
  }));
}

// A row of several points, as the service reads it (service/campaign_io/wide.py): `x2`, `x_2`, `marker2_x`.
function pointOf(column) {
  const numbered = column.match(/^([xyz])_?([1-9][0-9]*)$/);
  if (numbered) return { name: `p${numbered[2]}`, axis: numbered[1] };
  const named = column.match(/^([a-z]+?)_?([1-9][0-9]*)_([xyz])$/);
  return named ? { name: `${named[1]}${named[2]}`, axis: named[3] } : null;
}

function numberOf(table, row, column) {
  let text = (row.cells[table.columns.indexOf(column)] || "").trim();
  if (table.decimalComma) text = text.replace(",", ".");
  const value = Number(text);
  if (text === "" || !Number.isFinite(value)) {
    throw new Error(`line ${row.line}, column ${table.columns.indexOf(column) + 1} (${column}): '${text}' is not a number`);
  }
  return value;
}

const lengthFactor = (table, column) => MM_PER[table.units[column] || "mm"] ?? 1;

// The API's tracker records (joints, position, orientation, sigma_mm, temperature_c) from a table; the joints in
// the robot's units, where a header states degrees or radians for a revolute joint.
export function trackerRecords(table) {
  const byRole = Object.fromEntries(Object.entries(canonical(table.columns)).map(([c, r]) => [r, c]));
  for (const needed of ["x", "y", "z"]) {
    if (!byRole[needed]) throw new Error(`the header has no column ${needed} (found: ${table.columns.join(", ")})`);
  }
  if (table.joints.length === 0) throw new Error(`the header names no joint column (found: ${table.columns.join(", ")})`);
  const hasOrientation = ["qw", "qx", "qy", "qz"].every((q) => byRole[q]);
  return table.rows.map((row) => {
    if (row.cells.length !== table.columns.length) {
      throw new Error(`line ${row.line}: ${row.cells.length} cells for the ${table.columns.length} columns of the header`);
    }
    const record = {
      joints: table.joints.map((j) => numberOf(table, row, j) * (DEG_PER[table.units[j]] ?? MM_PER[table.units[j]] ?? 1)),
      position: ["x", "y", "z"].map((k) => numberOf(table, row, byRole[k]) * lengthFactor(table, byRole[k])),
    };
    if (hasOrientation) record.orientation = ["qw", "qx", "qy", "qz"].map((k) => numberOf(table, row, byRole[k]));
    if (byRole.u95) record.sigma_mm = numberOf(table, row, byRole.u95) * lengthFactor(table, byRole.u95) / 2;
    else if (byRole.sigma_mm) record.sigma_mm = numberOf(table, row, byRole.sigma_mm) * lengthFactor(table, byRole.sigma_mm);
    if (byRole.temperature_c) record.temperature_c = numberOf(table, row, byRole.temperature_c);
    return record;
  });
}

// Joint vectors as CSV, the robot's joint names as header (what a pendant program or the campaign file starts from).
export function jointsCsv(names, poses) {
  return [names.join(","), ...poses.map((q) => q.map((v) => Number(v).toFixed(6)).join(","))].join("\n") + "\n";
}

// Joint vectors typed, pasted or dropped, in the API's units (mm and degrees): JSON (an array of vectors, or an
// object whose `poses` or `joints` is one) or CSV, with or without a header. A header's joint columns are the
// robot's names or the campaign reader's (q1…, a1…, joint_1…); a column stating radians is turned into degrees.
export function readJointVectors(text, names) {
  const trimmed = text.replace(/^\ufeff/, "").trim();
  if (!trimmed) throw new Error("no joints: paste one joint vector a line, or a JSON array of them");
  const rows = /^[[{]/.test(trimmed) ? jsonVectors(trimmed) : csvVectors(trimmed, names);
  rows.forEach((q, k) => {
    if (!Array.isArray(q) || q.length !== names.length || q.some((v) => typeof v !== "number" || !Number.isFinite(v))) {
      throw new Error(`pose ${k + 1}: ${names.length} numbers are needed (${names.join(", ")}), got ${JSON.stringify(q)}`);
    }
  });
  return rows;
}

function jsonVectors(text) {
  let data;
  try { data = JSON.parse(text); } catch (error) { throw new Error(`the joints are not valid JSON: ${error.message}`); }
  const rows = Array.isArray(data) ? data : (data.poses || data.joints);
  if (!Array.isArray(rows)) throw new Error("JSON joints: an array of joint vectors, or an object with `poses` or `joints`");
  return rows;
}

function csvVectors(text, names) {
  const lines = text.split(/\r\n|\r|\n/).filter((l) => l.trim() && !l.trim().startsWith("#"));
  const delimiter = DELIMITERS.reduce((best, d) => (lines[0].split(d).length > lines[0].split(best).length ? d : best), ",");
  const cellsOf = (line) => splitLine(line, delimiter).map((c) => c.trim());
  const decimal = (c) => (delimiter === "," ? c : c.replace(",", "."));
  const numeric = (c) => c !== "" && Number.isFinite(Number(decimal(c)));
  const first = cellsOf(lines[0]);
  if (first.every(numeric)) return lines.map((l) => cellsOf(l).map((c) => Number(decimal(c))));
  const columns = first.map(normalise);
  const byName = names.map((n) => columns.indexOf(normalise(n)));
  const picked = byName.every((i) => i >= 0) ? byName : jointColumns(columns).map((c) => columns.indexOf(c));
  if (picked.length !== names.length) {
    throw new Error(`the header names ${picked.length} joint columns, the robot has ${names.length} (${names.join(", ")}); found: ${first.join(", ")}`);
  }
  const factor = picked.map((i) => (nameAndUnit(first[i])[1] === "rad" ? 180 / Math.PI : 1));
  return lines.slice(1).map((l, k) => {
    const cells = cellsOf(l);
    return picked.map((i, j) => {
      if (!numeric(cells[i] ?? "")) throw new Error(`line ${k + 2}, column ${first[i]}: '${cells[i] ?? ""}' is not a number`);
      return Number(decimal(cells[i])) * factor[j];
    });
  });
}
