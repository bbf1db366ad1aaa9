// Jobs: the list (GET /v1/jobs) with progress, cancel and a link to what each created, and the live progress of
// one job (GET /v1/jobs/{id}) that the campaign and pose-design views show while their work runs.
import { api } from "../api.js";
import { errorBox, fill, h, link, muted, statusBadge, table, when } from "../dom.js";

const POLL_MS = 400;
const LIST_POLL_MS = 2000;
const ACTIVE = new Set(["queued", "running"]);
let listTimer = null;

export function stopJobTimers() { clearTimeout(listTimer); }

function progressBar(job) {
  const fraction = job.status === "succeeded" ? 1 : (job.progress && job.progress.fraction) || 0;
  const percent = Math.round(fraction * 100);
  const stage = (job.progress && job.progress.stage) || job.status;
  return h("span", { class: "job-progress" },
    h("span", { class: "progress", role: "progressbar", "aria-valuemin": 0, "aria-valuemax": 100, "aria-valuenow": percent, title: stage },
      h("span", { style: `width:${percent}%` })), ` ${percent} % · ${stage}`);
}

// Where a finished job's outcome is: a calibration's result page (also for a failed one, which is stored), a
// design; null when it produced nothing.
function outcomeHash(job) {
  const id = job.result ? job.result.id : job.error && job.error.calibration_id;
  if (!id) return null;
  return job.kind === "calibration" ? `#/calibrations/${id}` : `#/robots/${job.robot_id}/design?design=${id}`;
}

// The list leaves results out (GET the job for its result), so a succeeded job's link asks for the job first.
// A kind whose outcome has no page here (a program compensation: its answer is shown where it was asked) has none.
function outcomeLink(job, message) {
  if (job.kind !== "calibration" && job.kind !== "pose_design") return null;
  const text = job.kind === "calibration" ? "result" : "design";
  if (job.status === "succeeded") {
    return h("button", { type: "button", class: "link", onclick: async () => {
      try { location.hash = outcomeHash(await api(`/v1/jobs/${job.id}`)); } catch (error) { fill(message, errorBox(error)); }
    } }, text);
  }
  const hash = outcomeHash(job);
  return hash ? link(hash, text) : null;
}

async function cancel(jobId) { return api(`/v1/jobs/${jobId}`, { method: "DELETE" }); }

// ---------------------------------------------------------------- one job, live
// Polls until the job ends, drawing its progress into `container`; resolves with the finished job.
export function watchJob(jobId, container) {
  return new Promise((resolve, reject) => {
    const status = h("p", { id: "job-status", "aria-live": "polite" });
    const cancelButton = h("button", { type: "button", id: "job-cancel" }, "Cancel");
    const message = h("div");
    fill(container, h("div", { class: "job", id: "job" }, h("h3", {}, "Job"), status, cancelButton, message));
    cancelButton.addEventListener("click", async () => {
      cancelButton.disabled = true;
      try { await cancel(jobId); } catch (error) { fill(message, errorBox(error, "cancel-error")); }
    });
    const poll = async () => {
      if (!container.isConnected) return;  // the user went to another page: stop asking
      let job;
      try { job = await api(`/v1/jobs/${jobId}`); } catch (error) { reject(error); return; }
      fill(status, statusBadge(job.status), " ", progressBar(job), job.cancel_requested ? " (cancel requested)" : "");
      if (ACTIVE.has(job.status)) { setTimeout(poll, POLL_MS); return; }
      cancelButton.remove();
      resolve(job);
    };
    poll();
  });
}

// ---------------------------------------------------------------- the list
// The job list (GET /v1/jobs) is newer than some services: ask the service's own contract whether it has it, so
// an older service gets a note instead of a failed request.
let hasJobList = null;
async function jobListAvailable() {
  if (hasJobList === null) {
    const contract = await api("/openapi.json");  // with the key: a service may guard its contract too
    hasJobList = Boolean(contract.paths && contract.paths["/v1/jobs"] && contract.paths["/v1/jobs"].get);
  }
  return hasJobList;
}

export async function jobsView(view) {
  if (!(await jobListAvailable())) {
    fill(view, h("h1", {}, "Jobs"), muted(
      "This service does not list jobs (GET /v1/jobs); each job is still at the status_url its submission returned.", "no-job-list"));
    return;
  }
  const jobs = await api("/v1/jobs");
  const message = h("div", { id: "jobs-message" });
  const cancelCell = (j) => (ACTIVE.has(j.status) && !j.cancel_requested
    ? h("button", { type: "button", class: "link", onclick: async () => {
      try { await cancel(j.id); await jobsView(view); } catch (error) { fill(message, errorBox(error)); }
    } }, "cancel") : "");
  fill(view, h("h1", {}, "Jobs"), message,
    jobs.length === 0 ? muted("No job yet.") :
      table(["submitted", "kind", "robot", "status", "progress", "outcome", ""], jobs.map((j) => [
        when(j.created_at), j.kind, link(`#/robots/${j.robot_id}`, "robot"), statusBadge(j.status), progressBar(j),
        h("span", {}, outcomeLink(j, message), j.error ? h("span", { class: "error" }, ` ${j.error.detail || ""}`) : ""),
        cancelCell(j)]), "jobs"));
  // Refresh while anything runs, only as long as this page is the one shown.
  if (jobs.some((j) => ACTIVE.has(j.status))) listTimer = setTimeout(() => { if (location.hash === "#/jobs") jobsView(view); }, LIST_POLL_MS);
}
