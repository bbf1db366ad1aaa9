// The calibration workbench in the browser: robots, pose design, campaign upload and calibration as a job,
// the result, validations, versions, the cell, adaptive campaigns, robots of several chains and jobs. Every number comes from the public /v1 API, so the page shows
// exactly what a client sees. Routing is the URL fragment (#/robots/…), one view module per page.
import { apiKey, setApiKey } from "./api.js";
import { errorBox, fill } from "./dom.js";
import { adaptiveCampaignView, adaptiveStartView } from "./views/adaptive.js";
import { calibrationView } from "./views/calibration.js";
import { campaignView } from "./views/campaign.js";
import { cellView } from "./views/cell.js";
import { designView } from "./views/design.js";
import { jobsView, stopJobTimers } from "./views/jobs.js";
import { programsIndex, programsView } from "./views/programs.js";
import { reportView, treeReportView } from "./views/report.js";
import { robotView } from "./views/robot.js";
import { robotsView } from "./views/robots.js";
import { treeView, treesView } from "./views/tree.js";
import { validationView } from "./views/validation.js";

const view = document.getElementById("view");
const keyInput = document.getElementById("api-key");
keyInput.value = apiKey();
// A new key redraws the page with it; an unchanged one (a second change event) must not wipe a half-filled form.
keyInput.addEventListener("change", () => {
  if (keyInput.value === apiKey()) return;
  setApiKey(keyInput.value);
  route();
});

// "#/robots/ID/design?design=X" → ["robots", "ID", "design"] and its parameters.
function parse(hash) {
  const [path, search] = hash.replace(/^#\/?/, "").split("?");
  return { parts: path.split("/").filter(Boolean), params: new URLSearchParams(search || "") };
}

function pick(parts, params) {
  const [first, id, sub, item] = parts;
  if (first === "robots" && id && sub === "adaptive" && item) return () => adaptiveCampaignView(view, id, item);
  if (first === "robots" && id && sub === "adaptive") return () => adaptiveStartView(view, id);
  if (first === "robots" && id && sub === "design") return () => designView(view, id, params);
  if (first === "robots" && id && sub === "calibrate") return () => campaignView(view, id);
  if (first === "robots" && id && sub === "validate") return () => validationView(view, id);
  if (first === "robots" && id && sub === "programs") return () => programsView(view, id);
  if (first === "robots" && id && sub === "cell") return () => cellView(view, id, params);
  if (first === "robots" && id) return () => robotView(view, id);
  if (first === "calibrations" && id && sub === "report") return () => reportView(view, id);
  if (first === "calibrations" && id) return () => calibrationView(view, id);
  if (first === "trees" && id && sub === "report" && item) return () => treeReportView(view, id, item);
  if (first === "trees" && id) return () => treeView(view, id);
  if (first === "trees") return () => treesView(view);
  if (first === "jobs") return () => jobsView(view);
  if (first === "programs") return () => programsIndex(view);
  return () => robotsView(view);
}

// body.dataset.ready names the page once drawn (the browser tests wait for it), "error" when it failed.
async function route() {
  stopJobTimers();
  const { parts, params } = parse(location.hash);
  delete document.body.dataset.ready;
  try {
    await pick(parts, params)();
    document.body.dataset.ready = location.hash || "#/";
  } catch (error) {
    fill(view, errorBox(error));
    document.body.dataset.ready = "error";
  }
  document.title = `${(view.querySelector("h1") || {}).textContent || "Robot calibration"} — robot calibration`;
}

window.addEventListener("hashchange", route);
route();
