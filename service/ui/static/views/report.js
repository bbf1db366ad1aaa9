// A calibration's HTML report, as the service renders it, inside the page.
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
