// Validations: records that are not fitted, judged against chosen parameter versions. The file itself is sent
// (text/csv), with the column map and the joints' unit, as a calibration's is: the service's reader decides, so a
// file that calibrates validates. The answer per version is shown with ISO 9283 AP/RP where the campaign repeats
// joint commands, and what the reader noted.
import { api, query } from "../api.js";
import { errorBox, field, fill, h, link, muted, num, numCell, table, when } from "../dom.js";
import { filePicker, showPreview } from "./campaign.js";

export async function validationView(view, robotId) {
  const [robot, versions, validations] = await Promise.all([api(`/v1/robots/${robotId}`),
    api(`/v1/robots/${robotId}/parameter-versions`), api(`/v1/robots/${robotId}/validations`)]);
  const state = { text: null, name: null, csv: null };
  const preview = h("div", { id: "validation-preview" });
  const picker = filePicker("validation-file", "Validation CSV", async (file) => {
    state.text = await file.text();
    state.name = file.name;
    state.csv = showPreview(preview, state, robot);
  });
  const choices = h("fieldset", { id: "validation-versions" }, h("legend", {}, "Versions to judge"),
    versions.map((v) => h("label", { class: "choice" }, h("input", { type: "checkbox", value: v.version, checked: v.current }),
      ` ${v.version} (${v.provenance}${v.current ? ", current" : ""})`)));
  const register = h("input", { type: "checkbox", id: "validation-register" });
  const columns = h("input", { id: "validation-column-map", size: 50, autocomplete: "off", placeholder: "Achse 1=joint_1, Achse 2=joint_2, X_m=x" });
  const jointUnit = h("select", { id: "validation-joint-unit" }, [["", "as the header says (default degrees)"], ["deg", "degrees"], ["rad", "radians"]]
    .map(([value, text]) => h("option", { value }, text)));
  const lengthUnit = h("select", { id: "validation-length-unit" }, ["mm", "m", "cm", "um", "in"].map((u) => h("option", { value: u }, u)));
  const result = h("div", { id: "validation-result" });
  const form = h("form", { id: "validation-form" }, picker, preview, choices,
    h("div", { class: "row" }, field("Column map (file column = joint or coordinate)", columns),
      field("Revolute joints' unit where the header states none", jointUnit),
      field("Length unit where the header states none (points, σ, prismatic joints)", lengthUnit)),
    h("label", {}, register, " Fit the instrument frame to each version first (register)"),
    h("p", {}, h("button", { type: "submit", id: "validate" }, "Validate")), result);
  form.addEventListener("submit", async (event) => {
    event.preventDefault();
    try {
      if (!state.csv) throw new Error("choose or drop a validation CSV first");
      const chosen = [...choices.querySelectorAll("input:checked")].map((i) => Number(i.value));
      const options = { versions: chosen, register: register.checked, notes: `from the browser: ${state.name}`,
        columns: columns.value.trim() || null, joint_unit: jointUnit.value || null, length_unit: lengthUnit.value };
      const answer = await api(`/v1/robots/${robotId}/validations${query(options)}`,
        { method: "POST", body: state.text, type: "text/csv" });
      fill(result, validationResult(answer));
    } catch (error) {
      fill(result, errorBox(error, "validation-error"));
    }
  });
  fill(view, h("p", {}, link(`#/robots/${robotId}`, `← ${robot.name}`)), h("h1", {}, `Validate ${robot.name}`), form,
    h("h2", {}, "Earlier validations"), validationsTable(validations));
}

// One row per (validation, version): the same campaign judged against each version it was asked for.
export function validationsTable(validations) {
  const rows = validations.flatMap((v) => v.results.map((r) => [when(v.created_at), numCell(r.version, 3),
    numCell(v.measurements, 3), numCell(r.position_mm.rms), numCell(r.position_mm.max),
    r.iso9283 ? r.iso9283.poses.map((p) => num(p.AP_mm, 3)).join(" · ") : "—", r.registered ? "yes" : "no"]));
  return rows.length === 0 ? muted("No validation yet.") :
    table(["when", "version", "poses", "RMS (mm)", "max (mm)", "ISO 9283 AP per pose (mm)", "registered"], rows, "validations");
}

function validationResult(v) {
  return h("section", { id: "validation-answer" }, h("h2", {}, `${v.measurements} ${v.measurement} records judged`),
    table(["version", "RMS (mm)", "max (mm)", "percentiles (mm)", "orientation RMS (deg)", "registered"], v.results.map((r) => [
      numCell(r.version, 3), numCell(r.position_mm.rms), numCell(r.position_mm.max),
      r.position_mm.percentiles ? Object.entries(r.position_mm.percentiles).map(([k, x]) => `${k}: ${num(x, 3)}`).join(", ") : "—",
      numCell(r.orientation_deg ? r.orientation_deg.rms : null), r.registered ? "yes" : "no"]), "validation-results"),
    v.results.filter((r) => r.iso9283).map((r) => h("div", {}, h("h3", {}, `ISO 9283, version ${r.version}`),
      table(["pose", "cycles", "AP (mm)", "RP (mm)", "AP orientation (deg)", "RP orientation (deg)"], r.iso9283.poses.map((p, i) => [
        numCell(i + 1), numCell(p.cycles), numCell(p.AP_mm), numCell(p.RP_mm),
        p.AP_abc_deg ? p.AP_abc_deg.map((x) => num(x, 3)).join(", ") : "—", p.RP_abc_deg ? p.RP_abc_deg.map((x) => num(x, 3)).join(", ") : "—"]),
      `iso-${r.version}`))),
    (v.import_notes || []).length ? h("ul", { id: "validation-notes" }, v.import_notes.map((n) => h("li", {}, n))) : null);
}

