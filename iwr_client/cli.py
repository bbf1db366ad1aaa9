"""`iwr`: the service's main workflow from a shell (robots, pose designs, calibrations, reports, parameters,
validations, program compensation), on `iwr_client.Client`.

Exit codes: 0 success; 1 a calibration that failed or was not applied, a check whose verdict is not `fine`, a
program with a target left uncorrected (or a cancelled job); 2 a usage error
(including a file that cannot be read); 3 the API refused the request (4xx: the problem's detail printed); 4 the
service unreachable or a 5xx. `--json` prints the API's JSON documents on stdout and nothing else there.
"""

from __future__ import annotations

import argparse
import json
import os
import sys
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any, TextIO, TypedDict

from iwr_client import summary
from iwr_client.client import Client, Json
from iwr_client.errors import ApiError, CampaignFileError, JobCancelled, ServiceUnreachable
from iwr_client.programs import ProgramFile, compensated_bytes, format_of
from iwr_client.progress import ProgressBar

DEFAULT_URL = "http://127.0.0.1:8000"
OK, NOT_APPLIED, USAGE, REFUSED, UNAVAILABLE = 0, 1, 2, 3, 4
INTERRUPTED = 130  # the shell's convention for SIGINT


class UsageError(Exception):
    """A command line argparse accepts that still cannot run (an unreadable file): exit 2."""


def exit_code(error: BaseException) -> int:
    """The exit code an error ends the command with: a problem by its status (4xx: the request was refused, 3;
    5xx, or none, the service's fault, 4), no answer 4, a cancelled job 1, a local input error 2."""
    if isinstance(error, ApiError):
        return REFUSED if 400 <= error.status < 500 else UNAVAILABLE
    if isinstance(error, ServiceUnreachable):
        return UNAVAILABLE
    if isinstance(error, JobCancelled):
        return NOT_APPLIED
    if isinstance(error, UsageError | CampaignFileError):
        return USAGE
    raise error


def describe(error: BaseException) -> str:
    """The error line(s) for stderr: a problem's status, title, detail and what its `errors` name."""
    if not isinstance(error, ApiError):
        return f"iwr: error: {error}"
    lines = [f"iwr: error: {error.status} {error.title}: {error.detail}".rstrip(": ")]
    if error.type not in {"", "about:blank"}:
        lines.append(f"  ({error.type})")
    for issue in (error.problem.get("errors") or [])[:10]:
        lines.append(f"  {issue.get('field') or issue.get('loc')}: {issue.get('msg')}")
    return "\n".join(lines)


class Console:
    """Where output goes: documents (`--json`) and summaries on stdout, progress and errors on stderr."""

    def __init__(self, as_json: bool, out: TextIO, err: TextIO) -> None:
        self.as_json, self.out, self.err = as_json, out, err

    def document(self, document: object, human: Callable[[], str]) -> None:
        self.out.write((json.dumps(document, indent=2) if self.as_json else human()) + "\n")

    def say(self, text: str) -> None:
        """A human line: left out under --json, where stdout holds the documents alone."""
        if not self.as_json:
            self.out.write(text + "\n")

    def progress(self) -> ProgressBar:
        return ProgressBar(self.err)


def _readable(path: str) -> Path:
    """An argparse `type`: a missing or unreadable input file is a usage error before any request."""
    file = Path(path)
    if not file.is_file() or not os.access(file, os.R_OK):
        raise argparse.ArgumentTypeError(f"cannot read {path}")
    return file


def _write(path: str | None, data: bytes, console: Console, what: str) -> None:
    if path is None or path == "-":
        # Bytes as they came (a PDF is binary); a replaced stdout without a buffer (a test's) takes text.
        console.out.flush()
        buffer = getattr(console.out, "buffer", None)
        if buffer is not None:
            buffer.write(data)
            buffer.flush()
        else:
            console.out.write(data.decode("utf-8", "replace"))
        return
    Path(path).write_bytes(data)
    console.say(f"{what} written to {path} ({len(data)} bytes)")


# -- the commands: each takes the client, its arguments and the console, and answers an exit code ------------


