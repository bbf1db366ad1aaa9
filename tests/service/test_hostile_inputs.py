"""The probe's attacks of issue 31 over HTTP, each answered by a clear 4xx problem within a second, with the
process's memory flat and the service still answering."""

from __future__ import annotations

import resource
import time
from collections.abc import Iterator
from pathlib import Path

import pytest
from fastapi.testclient import TestClient
from pydantic import BaseModel, ValidationError

from models import Registry
from service.schemas.calibrations import CalibrationCreate
from service.schemas.validations import ValidationCreate
from tests.models.test_urdf_hostile import chain, joint, urdf
from tests.service.conftest import make_client, postgres_url

SERIAL = pytest.mark.serial  # the tests with wall-time bounds run alone on the cores


@pytest.fixture
def warm(client: TestClient) -> TestClient:
    """A client whose process has imported the URDF reader (yourdfpy and trimesh: ~1.7 s once per process, the
    first URDF request's cost, not the attack's)."""
    assert client.post(
        "/v1/robots", json={"name": "ok", "urdf": chain(2), "base_link": "l0", "tip_link": "l2"}
    ).is_success
    return client


def _peak_rss_kb() -> int:
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss


@SERIAL
def test_a_urdf_with_a_cycle_is_a_422_at_once(warm: TestClient) -> None:
    client = warm
    # The request: two joints l1 -> l2 -> l1 below nothing; it hung and grew ~85 MB/s before.
    cyclic = urdf(["l0", "l1", "l2"], [joint("a", "l1", "l2"), joint("b", "l2", "l1")])
    self_loop = urdf(["l0", "l1"], [joint("a", "l0", "l1"), joint("b", "l1", "l1")])
    for text, tip, says in ((cyclic, "l2", "form a cycle"), (self_loop, "l1", "to itself")):
        before, start = _peak_rss_kb(), time.perf_counter()
        body = {"name": "loop", "urdf": text, "base_link": "l0", "tip_link": tip}
        answer = client.post("/v1/robots", json=body)
        assert time.perf_counter() - start < 1.0
        assert _peak_rss_kb() - before < 20_000
        assert answer.status_code == 422, answer.text
        assert answer.headers["content-type"].startswith("application/problem+json")
        assert says in answer.json()["detail"]
    assert client.get("/healthz").status_code == 200
    assert [r["name"] for r in client.get("/v1/robots").json()] == ["ok"]  # nothing stored


@SERIAL
def test_a_urdf_of_10_000_links_is_a_422_naming_the_limit(warm: TestClient) -> None:
    client = warm
    # bare links and joints (1.1 MB, under the 2 MB the schema allows a URDF)
    links = "".join(f'<link name="l{i}"/>' for i in range(10_001))
    joints = "".join(
        f'<joint name="j{i}" type="fixed"><parent link="l{i}"/><child link="l{i + 1}"/></joint>' for i in range(10_000)
    )
    text = f'<robot name="r">{links}{joints}</robot>'
    start = time.perf_counter()
    answer = client.post("/v1/robots", json={"name": "big", "urdf": text, "base_link": "l0", "tip_link": "l9"})
    assert time.perf_counter() - start < 1.0
    assert answer.status_code == 422 and "at most 1000" in answer.json()["detail"]


@SERIAL
def test_a_csv_header_of_20_000_columns_is_answered_at_once(warm: TestClient) -> None:
    # Issue 31's 6.1 s (names.count per column), then a 400 after reading the header in 0.23 s; since issue 48 the
    # body guard counts the fields of its widest line before any parser runs (the reader's own linearity is
    # tests/service/test_parser_linearity.py's).
    robot = warm.post("/v1/robots", json={"name": "cell"}).json()["id"]
    header = ",".join(f"c{i}" for i in range(20_000))
    body = header + "\n" + ",".join("1" for _ in range(20_000)) + "\n"
    start = time.perf_counter()
    answer = warm.post(f"/v1/robots/{robot}/calibrations", content=body, headers={"content-type": "text/csv"})
    assert time.perf_counter() - start < 1.0
    assert answer.status_code == 422, answer.status_code
    (error,) = answer.json()["errors"]
    assert error["msg"].startswith("line 1 of the CSV has 20000 fields; at most 256") and len(error["msg"]) < 1_000


@pytest.fixture(params=["sqlite", pytest.param("postgresql", marks=pytest.mark.slow)])
def any_db_client(request: pytest.FixtureRequest, tmp_path: Path, registry: Registry) -> Iterator[TestClient]:
    """A client on SQLite, and on PostgreSQL (where a NUL was a 500) in `make test`."""
    urls = iter([f"sqlite:///{tmp_path}/iwr.db"]) if request.param == "sqlite" else postgres_url()
    url = next(urls)
    with make_client(url, registry) as c:
        yield c
    next(urls, None)  # drops the PostgreSQL database


