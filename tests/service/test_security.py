"""Keys with scopes: each scope against each /v1 route, as a table generated from the app's routes."""

from __future__ import annotations

import json
import re
from collections.abc import Iterator
from pathlib import Path

import pytest
from fastapi import APIRouter, Request
from fastapi.testclient import TestClient

from service.http import security
from service.http.app import create_app
from service.http.deps import ApiKeyDep
from service.http.operations import Operation, table
from service.http.security import Scope, digest, parse_keys
from service.settings import Settings
from tests.service.contract_check import ContractClient

KEYS = {scope: f"secret-{scope.name}-0123456789" for scope in Scope}
"""One key per scope; the settings hold only their hashes."""
ENTRIES = ",".join(f"{s.name}-key:{s.name}:{digest(k)}" for s, k in KEYS.items())
_DB = Path(__import__("tempfile").mkdtemp()) / "security.db"
APP = create_app(
    Settings(database_url=f"sqlite:///{_DB}", api_keys=ENTRIES, job_workers=0, warm_up=False, log_level="ERROR")
)
POLICIES = table(APP)
TABLE = sorted(POLICIES)
DECLARED: dict[tuple[str, str], Operation] = {route: op for route, op in POLICIES.items() if op is not None}


def test_every_route_declares_its_operation() -> None:
    """A new /v1 route fails here until its endpoint declares its policy (`@operation`, service.http.operations)."""
    assert len(TABLE) >= 14
    missing = [route for route, op in POLICIES.items() if op is None]
    assert not missing, f"declare these routes' policy with @operation (service.http.operations): {missing}"
    assert DECLARED[("DELETE", "/v1/robots/{robot_id}")].scope is Scope.admin
    assert DECLARED[("POST", "/v1/robots/{robot_id}/parameter-versions/{version}/restore")].scope is Scope.admin
    # Storing nothing is reading: kinematics and error analysis; creating a record is writing.
    assert DECLARED[("POST", "/v1/robots/{robot_id}/forward-kinematics")].scope is Scope.read
    assert DECLARED[("POST", "/v1/robots/{robot_id}/calibrations")].scope is Scope.write
    assert DECLARED[("POST", "/v1/robots/{robot_id}/calibrations")].job == "calibration"


def test_policy_tables_hold_no_path_strings() -> None:
    """Scopes, byte pre-counts and job kinds live on the routes: no module keeps a table keyed by paths."""
    root = Path(__file__).resolve().parents[2] / "service"
    keyed = [
        re.compile(r'\("(GET|POST|PUT|PATCH|DELETE)",\s*"/'),  # (method, path) keys
        re.compile(r're\.compile\(r?"[^"]*(/v1|kinematics|calibrations)'),  # path patterns
        re.compile(r'"/v1[^"]*"\s*:'),  # path keys
    ]
    offenders = [
        f"{path.relative_to(root.parent)}:{n}"
        for path in sorted(root.rglob("*.py"))
        for n, line in enumerate(path.read_text().splitlines(), 1)
        if any(pattern.search(line) for pattern in keyed)
    ]
    assert not offenders, offenders


@pytest.fixture(scope="module")
def api() -> Iterator[ContractClient]:
    with ContractClient(APP) as c:
        yield c


def _url(template: str) -> str:
    return re.sub(r"\{[^}]+\}", "00000000-0000-0000-0000-000000000000", template).replace("/0000", "/1", 0)


@pytest.mark.parametrize(("method", "template"), TABLE, ids=[f"{m} {t}" for m, t in TABLE])
@pytest.mark.parametrize("scope", [None, *Scope], ids=["no key", *(s.name for s in Scope)])
@pytest.mark.slow  # over a second here: outside the inner loop (make test-fast)
def test_scope_on_route(api: ContractClient, method: str, template: str, scope: Scope | None) -> None:
    """Each route with no key, a wrong key and a key of each scope: 401, 403 below the route's scope, past the
    check otherwise (the body here is empty, so past the check means 404, 422 or 415, never 401 or 403)."""
    headers = {} if scope is None else {"X-API-Key": KEYS[scope]}
    r = api.request(method, _url(template), headers=headers, content=b"{}")
    needed = DECLARED[(method, template)].scope
    if scope is None:
        assert r.status_code == 401 and r.headers["www-authenticate"] == "ApiKey"
    elif scope < needed:
        assert r.status_code == 403, r.text
        assert r.json()["required"] == needed.name and r.json()["scope"] == scope.name
    else:
        assert r.status_code not in (401, 403, 500), r.text


@pytest.mark.slow  # over 0.25 s of CPU: outside the inner loop (make test-fast)
def test_a_new_route_is_caught_and_the_actor_is_the_key_name(tmp_path: Path) -> None:
    app = create_app(
        Settings(database_url=f"sqlite:///{tmp_path}/n.db", api_keys=ENTRIES, job_workers=0, warm_up=False)
    )
    router = APIRouter(dependencies=[ApiKeyDep])

    @router.get("/v1/whoami")
    async def whoami(request: Request) -> dict[str, str]:
        return {"actor": request.state.actor}

    app.include_router(router)
    assert table(app)[("GET", "/v1/whoami")] is None  # so test_every_route_declares_its_operation would fail
    with TestClient(app) as c:
        assert c.get("/v1/whoami", headers={"X-API-Key": "not-a-key"}).status_code == 401
        assert c.get("/v1/whoami", headers={"X-API-Key": KEYS[Scope.write]}).status_code == 403  # fail closed
        answer = c.get("/v1/whoami", headers={"X-API-Key": KEYS[Scope.admin]})
        assert answer.json() == {"actor": "admin-key"}  # the key's name, never the key