def robots_list(client: Client, args: argparse.Namespace, console: Console) -> int:
    robots = client.robots(limit=args.limit)
    console.document(robots, lambda: summary.robots_table(robots))
    return OK


def robots_create(client: Client, args: argparse.Namespace, console: Console) -> int:
    structure = json.loads(args.structure.read_text()) if args.structure else None
    urdf = args.urdf.read_text() if args.urdf else None
    robot = client.create_robot(args.name, structure, urdf=urdf, base_link=args.base_link, tip_link=args.tip_link)
    console.document(robot, lambda: summary.robot_summary(robot))
    return OK


def design(client: Client, args: argparse.Namespace, console: Console) -> int:
    bar = None if args.sync else console.progress()
    try:
        found = client.design(
            args.robot,
            args.count,
            target_rms_mm=args.target_rms_mm,
            criterion=args.criterion,
            measurement=args.measurement,
            candidate_count=args.candidates,
            seed=args.seed,
            async_=not args.sync,
            on_progress=bar,
        )
    finally:
        if bar is not None:
            bar.close()
    if args.csv:
        Path(args.csv).write_text(client.design_csv(found["id"]))
    console.document(found, lambda: summary.design_summary(found, args.csv))
    return OK


class _FileReading(TypedDict):
    """How the service reads a campaign file: the options `_file_options` gives every command that sends one."""

    columns: str | None
    joint_unit: str | None
    length_unit: str | None


def _file_reading(args: argparse.Namespace) -> _FileReading:
    return _FileReading(columns=args.columns, joint_unit=args.joint_unit, length_unit=args.length_unit)


def calibrate(client: Client, args: argparse.Namespace, console: Console) -> int:
    bar = None if args.sync else console.progress()
    try:
        calibration = client.calibrate(
            args.robot,
            args.campaign,
            noise_mm=args.noise_mm,
            apply=args.apply,
            async_=not args.sync,
            on_progress=bar,
            prior=args.prior,
            **_file_reading(args),
        )
    finally:
        if bar is not None:
            bar.close()
    console.document(calibration, lambda: summary.calibration_summary(calibration))
    return calibration_exit(calibration, asked_to_apply=args.apply)


def calibration_exit(calibration: Json, *, asked_to_apply: bool) -> int:
    """1 for a failed fit, or one asked to apply that was not (a check failed, or another calibration won)."""
    if calibration["status"] != "succeeded" or (asked_to_apply and not calibration.get("applied")):
        return NOT_APPLIED
    return OK


def report(client: Client, args: argparse.Namespace, console: Console) -> int:
    if args.pdf and args.output in {None, "-"} and console.out.isatty():
        raise UsageError("a PDF on a terminal: give -o FILE (or redirect stdout)")
    data = client.report(args.calibration, "pdf" if args.pdf else "html")
    _write(args.output, data, console, "PDF report" if args.pdf else "HTML report")
    return OK


def parameters(client: Client, args: argparse.Namespace, console: Console) -> int:
    fmt = "json" if console.as_json else args.format
    if fmt == "json":
        document = client.parameters(args.robot, "json", version=args.version)
        text = json.dumps(document, indent=2) + "\n"
    else:
        text = client.parameters(args.robot, "urdf" if fmt == "urdf" else "csv", version=args.version)
    _write(args.output, text.encode(), console, f"parameters ({fmt})")
    return OK


def check_poses(client: Client, args: argparse.Namespace, console: Console) -> int:
    plan = client.check_design(args.robot, count=args.count, measurement=args.measurement, seed=args.seed)
    _poses_csv(client, args, plan["poses"])
    console.document(plan, lambda: summary.check_design_summary(plan, args.csv))
    return OK


def check(client: Client, args: argparse.Namespace, console: Console) -> int:
    found = client.check(
        args.robot,
        args.records,
        noise_mm=args.noise_mm,
        alpha=args.alpha,
        notes=args.notes,
        **_file_reading(args),
    )
    console.document(found, lambda: summary.check_summary(found))
    return OK if found["verdict"] == "fine" else NOT_APPLIED


