// A robot's history: every calibration and check on one timeline, the accuracy each measured and predicted plotted
// over time (GET /v1/robots/{id}/history), and its export as CSV (?format=csv).
import { api } from "../api.js";
import { download, errorBox, fill, h, link, muted, numCell, table, when } from "../dom.js";

// The x axis in the unit that suits the timeline's span: seconds or minutes for a session, hours for a shift, days after.
const UNITS = [["seconds", 1_000, 120_000], ["minutes", 60_000, 7_200_000], ["hours", 3_600_000, 172_800_000], ["days", 86_400_000, Infinity]];

export async function historySection(robot) {
  const events = await api(`/v1/robots/${robot.id}/history?limit=1000`);
  const message = h("div", { id: "history-message" });
  const exportCsv = h("button", { type: "button", id: "history-csv", onclick: async () => {
    try {
      const response = await api(`/v1/robots/${robot.id}/history?limit=1000&format=csv`, { raw: true, accept: "text/csv" });
      download(`${robot.name}-history.csv`, await response.text());
    } catch (error) { fill(message, errorBox(error)); }
  } }, "Export CSV");
  const section = h("div", { id: "history" }, h("div", { class: "row" }, exportCsv), message);
  if (events.length === 0) {
    section.append(muted("No calibration or check yet."));
    return section;
  }
  const plotted = h("div", {});
  section.append(plotted, eventsTable(events));
  accuracyPlot(plotted, events);
  return section;
}

// Time since the first event on x (the events' times as tooltips): a calibration's RMS residual after its fit and a
// check's RMS error as "measured", what each predicted as "predicted".
function accuracyPlot(container, events) {
  const times = events.map((e) => Date.parse(e.at)), start = times[0];
  const [unit, ms] = UNITS.find(([, , below]) => times[times.length - 1] - start < below);
  Plot.series(container, {
    id: "history-plot", title: "TCP accuracy over time (mm)", xlabel: `${unit} since the first event`, ylabel: "mm",
    x: times.map((t) => (t - start) / ms),
    labels: events.map((e) => `${e.kind} ${when(e.at)}`),
    series: [
      { name: "measured (RMS)", values: events.map((e) => e.rms_mm) },
      { name: "predicted (1 σ RMS)", values: events.map((e) => e.predicted_mm) },
    ],
  });
}

function eventsTable(events) {
  return table(["when", "event", "version", "outcome", "measured (mm)", "predicted (mm)", "drift (mm)"],
    events.map((e) => [when(e.at),
      e.kind === "calibration" ? link(`#/calibrations/${e.id}`, "calibration") : "check",
      e.version ?? "—", e.outcome, numCell(e.rms_mm), numCell(e.predicted_mm), numCell(e.drift_mm)]), "history-events");
}
