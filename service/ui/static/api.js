// One fetch wrapper for the public /v1 API, so every view reports the service's RFC 9457 problem documents the
// same way: in words (detail, then each field error), never as an object. The API key, when the service has
// keys, is kept in this browser's storage and sent as X-API-Key.

const KEY_STORAGE = "iwr-api-key";

export function apiKey() { return localStorage.getItem(KEY_STORAGE) || ""; }
export function setApiKey(value) { localStorage.setItem(KEY_STORAGE, value); }

export class ApiError extends Error {
  constructor(status, problem) {
    super(problemText(status, problem));
    this.status = status;
    this.problem = problem;  // the whole document: views read extension members (calibration_id, diagnoses)
  }
}

// A problem document as one paragraph; `errors` (a validation error's list) adds "field: message" items.
export function problemText(status, problem) {
  if (status === 401 && apiKey()) {
    return "401: the service refused the API key given in the field at the top of the page: check it.";
  }
  if (status === 401) {
    return "401: the service asks for an API key. Enter a key in the API key field at the top of the page "
      + "(make run starts the service without keys; this one was started with IWR_API_KEYS or a key file).";
  }
  if (status === 403) return `403: this API key may not do that (${problem.detail || "its scope is too low"}).`;
  const detail = typeof problem.detail === "string" ? problem.detail : (problem.title || "the request failed");
  return `${status}: ${detail}`;
}

export function fieldErrors(problem) {
  if (!problem || !Array.isArray(problem.errors)) return [];
  return problem.errors.map((e) => `${e.field || (e.loc || []).join(".")}: ${e.msg || e.message || ""}`);
}

async function readProblem(response) {
  const text = await response.text();
  try { return JSON.parse(text); } catch (_) { return { detail: text.trim() || response.statusText }; }
}

// options: method, json (a body to send as JSON), body + type (any other body), accept, headers (more of them),
// raw (the Response).
export async function api(path, options = {}) {
  const headers = { Accept: options.accept || "application/json" };
  let body = options.body;
  if (options.json !== undefined) {
    headers["Content-Type"] = "application/json";
    body = JSON.stringify(options.json);
  } else if (options.type) {
    headers["Content-Type"] = options.type;
  }
  Object.assign(headers, options.headers || {});  // If-Match on a write that must not overwrite another's
  if (apiKey()) headers["X-API-Key"] = apiKey();
  const response = await fetch(path, { method: options.method || "GET", headers, body });
  if (!response.ok) throw new ApiError(response.status, await readProblem(response));
  if (options.raw) return response;
  return response.status === 204 ? null : response.json();
}

// A query string from the defined values only (arrays repeat their key, as FastAPI reads them).
export function query(params) {
  const search = new URLSearchParams();
  for (const [k, v] of Object.entries(params)) {
    if (v === null || v === undefined || v === "") continue;
    for (const item of Array.isArray(v) ? v : [v]) search.append(k, String(item));
  }
  const text = search.toString();
  return text ? `?${text}` : "";
}