@pytest.mark.slow  # over 0.25 s of CPU: outside the inner loop (make test-fast)
@pytest.mark.parametrize(
    ("field", "value"),
    [("name", "cell\x003"), ("name", "cell-3\nFORGED log line"), ("name", "bell\x07"), ("notes", "a\x00b")],
)
def test_patch_refuses_what_post_refuses(any_db_client: TestClient, field: str, value: str) -> None:
    client = any_db_client
    robot = client.post("/v1/robots", json={"name": "cell-3"}).json()
    answer = client.patch(f"/v1/robots/{robot['id']}", json={field: value})
    assert answer.status_code == 422, answer.text
    assert answer.json()["errors"][0]["loc"] == ["body", field]
    assert client.post("/v1/robots", json={"name": value}).status_code == 422 or field == "notes"  # POST's rule
    stored = client.get(f"/v1/robots/{robot['id']}").json()
    assert (stored["name"], stored["notes"], stored["revision"]) == ("cell-3", None, robot["revision"])


def test_notes_keep_their_lines_and_tabs(client: TestClient, robot_id: str) -> None:
    notes = "re-measured after the crash\n\tbase only\r\n"
    answer = client.patch(f"/v1/robots/{robot_id}", json={"notes": notes})
    assert answer.status_code == 200 and answer.json()["notes"] == notes


@pytest.mark.parametrize("schema", [CalibrationCreate, ValidationCreate])
def test_calibration_and_validation_notes_take_the_same_rule(schema: type[BaseModel]) -> None:
    record = {"joints": [400, 150, 90, 45, 420, 420, 420, 420, 420, 420], "position": [1, 2, 3]}
    assert schema.model_validate({"measurements": [record], "notes": "line 1\n\tline 2"})
    with pytest.raises(ValidationError, match="notes"):
        schema.model_validate({"measurements": [record], "notes": "a\x00b"})


@SERIAL
@pytest.mark.parametrize("depth", [5_000, 40_000])  # 10 kB, on the loop; 80 kB, the large bodies' check
def test_json_nested_5000_deep_is_a_422_naming_the_limit(client: TestClient, robot_id: str, depth: int) -> None:
    body = b'{"joints": ' + b"[" * depth + b"]" * depth + b"}"
    for path in ("/v1/robots", f"/v1/robots/{robot_id}/forward-kinematics"):
        start = time.perf_counter()
        answer = client.post(path, content=body, headers={"content-type": "application/json"})
        assert time.perf_counter() - start < 1.0
        assert answer.status_code == 422, answer.text
        problem = answer.json()
        assert problem["type"].endswith("/validation-error")
        assert problem["errors"] == [
            {"loc": ["body"], "field": "", "msg": f"JSON nested {depth + 1} levels deep; at most 32 are accepted"}
        ]
    assert client.get("/healthz").status_code == 200


def test_brackets_inside_strings_are_not_nesting(client: TestClient) -> None:
    answer = client.post("/v1/robots", json={"name": "[" * 100 + "{" * 100})
    assert answer.status_code == 201, answer.text


@pytest.mark.slow  # > 0.25 s of CPU: make test runs it, test-fast does not
def test_a_trailing_slash_is_a_404_naming_the_path_never_a_redirect(tmp_path: Path, registry: Registry) -> None:
    # With keys required and none sent: the 307 came before any key check and its Location took the Host header.
    with make_client(f"sqlite:///{tmp_path}/iwr.db", registry, api_keys="k-secret") as c:
        for method, path, canonical in (
            ("GET", "/v1/robots/", "/v1/robots"),
            ("POST", "/v1/robots/", "/v1/robots"),
            ("GET", "/v1/robots/r1/parameters/", "/v1/robots/r1/parameters"),
            ("GET", "/healthz//", "/healthz"),
        ):
            answer = c.request(method, path, headers={"host": "evil.example"}, follow_redirects=False)
            assert answer.status_code == 404, (method, path, answer.status_code)
            assert "location" not in answer.headers
            assert answer.headers["content-type"].startswith("application/problem+json")
            assert f"use {canonical!r}" in answer.json()["detail"] and "evil" not in answer.text
        assert c.get("/v1/nothing/", follow_redirects=False).json()["detail"] == "Not Found"  # no route: plain 404
        assert c.get("/healthz").status_code == 200
