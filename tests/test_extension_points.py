"""The extension points (docs/architecture.md) stay seams: each registry is complete, and the code that
composes stages or measurement kinds never asks which kind it holds."""

from __future__ import annotations

import ast
import inspect
import re
from pathlib import Path

import pytest

from models.measurement import MeasurementKind
from models.measurements import MEASUREMENTS, Measurement
from models.stages import READERS, Stage
from service.schemas.structure import STAGE_KINDS

ROOT = Path(__file__).resolve().parent.parent
STAGE_AWARE = {
    "models/stages",
    "models/description/hexapod.py",
    "models/description/robot.py",
    "models/description/iwr.py",
}
"""Where a stage's kind may be named: the stage modules, the hexapod's maths, the description that lays the
stages out (its single-hexapod convenience for the hexapod-only terms) and the IWR that is built of them."""
COMPOSERS = (
    "models/engine/symbolic.py",
    "models/kinematics.py",
    "models/workspace.py",
    "models/description/structure.py",
    "models/inverse",
    "models/identification/residuals.py",
    "models/identification/accuracy.py",
    "models/identifiability.py",
    "optimal_design/information.py",
)


def _protocol_members(protocol: type) -> set[str]:
    return {
        name
        for name, value in vars(protocol).items()
        if not name.startswith("_") and (callable(value) or isinstance(value, property))
    } | set(getattr(protocol, "__annotations__", {}))


def _sources(paths: tuple[str, ...] | set[str]) -> list[Path]:
    out: list[Path] = []
    for rel in paths:
        path = ROOT / rel
        out += sorted(path.rglob("*.py")) if path.is_dir() else [path]
    return out


def test_every_stage_kind_of_the_contract_has_a_reader_and_a_whole_stage() -> None:
    assert set(STAGE_KINDS) == set(READERS)
    members = _protocol_members(Stage) - {"kind", "section", "group", "classic_group"}
    for kind, reader in READERS.items():
        cls = inspect.signature(reader, eval_str=True).return_annotation
        assert cls.kind == kind
        missing = {m for m in members if not hasattr(cls, m)}
        assert not missing, f"{cls.__name__} lacks {sorted(missing)} of the Stage protocol"


def test_every_measurement_kind_has_a_whole_model() -> None:
    assert set(MEASUREMENTS) == set(MeasurementKind)
    members = _protocol_members(Measurement)
    for kind, model in MEASUREMENTS.items():
        assert model.kind is kind
        missing = {m for m in members if not hasattr(model, m)}
        assert not missing, f"{kind}'s model lacks {sorted(missing)} of the Measurement protocol"
        assert model.rows == kind.rows and len(model.columns) >= model.rows


@pytest.mark.parametrize("path", _sources(COMPOSERS), ids=lambda p: str(p.relative_to(ROOT)))
def test_composers_never_ask_a_stage_or_a_measurement_its_kind(path: Path) -> None:
    tree = ast.parse(path.read_text())
    for node in ast.walk(tree):
        if isinstance(node, ast.Attribute):
            assert node.attr != "has_hexapod", f"{path.name}:{node.lineno} asks whether there is a hexapod"
        if isinstance(node, ast.Call) and isinstance(node.func, ast.Name) and node.func.id == "isinstance":
            kinds = ast.unparse(node.args[1])
            assert "Stage" not in kinds and "Measurement" not in kinds, f"{path.name}:{node.lineno} tests a kind"
        if isinstance(node, ast.Compare) and isinstance(node.left, ast.Attribute) and node.left.attr == "kind":
            constants = [c for c in node.comparators if isinstance(c, ast.Constant)]
            assert not constants, f"{path.name}:{node.lineno} compares a kind to a literal"


def test_no_module_outside_the_stages_asks_for_a_hexapod_by_flag() -> None:
    for path in _sources(("models", "optimal_design", "service")):
        rel = str(path.relative_to(ROOT))
        if any(rel.startswith(allowed) for allowed in STAGE_AWARE):
            continue
        assert "has_hexapod" not in path.read_text(), rel


