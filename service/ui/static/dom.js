// Small DOM helpers shared by the views: element construction, tables, number formats, messages.
import { fieldErrors } from "./api.js";

export function h(tag, attrs = {}, ...children) {
  const node = document.createElement(tag);
  for (const [k, v] of Object.entries(attrs)) {
    if (k.startsWith("on") && typeof v === "function") node.addEventListener(k.slice(2), v);
    else if (v === true) node.setAttribute(k, "");
    else if (v !== null && v !== undefined && v !== false) node.setAttribute(k, String(v));
  }
  for (const c of children.flat()) {
    if (c === null || c === undefined || c === false) continue;
    node.append(c instanceof Node ? c : document.createTextNode(String(c)));
  }
  return node;
}

// Counts and versions stay integers; other numbers get `digits` significant digits.
export const num = (v, digits = 4) => (v === null || v === undefined ? "—"
  : Number.isInteger(v) ? String(v) : Number(v).toPrecision(digits));
export const when = (iso) => (iso ? new Date(iso).toLocaleString() : "—");

export function numCell(v, digits) { return h("td", { class: "num" }, num(v, digits)); }

// rows: arrays of cells; a cell that already is a <td> is kept (numCell), anything else is wrapped.
export function table(headers, rows, id, caption) {
  return h("table", { id },
    caption ? h("caption", {}, caption) : null,
    h("thead", {}, h("tr", {}, headers.map((x) => h("th", { scope: "col" }, x)))),
    h("tbody", {}, rows.map((r) => h("tr", {}, r.map((c) => (c instanceof Node && c.tagName === "TD" ? c : h("td", {}, c ?? "—")))))));
}

export const muted = (text, id) => h("p", { class: "muted", id }, text);

// An API error in words: the problem's detail and, for a validation error, each field.
export function errorBox(error, id = "error") {
  const fields = fieldErrors(error.problem);
  return h("div", { class: "error", id, role: "alert" },
    h("p", {}, String(error.message || error)),
    fields.length ? h("ul", {}, fields.map((f) => h("li", {}, f))) : null);
}

// replaceChildren that skips the null of an absent optional section (replaceChildren would print "null").
export function fill(node, ...children) {
  node.replaceChildren(...children.flat().filter((c) => c !== null && c !== undefined && c !== false));
  return node;
}

export function link(href, text, attrs = {}) { return h("a", { href, ...attrs }, text); }

// A file for the user to keep (a pose design for the pendant, a parameter export).
export function download(name, text, type = "text/csv") {
  const url = URL.createObjectURL(new Blob([text], { type }));
  const a = h("a", { href: url, download: name });
  document.body.append(a);
  a.click();
  a.remove();
  setTimeout(() => URL.revokeObjectURL(url), 1000);
}

// A labelled form control: <label>text <input …></label>, so every field has its name.
export function field(text, control, hint) {
  return h("label", { class: "field" }, h("span", {}, text), control, hint ? h("small", { class: "muted" }, hint) : null);
}

export function statusBadge(status) { return h("span", { class: `status-${status}` }, status); }
