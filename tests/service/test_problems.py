"""One renderer for every error: route handlers, the body-limit middleware and the job runner answer alike."""

from __future__ import annotations

from pathlib import Path

import pytest
from fastapi.exceptions import RequestValidationError
from fastapi.testclient import TestClient
from starlette.exceptions import HTTPException

from models import errors as domain
from models import iwr, sample_workspace
from models.simulation import perturbed_robot
from service import errors
from service.http.problems import TYPE_BASE, to_problem
from tests.service.conftest import make_client
from tests.service.helpers import finished_job, records

DESC = iwr()


@pytest.mark.parametrize(
    ("exc", "status", "slug", "extra"),
    [
        (
            domain.JointOutOfRange("q3 out", pose=2, joint="q3", value=200.0, min=0.0, max=180.0, unit="deg"),
            422,
            "joint-out-of-range",
            {"pose": 2, "joint": "q3", "value": 200.0, "min": 0.0, "max": 180.0, "unit": "deg", "count": 1},
        ),
        (domain.InvalidInput("bad", field="x"), 422, "invalid-input", {"field": "x"}),
        (errors.NotFound("no robot", resource="robot", id="r1"), 404, "not-found", {"resource": "robot", "id": "r1"}),
        (errors.PayloadTooLarge("too big", limit=10), 413, "payload-too-large", {"limit": 10}),
        (errors.BadRequest("CSV line 3", line=3), 400, "bad-request", {"line": 3}),
        (errors.Interrupted("stopped"), 503, "interrupted", {}),
        (HTTPException(405, "Method Not Allowed"), 405, "http-405", {}),
        (ZeroDivisionError("secret internals"), 500, "internal-error", {}),
    ],
)
def test_to_problem_renders_type_title_status_detail_and_the_data(
    exc: Exception, status: int, slug: str, extra: dict[str, object]
) -> None:
    body = to_problem(exc)
    assert body["type"] == TYPE_BASE + slug and body["status"] == status and body["title"]
    assert {k: v for k, v in body.items() if k not in ("type", "title", "status", "detail")} == extra
    assert "secret" not in body["detail"]  # an unexpected error's text stays in the log


class _Reserved(errors.ServiceError):
    """Fields named like the reserved members, which no class of the tree declares (`test_errors` checks)."""

    fields = ("status", "type", "line")

    def __init__(self, detail: str) -> None:
        super().__init__(detail)
        self.status, self.type, self.line = 200, "x", 1


def test_data_cannot_overwrite_the_reserved_members() -> None:
    body = to_problem(_Reserved("what to fix"))
    assert body["status"] == 500 and body["type"].endswith("service-error") and body["line"] == 1


def test_validation_errors_list_where() -> None:
    exc = RequestValidationError([{"loc": ("body", "joints", 0), "msg": "too short", "type": "x"}])
    body = to_problem(exc)
    assert body["detail"] == "body.joints.0: too short" and body["errors"] == [
        {"loc": ["body", "joints", 0], "field": "joints[0]", "msg": "too short"}
    ]
    assert body["field"] == "joints[0]"


def test_a_description_documents_fields_are_named_as_robots_md_names_them() -> None:
    loc = ("body", "structure", "stages", 1, "hexapod", "strokes", 0)
    body = to_problem(RequestValidationError([{"loc": loc, "msg": "bad", "type": "x"}]))
    assert body["field"] == "stages[1].strokes[0]"  # no `body`, no `structure`, no union tag
    other = to_problem(RequestValidationError([{"loc": ("body", "measurements", 4, "serial"), "msg": "m"}]))
    assert other["field"] == "measurements[4].serial"  # a tag is only dropped inside a document's stages


@pytest.mark.slow  # over 0.25 s of CPU: outside the inner loop (make test-fast)
def test_a_failed_job_stores_what_the_synchronous_request_answers(client: TestClient, robot_id: str) -> None:
    recs = records(DESC, perturbed_robot(DESC, seed=7), sample_workspace(DESC, 30, seed=8), seed=9)
    out_of_range = [400, 150, 190, 45, 420, 420, 420, 420, 420, 420]  # q3 beyond its range
    bad = [dict(r, joints=out_of_range) if k == 4 else r for k, r in enumerate(recs)]
    url = f"/v1/robots/{robot_id}/calibrations"
    sync = client.post(url, json={"measurements": bad})
    assert sync.status_code == 422 and sync.json()["type"].endswith("joint-out-of-range")
    job = finished_job(client, client.post(url + "?async=true", json={"measurements": bad}).json()["status_url"])
    assert job["status"] == "failed" and job["error"] == sync.json()

    design = {"count": 3, "candidates": (sample_workspace(DESC, 20, seed=1) * DESC.joint_to_boundary).tolist()}
    url = f"/v1/robots/{robot_id}/pose-designs"
    sync = client.post(url, json=design)
    assert sync.status_code == 422
    job = finished_job(client, client.post(url + "?async=true", json=design).json()["status_url"])
    assert job["status"] == "failed" and job["error"] == sync.json()


def test_the_body_limit_and_the_api_key_answer_with_the_same_renderer(tmp_path: Path) -> None:
    with make_client(f"sqlite:///{tmp_path}/limit.db", max_body_bytes=1000, api_keys="k") as c:
        declared = c.post("/v1/robots", json={"name": "x" * 2000}, headers={"X-API-Key": "k"})
        expected = to_problem(errors.PayloadTooLarge("the request body exceeds 1000 bytes; send less", limit=1000))
        assert declared.status_code == 413 and declared.json() == expected
        denied = c.get("/v1/robots")
        assert denied.status_code == 401 and denied.json() == to_problem(
            errors.Unauthorized("send a valid API key in the X-API-Key header")
        )
        assert denied.headers["www-authenticate"] == "ApiKey"