LONGEST_LINES = 60


@pytest.mark.slow  # over 0.25 s: outside the inner loop (make test-fast)
def test_a_function_over_sixty_lines_says_why() -> None:
    """A long function is a step that was not split: it must say why in a comment ("Long on purpose: …")."""
    unexplained = []
    for package in ("models", "optimal_design", "programs", "service", "iwr_client", "harness"):
        for path in sorted((ROOT / package).rglob("*.py")):
            if "migrations" in path.parts:
                continue
            source = path.read_text()
            lines = source.splitlines()
            for node in ast.walk(ast.parse(source)):
                if isinstance(node, ast.FunctionDef | ast.AsyncFunctionDef):
                    assert node.end_lineno is not None
                    body = lines[node.lineno - 1 : node.end_lineno]
                    if len(body) > LONGEST_LINES and not any("# Long on purpose:" in line for line in body):
                        unexplained.append(f"{path.relative_to(ROOT)}:{node.lineno} {node.name} ({len(body)} lines)")
    assert not unexplained, unexplained


def _record_kind_words() -> tuple[set[str], set[str]]:
    """The record classes (request and public) and every string that names a record kind or what it measures."""
    from service.record_kinds import RECORD_KINDS  # noqa: PLC0415  (the service only where a test needs it)

    classes = {cls.__name__ for kind in RECORD_KINDS.values() for cls in (kind.record, kind.public)}
    words = {m.value for m in MeasurementKind}
    for kind in RECORD_KINDS.values():
        words |= {kind.name, kind.label, kind.model, *kind.file_kinds, *([kind.named_by] if kind.named_by else [])}
    return classes, words - {""}


def _asks_a_record_its_kind(node: ast.AST, classes: set[str], words: set[str]) -> bool:
    if isinstance(node, ast.Call) and isinstance(node.func, ast.Name) and node.func.id == "isinstance":
        named = {n.id for n in ast.walk(node.args[1]) if isinstance(n, ast.Name)}
        return bool(named & classes)
    if not isinstance(node, ast.Compare):
        return False
    for op, right in zip(node.ops, node.comparators, strict=True):
        sides: tuple[ast.expr, ...]
        if isinstance(op, ast.Eq | ast.NotEq):
            sides = (node.left, right)
        elif isinstance(op, ast.In | ast.NotIn) and isinstance(right, ast.Tuple | ast.List | ast.Set):
            sides = tuple(right.elts)
        else:
            continue
        if any(isinstance(s, ast.Constant) and s.value in words for s in sides):
            return True
    return False


@pytest.mark.slow  # over 0.25 s of CPU: outside the inner loop (make test-fast)
def test_no_module_outside_the_record_kinds_asks_a_record_its_kind() -> None:
    """Outside service/record_kinds/, no module of the service or of pose design asks a record which kind it is
    (a string compared with a kind's name, an isinstance of a kind's schema): it looks the kind up in the registry
    and asks it. (models/ knows no record kinds, only its own measurement and reference kinds:
    `test_every_measurement_kind_has_a_whole_model`.)"""
    classes, words = _record_kind_words()
    found = []
    for path in _sources(("service", "optimal_design")):
        rel = str(path.relative_to(ROOT))
        if rel.startswith("service/record_kinds/"):
            continue
        for node in ast.walk(ast.parse(path.read_text())):
            if _asks_a_record_its_kind(node, classes, words):
                found.append(f"{rel}:{getattr(node, 'lineno', '?')} {ast.unparse(node)}")
    assert not found, found


