// A calibration's HTML report, as the service renders it, inside the page.
import { api } from "../api.js";
import { fill, h, link } from "../dom.js";

export async function reportView(view, id) {
  const response = await api(`/v1/calibrations/${id}/report`, { raw: true, accept: "text/html" });
  const frame = h("iframe", { id: "report", title: "calibration report", class: "report" });
  frame.srcdoc = await response.text();
  fill(view, h("p", {}, link(`#/calibrations/${id}`, "← the result")), frame);
}
