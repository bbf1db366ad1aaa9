"""A typed client of the service's main workflow over urllib: robots, pose designs, calibrations (as jobs with
progress), reports, parameter exports, validations and program compensation. Standard library only, so any
Python ≥ 3.11 runs it.

Millimetres and degrees, as the API takes them; answers are the API's JSON documents as dicts (their keys are
service/openapi.json's). An error answer raises `ApiError` with the problem; no answer, `ServiceUnreachable`.
"""

from __future__ import annotations

import contextlib
import json
import time
import urllib.error
import urllib.parse
import urllib.request
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Literal, overload

from iwr_client.errors import ApiError, JobCancelled, JobFailed, ServiceUnreachable
from iwr_client.programs import ProgramFile, format_of
from iwr_client.records import records_from_csv

Json = dict[str, Any]
Records = Sequence[Mapping[str, Any]]
Campaign = str | Path | Records
"""A campaign file's path (sent as it is, `text/csv`) or records as the API's JSON takes them."""
ProgramSource = str | Path | ProgramFile
"""A program file's path, or its text already read (`ProgramFile(name, text, encoding)`)."""
TERMINAL = frozenset({"succeeded", "failed", "cancelled"})


@dataclass(frozen=True)
class Progress:
    """A job's latest progress point: its stage (reading, identifying, designing, storing, done, …), the fraction
    done in [0, 1], the solver's iteration within the stage and the stage's time left, when the worker knows them."""

    stage: str
    fraction: float
    iteration: int | None = None
    eta_seconds: float | None = None

    @classmethod
    def of(cls, job: Mapping[str, Any]) -> Progress | None:
        point = job.get("progress")
        if not point:
            return None
        return cls(str(point["stage"]), float(point["fraction"]), point.get("iteration"), point.get("eta_seconds"))


@dataclass(frozen=True)
class Answer:
    status: int
    content_type: str
    body: bytes

    def json(self) -> Any:
        return json.loads(self.body)


def _problem(status: int, reason: str, content_type: str, body: bytes) -> Json:
    """The problem document of an error answer; anything else (a proxy's page) wrapped as one."""
    if "json" in content_type:
        try:
            document = json.loads(body)
        except ValueError:
            document = None
        if isinstance(document, dict):
            return {"status": status, "title": reason, "detail": "", **document}
    text = body.decode("utf-8", "replace").strip()[:300]
    return {"type": "about:blank", "title": reason, "status": status, "detail": text or reason}