def history(client: Client, args: argparse.Namespace, console: Console) -> int:
    if args.csv:
        _write(args.output, client.history(args.robot, "csv", limit=args.limit).encode(), console, "history")
        return OK
    events = client.history(args.robot, limit=args.limit)
    console.document(events, lambda: summary.history_table(events))
    return OK


def validate(client: Client, args: argparse.Namespace, console: Console) -> int:
    found = client.validate(
        args.robot,
        args.records,
        versions=args.version,
        register=args.register,
        **_file_reading(args),
    )
    console.document(found, lambda: summary.validation_summary(found))
    return OK


def compensate(client: Client, args: argparse.Namespace, console: Console) -> int:
    program = ProgramFile.read(args.program)
    files = {f.name: f for f in map(ProgramFile.read, args.files or [])}
    names = [program.name, *(Path(f).name for f in args.files or [])]
    if len(set(names)) != len(names):
        raise UsageError(f"two files named {next(n for n in names if names.count(n) > 1)}: the API names files so")
    fmt = args.format or format_of(program.name)
    if fmt is None:
        raise UsageError(f"the format of {program.name} is not known from its extension: give --format")
    out = Path(args.output) if args.output else None
    inputs = {Path(p).resolve() for p in [args.program, *(args.files or [])]}
    if out is not None and any((out / name).resolve() in inputs for name in names):
        raise UsageError(f"-o {out} would overwrite the files read: write the compensated ones elsewhere")
    bar = console.progress()
    try:
        answer = client.compensate(
            args.robot,
            program,
            files=list(files.values()),
            format=fmt,
            version=args.version,
            seed=args.seed,
            async_=True if args.use_async else None,
            on_progress=bar,
        )
    finally:
        bar.close()
    written: list[str] = []
    if out is not None:
        out.mkdir(parents=True, exist_ok=True)
        for name, data in compensated_bytes(answer, program, files).items():
            (out / name).write_bytes(data)
            written.append(str(out / name))
    console.document(answer, lambda: summary.program_summary(answer, program.name, written))
    return program_exit(answer)


def program_exit(answer: Json) -> int:
    """1 when a target was kept as written (unreachable, another configuration, …): the program would not run
    compensated everywhere. Values the service leaves alone because they are no motion targets are not such."""
    return OK if all(t.get("reached") for t in answer.get("targets") or []) else NOT_APPLIED


def campaign_start(client: Client, args: argparse.Namespace, console: Console) -> int:
    noise = None if args.noise_mm is None else {"position_mm": args.noise_mm}
    found = client.adaptive_start(
        args.robot,
        args.target_mm,
        target="max_tcp_mm" if args.worst else None,
        budget=args.budget,
        measurement=args.measurement,
        criterion=args.criterion,
        candidate_count=args.candidates,
        seed=args.seed,
        noise=noise,
    )
    _poses_csv(client, args, found["next"])
    console.document(found, lambda: summary.adaptive_summary(found))
    return OK


def _poses_csv(client: Client, args: argparse.Namespace, poses: list[Json]) -> None:
    """The poses to measure as CSV (the robot's joint names), where --csv asks for it."""
    if getattr(args, "csv", None):
        names = client.robot(args.robot)["joint_names"]
        lines = [",".join(names)] + [",".join(repr(float(v)) for v in pose["joints"]) for pose in poses]
        Path(args.csv).write_text("\n".join(lines) + "\n")


def campaign_show(client: Client, args: argparse.Namespace, console: Console) -> int:
    found = client.adaptive_campaign(args.robot, args.campaign)
    _poses_csv(client, args, found["next"])
    if args.command_name == "next":
        console.document(found["next"], lambda: summary.adaptive_summary(found))
    else:
        console.document(found, lambda: summary.adaptive_summary(found))
    return OK


def campaign_post(client: Client, args: argparse.Namespace, console: Console) -> int:
    step = client.adaptive_records(args.robot, args.campaign, args.records)
    _poses_csv(client, args, step["next"])
    console.document(step, lambda: summary.adaptive_step_summary(step))
    return OK


def campaign_finish(client: Client, args: argparse.Namespace, console: Console) -> int:
    found = client.adaptive_finish(args.robot, args.campaign, calibrate=args.calibrate, apply=args.apply)
    console.document(found, lambda: summary.adaptive_summary(found))
    return OK