def test_the_record_kind_check_sees_what_it_forbids() -> None:
    classes, words = _record_kind_words()
    asks = ['kind == "distance"', 'r.get("kind") != "image"', 'm in ("point", "x")', "isinstance(r, ImageRecord)"]
    for source in asks:
        assert any(_asks_a_record_its_kind(n, classes, words) for n in ast.walk(ast.parse(source))), source
    fine = ['"position" in r', "kind is DISTANCE", 'name == "a1"', "isinstance(r, dict)"]
    for source in fine:
        assert not any(_asks_a_record_its_kind(n, classes, words) for n in ast.walk(ast.parse(source))), source


KIND_MODULES = ("service/record_kinds/", "models/measurements/")
"""The registry and the kinds themselves: the only modules that may ask which kind of record or reference they
hold (each kind answers for itself there)."""
PIPELINES = (
    "service",
    "optimal_design",
    "models/identification",
    "models/evaluation/checks.py",
    "models/evaluation/accuracy.py",
)
"""The code that runs a campaign's records through an operation (fit, check, validate, design)."""
TRACKER_BRANCHES = {"has_references", "tracker_records", "TRACKER", "measures_reference"}
"""What a tracker-or-reference fork was written with before each operation became one pipeline (issue 43): a
pipeline asks a kind's capability (`RecordKind.whole_campaign`, `Traits.registers_frame`, …) instead."""


def _reference_classes() -> set[str]:
    """Every class of the models' measurement and reference kinds (those with `traits`, and the measurements)."""
    import models.measurements.camera  # noqa: PLC0415
    import models.measurements.line  # noqa: PLC0415
    import models.measurements.references  # noqa: PLC0415
    import models.measurements.tcp  # noqa: PLC0415

    modules = (models.measurements.references, models.measurements.camera, models.measurements.line)
    found = {
        name
        for module in (*modules, models.measurements.tcp)
        for name, value in vars(module).items()
        if isinstance(value, type)
        and value.__module__ == module.__name__
        and (hasattr(value, "traits") or _protocol_members(Measurement) <= set(dir(value)))
    }
    return found


def _forks_on_a_kind(node: ast.AST, classes: set[str]) -> bool:
    """An isinstance on a measurement's or reference's class, or a tracker-or-reference fork's helper."""
    if isinstance(node, ast.Call) and isinstance(node.func, ast.Name) and node.func.id == "isinstance":
        return bool({n.id for n in ast.walk(node.args[1]) if isinstance(n, ast.Name)} & classes)
    if isinstance(node, ast.Name):
        return node.id in TRACKER_BRANCHES
    if isinstance(node, ast.Attribute):
        return node.attr in TRACKER_BRANCHES
    if isinstance(node, ast.alias):
        return node.name in TRACKER_BRANCHES
    return False


@pytest.mark.slow  # over 0.25 s of CPU: outside the inner loop (make test-fast)
def test_each_operation_is_one_pipeline_that_asks_its_kinds() -> None:
    """Outside the registry and the kinds' own modules, no pipeline tests `isinstance` on a measurement's or a
    reference's class, nor forks a campaign into a tracker path and a reference path by the helpers that did
    (docs/architecture.md, "One pipeline per operation")."""
    classes = _reference_classes()
    found = []
    for path in _sources(PIPELINES):
        rel = str(path.relative_to(ROOT))
        if rel.startswith(KIND_MODULES):
            continue
        for node in ast.walk(ast.parse(path.read_text())):
            if _forks_on_a_kind(node, classes):
                found.append(f"{rel}:{getattr(node, 'lineno', '?')} {ast.unparse(node)}")
    assert not found, found