class Client:
    """`Client("http://127.0.0.1:8000", api_key=...)`; `timeout` bounds each request, in seconds."""

    def __init__(self, base_url: str = "http://127.0.0.1:8000", api_key: str | None = None, timeout: float = 60.0):
        self.base_url = base_url.rstrip("/")
        self.api_key = api_key
        self.timeout = timeout

    # -- the HTTP exchange ------------------------------------------------------------------------------------

    def request(
        self,
        method: str,
        path: str,
        *,
        query: Mapping[str, object] | None = None,
        json_body: object = None,
        data: bytes | None = None,
        content_type: str | None = None,
        accept: str = "application/json",
        if_match: str | None = None,
    ) -> Answer:
        """One request; an error status raises `ApiError`, no answer `ServiceUnreachable`. `if_match`: the
        robot's ETag as last read (a 412 `ApiError` when it has changed since)."""
        url = self.base_url + path
        if query:
            url += "?" + urllib.parse.urlencode(_query_pairs(query))
        headers = {"Accept": accept + ", application/problem+json"}
        if self.api_key:
            headers["X-API-Key"] = self.api_key
        if json_body is not None:
            data, content_type = json.dumps(json_body).encode(), "application/json"
        if content_type:
            headers["Content-Type"] = content_type
        if if_match is not None:
            headers["If-Match"] = if_match
        request = urllib.request.Request(url, data=data, headers=headers, method=method)
        try:
            with urllib.request.urlopen(request, timeout=self.timeout) as response:
                return Answer(response.status, response.headers.get("Content-Type", ""), response.read())
        except urllib.error.HTTPError as exc:
            body = exc.read()
            raise ApiError(_problem(exc.code, str(exc.reason), exc.headers.get("Content-Type", ""), body)) from None
        except (urllib.error.URLError, OSError) as exc:  # refused, reset, timed out, unresolved
            raise ServiceUnreachable(self.base_url, getattr(exc, "reason", exc)) from None

    def _get(self, path: str, **query: object) -> Any:
        return self.request("GET", path, query=query).json()

    def _post(self, path: str, body: object, **query: object) -> Any:
        return self.request("POST", path, query=query, json_body=body).json()

    # -- what the service knows by name ------------------------------------------------------------------------

    def design_criteria(self) -> list[Json]:
        """The pose-design criteria, each with what it makes small and what it may be used for."""
        return list(self._get("/v1/design-criteria"))

    def adaptive_criteria(self) -> list[Json]:
        """The criteria an adaptive campaign may choose its next pose by, the default marked."""
        return list(self._get("/v1/adaptive-criteria"))

    def record_kinds(self) -> list[Json]:
        """The kinds of record a campaign may hold (a tracker's first), and what a design can do with each."""
        return list(self._get("/v1/record-kinds"))

    # -- robots -----------------------------------------------------------------------------------------------

    def robots(self, limit: int = 100, offset: int = 0) -> list[Json]:
        return list(self._get("/v1/robots", limit=limit, offset=offset))

    def robot(self, robot_id: str) -> Json:
        return dict(self._get(f"/v1/robots/{_segment(robot_id)}"))

    def create_robot(
        self,
        name: str,
        structure: Mapping[str, Any] | None = None,
        *,
        urdf: str | None = None,
        base_link: str | None = None,
        tip_link: str | None = None,
        notes: str | None = None,
    ) -> Json:
        """The IWR by default; another robot from its structure document or a URDF's chain base_link → tip_link."""
        body: Json = {"name": name, "model": "iwr" if structure is None and urdf is None else "custom"}
        extra = {"structure": structure, "urdf": urdf, "base_link": base_link, "tip_link": tip_link, "notes": notes}
        body.update({k: v for k, v in extra.items() if v is not None})
        return dict(self._post("/v1/robots", body))

    # -- jobs -------------------------------------------------------------------------------------------------

    def job(self, job_id: str) -> Json:
        return dict(self._get(f"/v1/jobs/{_segment(job_id)}"))

    def cancel(self, job_id: str) -> Json:
        return dict(self.request("DELETE", f"/v1/jobs/{_segment(job_id)}").json())

    def wait(
        self,
        job_id: str,
        on_progress: Callable[[Progress], None] | None = None,
        *,
        interval: float = 0.25,
        timeout: float | None = None,
    ) -> Json:
        """Polls the job until it ends and answers it; `on_progress` hears each new progress point. Over `timeout`
        seconds it raises TimeoutError (the job runs on: `cancel` stops it)."""
        deadline = None if timeout is None else time.monotonic() + timeout
        last: Progress | None = None
        while True:
            job = self.job(job_id)
            progress = Progress.of(job)
            if on_progress is not None and progress is not None and progress != last:
                on_progress(progress)
                last = progress
            if job["status"] in TERMINAL:
                return job
            if deadline is not None and time.monotonic() > deadline:
                raise TimeoutError(f"job {job_id} still {job['status']} after {timeout} s")
            time.sleep(interval)

    def result(self, job_id: str, on_progress: Callable[[Progress], None] | None = None) -> Json:
        """What a job created, once it ends: `JobFailed` (with the synchronous request's problem) or
        `JobCancelled` otherwise. Interrupted (Ctrl-C) while waiting, it cancels the job before the interrupt goes
        on: `design` and `calibrate` never handed its id back, so nothing else could stop it."""
        try:
            job = self.wait(job_id, on_progress)
        except KeyboardInterrupt:
            # It ended meanwhile (409), or the service went: nothing left to stop.
            with contextlib.suppress(ApiError, ServiceUnreachable):
                self.cancel(job_id)
            raise
        if job["status"] == "failed":
            raise JobFailed(job)
        if job["status"] == "cancelled":
            raise JobCancelled(job)
        return dict(job["result"])

    # -- pose designs -----------------------------------------------------------------------------------------

    def design(
        self,
        robot_id: str,
        count: int | None = None,
        *,
        target_rms_mm: float | None = None,
        criterion: str | None = None,
        measurement: str = "pose",
        candidate_count: int | None = None,
        seed: int | None = None,
        cell: str | Json | None = None,
        async_: bool = False,
        on_progress: Callable[[Progress], None] | None = None,
    ) -> Json:
        """The `count` poses worth measuring, or the fewest that reach `target_rms_mm` (give one). `cell`: design
        only among the poses a cell can measure, "stored" (the robot's) or a cell document. `async_` runs it as a
        job (what designs over the synchronous budget need) and waits for it."""
        if (count is None) == (target_rms_mm is None):
            raise ValueError("give count or target_rms_mm, not both")
        body: Json = {"measurement": measurement}
        extra = {"count": count, "criterion": criterion, "candidate_count": candidate_count, "seed": seed, "cell": cell}
        body.update({k: v for k, v in extra.items() if v is not None})
        if target_rms_mm is not None:
            body["target"] = {"rms_tcp_mm": target_rms_mm}
        path = f"/v1/robots/{_segment(robot_id)}/pose-designs"
        if async_:
            return self.result(self._post(path, body, **{"async": True})["job_id"], on_progress)
        return dict(self._post(path, body))

    # -- the cell -----------------------------------------------------------------------------------------------

    def cell(self, robot_id: str, *, version: int | None = None) -> Json:
        """The robot's current cell (or a past version) with its effective geometry and allowed pairs."""
        return dict(self._get(f"/v1/robots/{_segment(robot_id)}/cell", version=version))

    def put_cell(self, robot_id: str, cell: Json, *, if_match: str | None = None) -> Json:
        """A new version of the robot's cell (mm and degrees: docs/pose-design.md, "The cell")."""
        path = f"/v1/robots/{_segment(robot_id)}/cell"
        return dict(self.request("PUT", path, json_body=cell, if_match=if_match).json())

    def cell_versions(self, robot_id: str, limit: int = 100, offset: int = 0) -> list[Json]:
        return list(self._get(f"/v1/robots/{_segment(robot_id)}/cell/versions", limit=limit, offset=offset))

    def delete_cell(self, robot_id: str, *, if_match: str | None = None) -> None:
        """Ends the robot's cell (its versions stay readable)."""
        self.request("DELETE", f"/v1/robots/{_segment(robot_id)}/cell", if_match=if_match)

    def check_cell(self, robot_id: str, poses: Sequence[Sequence[float]], cell: str | Json = "stored") -> Json:
        """Each pose (joints in mm and degrees) feasible or not in the cell, with its reason and detail."""
        body = {"poses": [list(map(float, p)) for p in poses], "cell": cell}
        return dict(self._post(f"/v1/robots/{_segment(robot_id)}/cell/check", body))

    # -- robots of several chains (a dual-arm torso, an arm and its positioner) ---------------------------------

    def robot_trees(self, limit: int = 100, offset: int = 0) -> list[Json]:
        return list(self._get("/v1/robot-trees", limit=limit, offset=offset))

    def robot_tree(self, tree_id: str) -> Json:
        """The tree: branches, tools, joint names, parameters by name and group (current values)."""
        return dict(self._get(f"/v1/robot-trees/{_segment(tree_id)}"))

    def create_robot_tree(
        self,
        name: str,
        branches: Sequence[Json] | None = None,
        *,
        base: Json | None = None,
        urdf: str | None = None,
        base_link: str | None = None,
        tip_links: Sequence[str] | None = None,
    ) -> Json:
        """A tree from its `branches` (name, parent, mount, stages, tool, joint_names: docs/api.md, "Robots of
        several chains"), or from a `urdf` and the `tip_links` that carry its tools."""
        body: dict[str, object] = {"name": name, "base": base, "branches": branches, "urdf": urdf}
        body |= {"base_link": base_link, "tip_links": None if tip_links is None else list(tip_links)}
        return dict(self._post("/v1/robot-trees", {k: v for k, v in body.items() if v is not None}))

    def delete_robot_tree(self, tree_id: str, *, if_match: str | None = None) -> None:
        self.request("DELETE", f"/v1/robot-trees/{_segment(tree_id)}", if_match=if_match)

    def tree_kinematics(
        self, tree_id: str, joints: Sequence[Mapping[str, float] | Sequence[float]], *, frames: bool = False
    ) -> Json:
        """Each tool's pose and each tool in every other's frame (`a/b`), per joint vector (by name or in the
        tree's order; deg and mm); with `frames`, every frame to draw."""
        rows = [dict(j) if isinstance(j, Mapping) else [float(v) for v in j] for j in joints]
        return dict(self._post(f"/v1/robot-trees/{_segment(tree_id)}/kinematics", {"joints": rows, "frames": frames}))

    def calibrate_tree(
        self,
        tree_id: str,
        records: Sequence[Json],
        *,
        held_out: Sequence[Json] = (),
        if_match: str | None = None,
        **options: object,
    ) -> Json:
        """The tree calibrated from `records` (each names its `tool`, optionally the tool `frame` it was measured
        in, its joints, position, orientation, sigma_mm); `held_out` judged after. Options: noise_position_mm,
        noise_orientation_deg, apply, accuracy_samples."""
        body = {"records": list(records), "held_out": list(held_out), **options}
        path = f"/v1/robot-trees/{_segment(tree_id)}/calibrations"
        return dict(self.request("POST", path, json_body=body, if_match=if_match).json())

    def tree_calibrations(self, tree_id: str, limit: int = 100, offset: int = 0) -> list[Json]:
        return list(self._get(f"/v1/robot-trees/{_segment(tree_id)}/calibrations", limit=limit, offset=offset))

    def design_tree(self, tree_id: str, count: int, **options: object) -> Json:
        """Which `count` records of the tree's tools to take (docs/api.md, "Robots of several chains"). Options:
        criterion, measure (each {tool, frame, measurement, sigma_mm}), candidates (joint vectors), candidate_count,
        joint_ranges, seed, noise_position_mm, noise_orientation_deg."""
        body = {"count": count, **{k: v for k, v in options.items() if v is not None}}
        return dict(self._post(f"/v1/robot-trees/{_segment(tree_id)}/designs", body))

    def design_tree_csv(self, tree_id: str, count: int, **options: object) -> str:
        """The same design's chosen records as a campaign sheet: tool, frame, measurement, the tree's joints."""
        body = {"count": count, **{k: v for k, v in options.items() if v is not None}}
        path = f"/v1/robot-trees/{_segment(tree_id)}/designs"
        return self.request("POST", path, query={"format": "csv"}, json_body=body, accept="text/csv").body.decode()

    def compensate_tree(self, tree_id: str, targets: Sequence[Json]) -> Json:
        """The joints that put each target's `tool` on its pose (position mm, orientation [w, x, y, z]) in the world
        or in tool `frame`'s frame, on the tree's current parameters, next to the target's program `joints`."""
        path = f"/v1/robot-trees/{_segment(tree_id)}/compensations"
        return dict(self._post(path, {"targets": list(targets)}))

    @overload
    def tree_export(self, tree_id: str, fmt: Literal["urdf", "dh-csv"]) -> str: ...

    @overload
    def tree_export(self, tree_id: str, fmt: Literal["urdf-json", "dh"]) -> Json: ...

    def tree_export(self, tree_id: str, fmt: Literal["urdf", "urdf-json", "dh", "dh-csv"]) -> Json | str:
        """The calibrated tree as a controller reads it: its URDF (a tree imported from one; `urdf-json`: with
        world <- base_link and each tip -> TCP beside it) or each branch's DH table (JSON or CSV)."""
        what, query, accept = {
            "urdf": ("urdf", "urdf", "application/xml"),
            "urdf-json": ("urdf", "json", "application/json"),
            "dh": ("dh", "json", "application/json"),
            "dh-csv": ("dh", "csv", "text/csv"),
        }[fmt]
        path = f"/v1/robot-trees/{_segment(tree_id)}/exports/{what}"
        answer = self.request("GET", path, query={"format": query}, accept=accept)
        return dict(answer.json()) if accept == "application/json" else answer.body.decode()

    def design_csv(self, design_id: str) -> str:
        """A design's poses as CSV, the robot's joint names as header (what a pendant or a controller takes)."""
        return self.request("GET", f"/v1/pose-designs/{_segment(design_id)}", accept="text/csv").body.decode()

    # -- calibrations -----------------------------------------------------------------------------------------

    def calibrate(
        self,
        robot_id: str,
        campaign: Campaign,
        *,
        noise_mm: float | None = None,
        apply: bool = True,
        async_: bool = False,
        on_progress: Callable[[Progress], None] | None = None,
        prior: str | None = None,
        columns: str | None = None,
        joint_unit: str | None = None,
        length_unit: str | None = None,
    ) -> Json:
        """Identifies the robot's parameters from a campaign and answers the calibration (status, residuals,
        predicted accuracy, whether it was applied and if not why). `async_` runs it as a job and waits for it.
        `prior="fleet"`: with the population of the robot's fleet as prior (docs/fleet.md). For a campaign file:
        `columns`, the column map (`"J1=joint_1,X_m=x"`: file column = the robot's joint or a coordinate), and
        `joint_unit` (`"rad"`: the revolute joint columns whose header states no unit), `length_unit` (`"m"`: the
        points, σ and prismatic joint columns whose header states none)."""
        path = f"/v1/robots/{_segment(robot_id)}/calibrations"
        query: dict[str, object] = {"apply": apply}
        if prior is not None:
            query["prior"] = prior
        if async_:
            query["async"] = True
        if isinstance(campaign, str | Path):
            query.update(noise_position_mm=noise_mm, columns=columns, joint_unit=joint_unit, length_unit=length_unit)
            answer = self._post_file(path, campaign, query)
        else:
            _records_only(columns, joint_unit, length_unit)
            body: Json = {"measurements": list(campaign), "apply": apply}
            if noise_mm is not None:
                body["noise"] = {"position_mm": noise_mm}
            if prior is not None:
                body["options"] = {"prior": query.pop("prior")}
            answer = self._post(path, body, **query)
        if async_:
            return self.result(answer["job_id"], on_progress)
        return dict(answer)

    def _post_file(self, path: str, campaign: str | Path, query: Mapping[str, object]) -> Any:
        """A campaign file sent as it is (`text/csv`): the service's reader knows the instruments' column and
        unit variants, and the query's `columns` and `joint_unit` say what its header does not."""
        data = Path(campaign).read_bytes()
        return self.request("POST", path, query=query, data=data, content_type="text/csv").json()

    def calibration(self, calibration_id: str) -> Json:
        return dict(self._get(f"/v1/calibrations/{_segment(calibration_id)}"))

    def report(self, calibration_id: str, fmt: Literal["html", "pdf"] = "html") -> bytes:
        """The calibration report: self-contained HTML (inline SVG figures) or PDF."""
        accept = "application/pdf" if fmt == "pdf" else "text/html"
        path = f"/v1/calibrations/{_segment(calibration_id)}/report"
        return self.request("GET", path, query={"format": fmt}, accept=accept).body

    # -- program compensation ---------------------------------------------------------------------------------

    def compensate(
        self,
        robot_id: str,
        program: ProgramSource,
        *,
        files: Sequence[ProgramSource] = (),
        format: str | None = None,
        version: int | None = None,
        seed: Sequence[float] | None = None,
        async_: bool | None = None,
        on_progress: Callable[[Progress], None] | None = None,
        options: Mapping[str, Any] | None = None,
    ) -> Json:
        """A robot program with its targets corrected for the robot's current (or `version`'s) parameters: the
        API's answer (the program's text, the companion files it rewrote, one entry per target with its
        correction or why it was kept). `files` are the companion files (a KRL .dat and $config.dat, RAPID
        modules), sent by their names; `format` defaults to the program's extension's (`programs.FORMATS`);
        `seed` is in degrees (mm for prismatic joints); `options` are further members of the request body
        (`pendant`, `temperature_c`, …). `async_=None` sends one request and, if the service answers that the
        work is over its synchronous budget and may run as a job, sends it again as one (`?async=true`) and
        waits; True sends it as a job at once, False never. `ProgramFile.encode` writes an answer's texts back
        in the encoding each file came in (`programs.compensated_bytes`)."""
        source = _program_file(program)
        companions = [_program_file(f) for f in files]
        fmt = format or format_of(source.name)
        if fmt is None:
            raise ValueError(f"the format of {source.name!r} is not known from its name: give format=")
        names = [source.name, *(f.name for f in companions)]
        if len(set(names)) != len(names):
            raise ValueError(f"two files of one name: {sorted(n for n in set(names) if names.count(n) > 1)}")
        body: Json = {"format": fmt, "program": source.text, "files": {f.name: f.text for f in companions}}
        if version is not None:
            body["version"] = version
        if seed is not None:
            body["seed"] = [float(v) for v in seed]
        body.update(options or {})
        path = f"/v1/robots/{_segment(robot_id)}/programs/compensate"
        try:
            answer = self.request("POST", path, query={"async": True} if async_ else None, json_body=body)
        except ApiError as refused:
            if async_ is not None or not refused.problem.get("use_async"):
                raise
            answer = self.request("POST", path, query={"async": True}, json_body=body)
        document = answer.json()
        # A service with the job form answers 202 and a job; one without it ignores ?async and answers at once.
        if answer.status == 202 or ("job_id" in document and "program" not in document):
            return self.result(str(document["job_id"]), on_progress)
        return dict(document)

    # -- parameters and validations ---------------------------------------------------------------------------

    @overload
    def parameters(self, robot_id: str, fmt: Literal["json"] = "json", *, version: int | None = None) -> Json: ...

    @overload
    def parameters(self, robot_id: str, fmt: Literal["csv", "urdf"], *, version: int | None = None) -> str: ...

    def parameters(
        self, robot_id: str, fmt: Literal["json", "csv", "urdf"] = "json", *, version: int | None = None
    ) -> Json | str:
        """The current (or `version`'s) parameters: the JSON document, the CSV that re-imports, or the calibrated
        serial model as URDF."""
        accept = {"json": "application/json", "csv": "text/csv", "urdf": "application/xml"}[fmt]
        path = f"/v1/robots/{_segment(robot_id)}/parameters"
        answer = self.request("GET", path, query={"format": fmt, "version": version}, accept=accept)
        return dict(answer.json()) if fmt == "json" else answer.body.decode()

    def forward_kinematics(
        self, robot_id: str, joints: Sequence[Sequence[float]], *, accuracy: bool = False, frames: bool = False
    ) -> Json:
        """The TCP's pose per joint vector (robots.md's order; deg and mm) on the current version; with `accuracy`,
        each pose's predicted error and whether it lies in the region the calibration measured (outside it:
        `extrapolation` and why); with `frames`, every frame to draw."""
        body = {"joints": [[float(v) for v in row] for row in joints], "accuracy": accuracy, "frames": frames}
        return dict(self._post(f"/v1/robots/{_segment(robot_id)}/forward-kinematics", body))

    def validate(
        self,
        robot_id: str,
        records: Campaign,
        *,
        versions: Sequence[int] | None = None,
        register: bool = False,
        columns: str | None = None,
        joint_unit: str | None = None,
        length_unit: str | None = None,
    ) -> Json:
        """Each version (default: the current one) against records it was not fitted to: errors, percentiles and
        ISO 9283 characteristics. A campaign file is sent as it is and read by the service as a calibration's is
        (`columns`, `joint_unit`, `length_unit`: as for `calibrate`); records are sent as JSON."""
        path = f"/v1/robots/{_segment(robot_id)}/validations"
        if isinstance(records, str | Path):
            query = {"versions": list(versions or []), "register": register or None}
            return dict(self._post_file(path, records, {**query, **_file_query(columns, joint_unit, length_unit)}))
        _records_only(columns, joint_unit, length_unit)
        body: Json = {"measurements": list(records)}
        if versions is not None:
            body["versions"] = list(versions)
        if register:
            body["register"] = True
        return dict(self._post(path, body))

    def _records(self, robot_id: str, records: Campaign) -> list[Any]:
        """Records as JSON for a request that takes JSON only (an adaptive campaign's): a file read here, its
        joint columns named as the robot's joints (GET of the robot)."""
        if isinstance(records, str | Path):
            return records_from_csv(Path(records).read_text(), self.robot(robot_id)["joint_names"])
        return list(records)

    # -- quick checks and the history ---------------------------------------------------------------------------

    def check_design(
        self, robot_id: str, *, count: int = 8, measurement: Literal["position", "pose"] = "position", seed: int = 0
    ) -> Json:
        """The `count` poses a quick check should measure (the most sensitive to the likely changes: the joint
        offsets, the tool), and the change of each it would flag with 95 % probability. Stores nothing."""
        body = {"count": count, "measurement": measurement, "seed": seed}
        return dict(self._post(f"/v1/robots/{_segment(robot_id)}/checks/design", body))

    def check(
        self,
        robot_id: str,
        records: Campaign,
        *,
        noise_mm: float | None = None,
        alpha: float | None = None,
        notes: str | None = None,
        columns: str | None = None,
        joint_unit: str | None = None,
        length_unit: str | None = None,
    ) -> Json:
        """A quick check of the current version: the verdict (fine, drifted, changed), what best explains a
        change, and what to do. A campaign file is sent as it is, as for `validate`; records as JSON."""
        path = f"/v1/robots/{_segment(robot_id)}/checks"
        if isinstance(records, str | Path):
            query = {"noise_position_mm": noise_mm, "alpha": alpha, "notes": notes}
            return dict(self._post_file(path, records, {**query, **_file_query(columns, joint_unit, length_unit)}))
        _records_only(columns, joint_unit, length_unit)
        body: Json = {"measurements": list(records)}
        if noise_mm is not None:
            body["noise"] = {"position_mm": noise_mm}
        if alpha is not None:
            body["alpha"] = alpha
        if notes is not None:
            body["notes"] = notes
        return dict(self._post(path, body))

    # -- adaptive campaigns ------------------------------------------------------------------------------------

    def adaptive_start(self, robot_id: str, target_mm: float, **options: object) -> Json:
        """An adaptive campaign (docs/pose-design.md "Adaptive campaigns"): its first poses to measure in `next`.
        `options` are the request's other fields (budget, measurement, criterion, candidate_count, seed, noise,
        blunder_sigma, measurements, notes); None ones are left out."""
        body: Json = {"target_mm": target_mm, **{k: v for k, v in options.items() if v is not None}}
        return dict(self._post(f"/v1/robots/{_segment(robot_id)}/adaptive-campaigns", body))

    def adaptive_records(self, robot_id: str, campaign_id: str, records: Campaign) -> Json:
        """Post measured records (a file is read here, its joint columns named as the robot's joints): the step
        (estimate, predicted accuracy, blunders, the next pose or done with why)."""
        body = {"measurements": self._records(robot_id, records)}
        return dict(self._post(self._adaptive(robot_id, campaign_id) + "/records", body))

    def adaptive_campaign(self, robot_id: str, campaign_id: str) -> Json:
        return dict(self._get(self._adaptive(robot_id, campaign_id)))

    def adaptive_finish(self, robot_id: str, campaign_id: str, *, calibrate: bool = True, apply: bool = True) -> Json:
        """End the campaign; with `calibrate`, store a calibration of its records (blunders left out)."""
        body = {"calibrate": calibrate, "apply": apply}
        return dict(self._post(self._adaptive(robot_id, campaign_id) + "/finish", body))

    @staticmethod
    def _adaptive(robot_id: str, campaign_id: str) -> str:
        return f"/v1/robots/{_segment(robot_id)}/adaptive-campaigns/{_segment(campaign_id)}"

    @overload
    def history(self, robot_id: str, fmt: Literal["json"] = "json", *, limit: int = 100) -> list[Json]: ...

    @overload
    def history(self, robot_id: str, fmt: Literal["csv"], *, limit: int = 100) -> str: ...

    def history(self, robot_id: str, fmt: Literal["json", "csv"] = "json", *, limit: int = 100) -> list[Json] | str:
        """The robot's calibrations and checks on one timeline, oldest first, with the accuracy measured then."""
        accept = "text/csv" if fmt == "csv" else "application/json"
        path = f"/v1/robots/{_segment(robot_id)}/history"
        answer = self.request("GET", path, query={"format": fmt, "limit": limit}, accept=accept)
        return answer.body.decode() if fmt == "csv" else list(answer.json())


def _query_pairs(query: Mapping[str, object]) -> list[tuple[str, str]]:
    """The query's pairs: None left out, booleans as the API spells them, a list as its key repeated
    (`versions=1&versions=2`)."""
    pairs = []
    for key, value in query.items():
        for item in value if isinstance(value, list | tuple) else [value]:
            if item is not None:
                pairs.append((key, str(item).lower() if isinstance(item, bool) else str(item)))
    return pairs


def _records_only(columns: str | None, joint_unit: str | None, length_unit: str | None = None) -> None:
    if columns is not None or joint_unit is not None or length_unit is not None:
        raise ValueError(
            "columns and joint_unit say how to read a campaign file (length_unit too); records are the API's own"
        )


def _file_query(columns: str | None, joint_unit: str | None, length_unit: str | None) -> dict[str, object]:
    return {"columns": columns, "joint_unit": joint_unit, "length_unit": length_unit}


def _program_file(source: ProgramSource) -> ProgramFile:
    return source if isinstance(source, ProgramFile) else ProgramFile.read(source)


def _segment(value: str) -> str:
    """An id as one path segment: a '/' or '?' in it cannot reach another route."""
    return urllib.parse.quote(value, safe="")