def main(argv: Sequence[str] | None = None) -> int:
    """The console script `iwr` (and `python -m iwr_client`)."""
    parser = build_parser()
    try:
        args = parser.parse_args(argv)
    except SystemExit as stop:  # argparse's own exit: 2 for a usage error, 0 for --help
        return int(stop.code or 0)
    console = Console(args.json, sys.stdout, sys.stderr)
    client = Client(args.url, api_key=args.api_key or None, timeout=args.timeout)
    try:
        code: int = args.run(client, args, console)
    except KeyboardInterrupt:
        sys.stderr.write("\niwr: interrupted (a job it was waiting for is cancelled)\n")
        return INTERRUPTED
    except (ApiError, ServiceUnreachable, JobCancelled, UsageError, CampaignFileError) as error:
        sys.stderr.write(describe(error) + "\n")
        return exit_code(error)
    return code


# -- the parser ------------------------------------------------------------------------------------------------


def _globals(parser: argparse.ArgumentParser, defaults: dict[str, Any] | None) -> None:
    """The global options, on the top parser (with `defaults`) and again on each subcommand (with none, so that
    `iwr robots list --json` and `iwr --json robots list` mean the same and neither overrides the other)."""

    def default(name: str) -> Any:
        return argparse.SUPPRESS if defaults is None else defaults[name]

    parser.add_argument("--url", default=default("url"), help=f"the service (default: $IWR_URL or {DEFAULT_URL})")
    parser.add_argument("--api-key", default=default("api_key"), help="X-API-Key (default: $IWR_API_KEY)")
    parser.add_argument("--json", action="store_true", default=default("json"), help="the API's JSON on stdout only")
    parser.add_argument("--timeout", type=float, default=default("timeout"), help="seconds per request (default 120)")


def _command(
    group: Any, name: str, run: Callable[[Client, argparse.Namespace, Console], int], text: str
) -> argparse.ArgumentParser:
    parser: argparse.ArgumentParser = group.add_parser(name, help=text, description=text)
    _globals(parser, None)
    parser.set_defaults(run=run)
    return parser


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(prog="iwr", description=__doc__.split("\n\n")[0] if __doc__ else None)
    environment = {"url": os.environ.get("IWR_URL") or DEFAULT_URL, "api_key": os.environ.get("IWR_API_KEY")}
    _globals(parser, {**environment, "json": False, "timeout": 120.0})
    commands = parser.add_subparsers(dest="command", required=True, metavar="COMMAND")
    _robot_commands(commands)
    _design_command(commands)
    _calibration_commands(commands)
    _export_commands(commands)
    _check_commands(commands)
    _program_command(commands)
    _campaign_commands(commands)
    return parser


def _robot_commands(commands: Any) -> None:
    robots = commands.add_parser("robots", help="list or create robots").add_subparsers(
        dest="robots_command", required=True, metavar="ACTION"
    )
    listing = _command(robots, "list", robots_list, "the service's robots")
    listing.add_argument("--limit", type=int, default=100)
    create = _command(robots, "create", robots_create, "a new robot: the IWR, or a structure document or a URDF")
    create.add_argument("name")
    source = create.add_mutually_exclusive_group()
    source.add_argument("--structure", type=_readable, metavar="FILE.json", help="the structure document")
    source.add_argument("--urdf", type=_readable, metavar="FILE", help="a URDF (with --base-link, --tip-link)")
    create.add_argument("--base-link", metavar="LINK")
    create.add_argument("--tip-link", metavar="LINK")


