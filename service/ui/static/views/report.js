// A calibration's HTML report (a robot's, or a robot tree's), as the service renders it, inside the page.
import { api } from "../api.js";
import { fill, h, link } from "../dom.js";

export async function reportView(view, id) {
  const response = await api(`/v1/calibrations/${id}/report`, { raw: true, accept: "text/html" });
  // sandbox with no allow-*: the report (the service's own HTML, but it quotes names users typed) runs no script
  // and gets a unique origin, so it can neither read this page's API key nor call the API.
  const frame = h("iframe", { id: "report", title: "calibration report", class: "report", sandbox: "" });
  frame.srcdoc = await response.text();
  fill(view, h("p", {}, link(`#/calibrations/${id}`, "← the result")), frame);
}

// A tree calibration's report: the same sandboxed frame (it quotes the tree's and its branches' typed names).
export async function treeReportView(view, treeId, calibrationId) {
  const response = await api(`/v1/robot-trees/${treeId}/calibrations/${calibrationId}/report`, { raw: true, accept: "text/html" });
  const frame = h("iframe", { id: "report", title: "tree calibration report", class: "report", sandbox: "" });
  frame.srcdoc = await response.text();
  fill(view, h("p", {}, link(`#/trees/${treeId}`, "← the tree")), frame);
}