def test_the_pipeline_check_sees_what_it_forbids() -> None:
    classes = _reference_classes()
    assert {"Anchor", "Plane", "Camera", "ToolCamera", "TrackerPositions", "Line", "Reflector"} <= classes
    forks = [
        "isinstance(reference, Anchor)",
        "isinstance(g.reference, (Plane, Camera))",
        "if has_references(body.measurements): pass",
        "records = tracker_records(body.measurements)",
        "from service.record_kinds import tracker_records",
        "kind is TRACKER",
        "any(kind_of(r).measures_reference for r in rs)",
    ]
    for source in forks:
        assert any(_forks_on_a_kind(n, classes) for n in ast.walk(ast.parse(source))), source
    fine = ["isinstance(c, ReferenceCandidate)", "kind.whole_campaign", "g.reference.traits.registers_frame"]
    for source in fine:
        assert not any(_forks_on_a_kind(n, classes) for n in ast.walk(ast.parse(source))), source


def test_the_architecture_doc_states_the_record_kinds_and_the_allowed_modules() -> None:
    """docs/architecture.md's counts match the code: the kinds it names, that none is allowed to ask, and every
    file it says a new record kind touches exists."""
    from service.record_kinds import RECORD_KINDS  # noqa: PLC0415

    doc = (ROOT / "docs" / "architecture.md").read_text()
    section = doc[doc.index("**Record kinds**") : doc.index("**References**")]
    stated = re.search(r"`tracker`\s+\(the models' pose and position kinds\),(.*?)each one", section, re.S)
    assert stated is not None
    assert ["tracker", *re.findall(r"`(\w+)`", stated.group(1))] == list(RECORD_KINDS)
    assert "(0 now:" in section  # no module outside the registry is allowed to ask (the test above)
    listed = re.findall(r"^\d+\. `([\w/.<>]+)`", section, re.M)
    assert f"That is {len(listed)} files" in section and f"beside its tests, {len(listed)} files" in section
    assert len(listed) <= 3  # issue 43: a new record kind is at most three files plus its tests
    for rel in listed:
        assert (ROOT / rel).exists() or rel.endswith("<kind>.py"), rel
    assert listed == [
        "models/measurements/<kind>.py",
        "service/record_kinds/<kind>.py",
        "service/record_kinds/__init__.py",
    ]


@pytest.mark.slow  # > 0.25 s of CPU: make test runs it, test-fast does not
def test_the_last_kind_added_is_named_only_in_the_files_the_doc_lists() -> None:
    """The kind the doc names as proof (`displacement`) is those files: its tag, its reference's name, its field
    and its body's map are string constants in its two modules, the registry line aside, and nowhere else in
    models/, optimal_design/ or service/ (the contract excepted: it is generated)."""
    from service.record_kinds import RECORD_KINDS  # noqa: PLC0415

    kind = RECORD_KINDS["displacement"]
    words = {kind.name, kind.model, str(kind.named_by), str(kind.described_in), *kind.file_kinds}
    own = {"models/measurements/line.py", "service/record_kinds/displacement.py"}
    found = []
    for path in _sources(("models", "optimal_design", "service")):
        rel = str(path.relative_to(ROOT))
        if rel in own:
            continue
        for node in ast.walk(ast.parse(path.read_text())):
            if isinstance(node, ast.Constant) and node.value in words:
                found.append(f"{rel}:{node.lineno} {node.value!r}")
    assert not found, found
    assert "DISPLACEMENT" in (ROOT / "service/record_kinds/__init__.py").read_text()


def test_the_architecture_doc_states_the_criterion_count() -> None:
    """A new criterion is at most two files: its class in optimal_design/criteria.py (registered in CRITERIA under
    its `Criterion` member) and the regenerated contract; the doc says so and the registry is the enum."""
    from optimal_design.criteria import CRITERIA, Criterion  # noqa: PLC0415

    doc = (ROOT / "docs" / "architecture.md").read_text()
    section = doc[doc.index("### Design criteria") :]
    section = section[: section.index("\n### ") if "\n### " in section else len(section)]
    assert "touches two files" in section
    listed = re.findall(r"^\d+\. `([\w/.]+)`", section, re.M)
    assert listed == ["optimal_design/criteria.py", "service/openapi.json"]
    assert set(CRITERIA) == set(Criterion)