def _design_command(commands: Any) -> None:
    design_parser = _command(commands, "design", design, "the poses worth measuring")
    design_parser.add_argument("robot", metavar="ROBOT")
    size = design_parser.add_mutually_exclusive_group(required=True)
    size.add_argument("--count", type=int, help="the number of poses")
    size.add_argument("--target-rms-mm", type=float, help="instead: the fewest poses reaching this TCP RMS")
    # No list of criteria here: the service's is the one (GET /v1/design-criteria); a name it does not know is its
    # 422, which lists them.
    design_parser.add_argument("--criterion", help="a criterion of `GET /v1/design-criteria` (default D)")
    design_parser.add_argument("--measurement", default="pose", choices=["pose", "position"])
    design_parser.add_argument("--candidates", type=int, help="sampled candidates (default 2000)")
    design_parser.add_argument("--seed", type=int)
    design_parser.add_argument("--csv", metavar="OUT", help="write the poses as CSV (the robot's joint names)")
    design_parser.add_argument("--sync", action="store_true", help="one request, not a job with progress")


def _calibration_commands(commands: Any) -> None:
    parser = _command(commands, "calibrate", calibrate, "identify the robot's parameters from a campaign")
    parser.add_argument("robot", metavar="ROBOT")
    parser.add_argument("campaign", type=_readable, metavar="CAMPAIGN.csv")
    parser.add_argument("--noise-mm", type=float, help="the instrument's position σ (default 0.025)")
    parser.add_argument("--no-apply", dest="apply", action="store_false", help="fit and store, keep the parameters")
    parser.add_argument("--sync", action="store_true", help="one request, not a job with progress")
    parser.add_argument(
        "--prior", choices=["none", "fleet"], help="fleet: with the population of the robot's fleet (fewer poses)"
    )
    _file_options(parser)
    check = _command(commands, "validate", validate, "versions against records they were not fitted to")
    check.add_argument("robot", metavar="ROBOT")
    check.add_argument("records", type=_readable, metavar="RECORDS.csv")
    check.add_argument("--version", type=int, action="append", help="a version to evaluate (repeatable)")
    check.add_argument("--register", action="store_true", help="fit the instrument frame first")
    _file_options(check)


def _file_options(parser: argparse.ArgumentParser) -> None:
    """How the service reads the campaign file (sent as it is): the same options for every command that sends one."""
    parser.add_argument(
        "--columns",
        metavar="MAP",
        help="which file column is which: 'J1=joint_1,J2=joint_2,X_m=x' (a joint of the robot, its URDF's names "
        "too, or x, y, z, qw…, pose_id, sigma_mm, u95, temperature_c, time; x2, y2, z2 … a row's further points)",
    )
    parser.add_argument(
        "--joint-unit", choices=["deg", "rad"], help="the revolute joint columns' unit where the header has none"
    )
    parser.add_argument(
        "--length-unit",
        choices=["mm", "m", "cm", "um", "in"],
        help="the points', σ's and prismatic joint columns' unit where the header has none (default mm)",
    )


def _check_commands(commands: Any) -> None:
    poses = _command(commands, "check-poses", check_poses, "the poses a quick check should measure")
    poses.add_argument("robot", metavar="ROBOT")
    poses.add_argument("--count", type=int, default=8, help="5-10 poses (default 8)")
    poses.add_argument("--measurement", default="position", choices=["position", "pose"])
    poses.add_argument("--seed", type=int, default=0)
    poses.add_argument("--csv", metavar="OUT", help="write the poses as CSV (the robot's joint names)")
    parser = _command(commands, "check", check, "a quick check of the current version (exit 1 unless fine)")
    parser.add_argument("robot", metavar="ROBOT")
    parser.add_argument("records", type=_readable, metavar="RECORDS.csv")
    parser.add_argument("--noise-mm", type=float, help="the instrument's position σ (default 0.025)")
    parser.add_argument("--alpha", type=float, help="the false-alarm rate (default 0.01)")
    parser.add_argument("--notes", help="stored with the check (what happened to the robot)")
    _file_options(parser)
    timeline = _command(commands, "history", history, "the robot's calibrations and checks, oldest first")
    timeline.add_argument("robot", metavar="ROBOT")
    timeline.add_argument("--csv", action="store_true", help="the CSV export (with -o FILE, else stdout)")
    timeline.add_argument("-o", "--output", metavar="FILE", help="with --csv; default: stdout")
    timeline.add_argument("--limit", type=int, default=100)


