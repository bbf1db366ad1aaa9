"""`GET /v1/design-criteria`, `GET /v1/adaptive-criteria` and `GET /v1/record-kinds`: the registries as clients
read them (issue 43: the client's and the UI's lists come from the API), checked
against the schema's enum and the registries themselves."""

from __future__ import annotations

from fastapi.testclient import TestClient

from optimal_design.adaptive_scores import AdaptiveCriterion
from optimal_design.criteria import Criterion
from service.record_kinds import RECORD_KINDS
from tests.service.helpers import InProcess


def test_the_criteria_are_the_enums_in_its_order_each_with_what_it_makes_small(client: TestClient) -> None:
    listed = client.get("/v1/design-criteria").json()
    assert [c["name"] for c in listed] == [c.value for c in Criterion]
    assert all(c["summary"] for c in listed)
    assert {c["name"] for c in listed if c["targetable"]} == {"D", "I"}  # what a target design accepts (its docs)


def test_the_adaptive_criteria_are_the_enums_with_the_campaigns_default(client: TestClient) -> None:
    listed = client.get("/v1/adaptive-criteria").json()
    assert [c["name"] for c in listed] == [c.value for c in AdaptiveCriterion]
    assert all(c["summary"] for c in listed)
    assert [c["name"] for c in listed if c["default"]] == ["I"]  # the campaign's documented default


def test_the_record_kinds_are_the_registrys_and_say_what_a_design_can_do(client: TestClient) -> None:
    listed = {k["name"]: k for k in client.get("/v1/record-kinds").json()}
    assert list(listed) == list(RECORD_KINDS) and next(iter(listed)) == "tracker"
    assert listed["distance"]["named_by"] == "anchor" and listed["distance"]["described_in"] == "anchors"
    assert listed["reflector"]["sampled"] and not listed["point"]["sampled"]  # no sampled pose is on a point
    assert all(k["designable"] for k in listed.values())
    assert listed["tracker"]["file_kinds"] == ["tracker", "position"]


def test_the_client_reads_both_lists(client: TestClient) -> None:
    """The Python client's methods return the API's lists as they are (requests made through the test client)."""
    iwr = InProcess(client)
    assert iwr.design_criteria() == client.get("/v1/design-criteria").json()
    assert iwr.record_kinds() == client.get("/v1/record-kinds").json()
    assert iwr.adaptive_criteria() == client.get("/v1/adaptive-criteria").json()