@pytest.mark.slow  # over 0.25 s of CPU: outside the inner loop (make test-fast)
def test_admin_alone_deletes_a_robot(api: ContractClient) -> None:
    rid = api.post("/v1/robots", json={"name": "r"}, headers={"X-API-Key": KEYS[Scope.write]}).json()["id"]
    assert api.delete(f"/v1/robots/{rid}", headers={"X-API-Key": KEYS[Scope.write]}).status_code == 403
    assert api.get(f"/v1/robots/{rid}", headers={"X-API-Key": KEYS[Scope.read]}).status_code == 200
    assert api.delete(f"/v1/robots/{rid}", headers={"X-API-Key": KEYS[Scope.admin]}).status_code == 204


def test_bare_keys_stay_write_keys_and_a_file_holds_hashes(tmp_path: Path) -> None:
    (bare,) = parse_keys("plain-old-key", None)
    assert bare.scope is Scope.write and bare.name == f"key-{digest('plain-old-key')[:8]}"
    assert "plain-old-key" not in repr(bare)
    file = tmp_path / "keys.json"
    file.write_text(json.dumps([{"name": "ops", "scope": "admin", "sha256": digest("k-ops")}]))
    keys = parse_keys("", str(file))
    assert keys == (security.ApiKey("ops", Scope.admin, digest("k-ops")),)
    for wrong in ("a:superuser:" + "0" * 64, "bad name:read:" + "0" * 64):
        with pytest.raises(ValueError, match=r"scope|name"):
            parse_keys(wrong, None)
    with pytest.raises(ValueError, match="unique"):
        parse_keys(f"a:read:{digest('x')},a:write:{digest('y')}", None)


@pytest.mark.parametrize(("metrics_public", "docs_public"), [(False, True), (True, False)])
@pytest.mark.slow  # over a second here: outside the inner loop (make test-fast)
def test_metrics_and_docs_behind_a_key_by_setting(tmp_path: Path, metrics_public: bool, docs_public: bool) -> None:
    settings = Settings(
        database_url=f"sqlite:///{tmp_path}/m.db",
        api_keys=ENTRIES,
        metrics_public=metrics_public,
        docs_public=docs_public,
        job_workers=0,
        warm_up=False,
    )
    with TestClient(create_app(settings)) as c:
        read = {"X-API-Key": KEYS[Scope.read]}
        assert c.get("/metrics").status_code == (200 if metrics_public else 401)
        assert c.get("/metrics", headers=read).status_code == 200
        for path in ("/openapi.json", "/docs"):
            assert c.get(path).status_code == (200 if docs_public else 401)
            assert c.get(path, headers=read).status_code == 200
        assert c.get("/healthz").status_code == 200  # probes never need a key


@pytest.mark.slow  # > 0.25 s of CPU: make test runs it, test-fast does not
def test_the_document_declares_the_scheme_and_every_scope() -> None:
    doc = APP.openapi()
    assert doc["components"]["securitySchemes"]["ApiKey"] == {
        "type": "apiKey",
        "in": "header",
        "name": "X-API-Key",
        "description": doc["components"]["securitySchemes"]["ApiKey"]["description"],
    }
    for method, template in TABLE:
        operation = doc["paths"][template][method.lower()]
        assert operation["security"] == [{"ApiKey": []}]
        assert operation["x-scope"] == DECLARED[(method, template)].scope.name


@pytest.mark.parametrize(("method", "template"), [(m, t) for m, t in TABLE if DECLARED[(m, t)].job is not None])
def test_a_job_needs_a_write_key_whatever_the_synchronous_form_needs(
    api: ContractClient, method: str, template: str
) -> None:
    """`?async=true` stores a job (its row, its answer): a read key may compensate a program in one request,
    never queue one (403 naming `write`); the document says so in `x-async-scope`."""
    declared = DECLARED[(method, template)]
    url = _url(template) + "?async=true"
    refused = api.request(method, url, headers={"X-API-Key": KEYS[Scope.read]}, content=b"{}")
    assert refused.status_code == 403 and refused.json()["required"] == "write", refused.text
    past = api.request(method, url, headers={"X-API-Key": KEYS[Scope.write]}, content=b"{}")
    assert past.status_code not in (401, 403, 500), past.text
    if declared.scope is Scope.read:  # the synchronous form still takes a read key
        direct = api.request(method, _url(template), headers={"X-API-Key": KEYS[Scope.read]}, content=b"{}")
        assert direct.status_code not in (401, 403, 500), direct.text
    assert APP.openapi()["paths"][template][method.lower()]["x-async-scope"] == "write"