def _export_commands(commands: Any) -> None:
    parser = _command(commands, "report", report, "a calibration's report (HTML, or PDF)")
    parser.add_argument("calibration", metavar="CALIBRATION")
    parser.add_argument("--pdf", action="store_true")
    parser.add_argument("-o", "--output", metavar="FILE", help="default: stdout")
    export = _command(commands, "parameters", parameters, "a robot's parameters (current or --version)")
    export.add_argument("robot", metavar="ROBOT")
    export.add_argument("--format", default="csv", choices=["csv", "urdf", "json"])
    export.add_argument("--version", type=int)
    export.add_argument("-o", "--output", metavar="FILE", help="default: stdout")


def _seed(text: str) -> list[float]:
    """An argparse `type`: joints as '0,-90,80,-90,90,0' (commas: a leading minus is no option then)."""
    try:
        return [float(v) for v in text.replace(" ", ",").split(",") if v]
    except ValueError:
        raise argparse.ArgumentTypeError(f"not a list of numbers: {text!r}") from None


def _program_command(commands: Any) -> None:
    parser = _command(commands, "compensate", compensate, "a robot program with its targets corrected for the robot")
    parser.add_argument("robot", metavar="ROBOT")
    parser.add_argument("program", type=_readable, metavar="PROGRAM", help=".src, .mod, .script, .csv, …")
    parser.add_argument(
        "--files",
        nargs="+",
        type=_readable,
        metavar="FILE",
        help="companion files: the KRL .dat, $config.dat (quote the $), RAPID modules with its tooldata/wobjdata",
    )
    parser.add_argument("--format", choices=["krl", "rapid", "urscript", "csv"], help="default: from the extension")
    parser.add_argument("--version", type=int, help="the parameter version (default: the current one)")
    parser.add_argument("--seed", type=_seed, metavar="J1,J2,…", help="joints (deg, mm) the solutions start near")
    parser.add_argument("-o", "--output", metavar="DIR", help="write the compensated files there, same names")
    parser.add_argument(
        "--async", dest="use_async", action="store_true", help="as a job with progress (large programs)"
    )


def _campaign_commands(commands: Any) -> None:
    group = commands.add_parser(
        "campaign", help="an adaptive campaign: a pose at a time until the target"
    ).add_subparsers(dest="campaign_command", required=True, metavar="ACTION")
    start = _command(group, "start", campaign_start, "start one: its first poses to measure")
    start.add_argument("robot", metavar="ROBOT")
    start.add_argument("--target-mm", type=float, required=True, help="the predicted RMS TCP error to reach (mm)")
    start.add_argument("--worst", action="store_true", help="the target is the worst workspace pose's error")
    start.add_argument("--budget", type=int, help="at most this many records (default 60)")
    start.add_argument("--measurement", choices=["pose", "position"], help="default pose")
    start.add_argument(
        "--criterion", help="what each pose improves: a criterion of `GET /v1/adaptive-criteria` (default I)"
    )
    start.add_argument("--candidates", type=int, help="candidate poses sampled (default 500)")
    start.add_argument("--seed", type=int)
    start.add_argument("--noise-mm", type=float, help="the instrument's position σ (default 0.025)")
    for name, run, text in (
        ("next", campaign_show, "the poses to measure now"),
        ("show", campaign_show, "the campaign's state and every step"),
        ("post", campaign_post, "post measured records: the estimate, predicted accuracy and next pose"),
        ("finish", campaign_finish, "end it, by default storing a calibration of its records"),
    ):
        parser = _command(group, name, run, text)
        parser.set_defaults(command_name=name)
        parser.add_argument("robot", metavar="ROBOT")
        parser.add_argument("campaign", metavar="CAMPAIGN")
        if name == "post":
            parser.add_argument("records", type=_readable, metavar="RECORDS.csv")
        if name == "finish":
            parser.add_argument("--no-calibrate", dest="calibrate", action="store_false", help="only end it")
            parser.add_argument("--no-apply", dest="apply", action="store_false", help="calibrate, keep the parameters")
        else:
            parser.add_argument("--csv", metavar="OUT", help="write the poses to measure as CSV (joint names)")
    start.add_argument("--csv", metavar="OUT", help="write the poses to measure as CSV (joint names)")
