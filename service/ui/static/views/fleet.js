// A robot's fleet (GET /v1/robots/{id}/fleet): the robots of its structure document, how many are calibrated (a
// current version from a calibration without a prior), whether their population can be this robot's prior and,
// if not, how many more calibrated units it needs; the units flagged as outliers; the population per parameter.
import { api } from "../api.js";
import { errorBox, h, link, muted, num, numCell, table } from "../dom.js";

// The calibrated units a calibration of `robotId` with the fleet's prior would lean on: the robot itself is never
// part of its own prior (services/fleets.py: population(without=robot)).
export function priorUnits(fleet, robotId) {
  return fleet.units.filter((u) => u.calibrated && u.robot_id !== robotId).length;
}

// One sentence: available, or how many more calibrated units are needed, for this robot's calibration.
export function priorSentence(fleet, robotId) {
  if (!fleet) return "The fleet could not be read: the service decides when the request is sent.";
  const others = priorUnits(fleet, robotId);
  if (others >= fleet.needed) {
    return `A prior is available: ${others} other calibrated units of this structure (a prior needs ${fleet.needed}).`;
  }
  const more = fleet.needed - others;
  return `No prior yet: the fleet has ${others} other calibrated unit${others === 1 ? "" : "s"} and a prior needs ${fleet.needed}; `
    + `calibrate ${more} more robot${more === 1 ? "" : "s"} of this structure without a prior first.`;
}

// The fleet's own errors stay in its section: the rest of the robot's page does not depend on it.
export async function fleetSection(robot) {
  let fleet;
  try { fleet = await api(`/v1/robots/${robot.id}/fleet`); } catch (error) { return h("div", { id: "fleet" }, errorBox(error, "fleet-error")); }
  const figure = (key, label, value) => h("div", { class: "figure" }, h("dt", {}, label),
    h("dd", { "data-key": key, "data-value": value, id: `fleet-${key}` }, num(value)));
  const section = h("div", { id: "fleet", "data-fleet": fleet.fleet },
    muted(`Fleet ${fleet.fleet}: the robots sharing ${robot.name}'s structure document (base and tool guesses aside).`),
    h("dl", { class: "figures" },
      figure("units", "units", fleet.units.length), figure("calibrated", "calibrated (without a prior)", fleet.calibrated),
      figure("needed", "calibrated units a prior needs", fleet.needed), figure("outliers", "outlier units", fleet.outliers.length),
      figure("prior_units", `calibrated units besides ${robot.name}`, priorUnits(fleet, robot.id))),
    h("p", { id: "fleet-prior", class: priorUnits(fleet, robot.id) >= fleet.needed ? "status-succeeded" : "" }, priorSentence(fleet, robot.id)),
    unitsTable(fleet, robot.id));
  if (fleet.parameters.length) section.append(populationTable(fleet));
  return section;
}

function outlierCell(u) {
  if (u.outlier === true) return h("td", { class: "status-failed" }, "outlier");
  if (u.outlier === false) return h("td", {}, "like the others");
  return h("td", { class: "muted" }, "—");  // not calibrated, or too few others to judge it by
}

function unitsTable(fleet, robotId) {
  return table(["unit", "version", "calibrated", "outlier", "its worst parameter", "z (spreads off)"],
    fleet.units.map((u) => [u.robot_id === robotId ? h("b", {}, u.name) : link(`#/robots/${u.robot_id}`, u.name),
      numCell(u.version, 3), u.calibrated ? "yes" : "no", outlierCell(u), u.worst_parameter || "—", numCell(u.worst_z, 3)]),
    "fleet-units", "Outliers are judged leave-one-out: each calibrated unit against the population of the others.");
}

function populationTable(fleet) {
  const holder = h("div", { class: "scroll" }, table(["parameter", "mean deviation from nominal", "spread (1 σ)", "units", "unit"],
    fleet.parameters.map((p) => [p.name, numCell(p.mean_offset, 3), numCell(p.spread, 3), numCell(p.units, 3), p.unit]), "fleet-population"));
  return h("details", { id: "fleet-population-details" },
    h("summary", {}, `The population: ${fleet.parameters.length} parameters (the base, each campaign's instrument frame, has none)`), holder);
}

// The fleet for a form's note, or null when it cannot be read (the form works without it).
export const fleetOrNull = (robotId) => api(`/v1/robots/${robotId}/fleet`).catch(() => null);

// Beside a refusal: the fleet-too-small problem's own counts in words; `option` names the form's checkbox.
export function fleetRefusal(problem, option = "Calibrate with the fleet's prior") {
  if (!problem || typeof problem.type !== "string" || !problem.type.endsWith("/fleet-too-small")) return null;
  const more = problem.needed - problem.units;
  return h("p", { id: "fleet-too-small" }, `The fleet has ${problem.units} other calibrated unit${problem.units === 1 ? "" : "s"}; `
    + `its prior needs ${problem.needed}. Calibrate ${more} more robot${more === 1 ? "" : "s"} of this structure without the prior `
    + `first, or untick “${option}”.`);
}

