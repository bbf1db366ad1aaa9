"""Command line of the tolerance study: `python -m models.error_analysis --help` (also `iwr-error-analysis`).

The only place of the study that prints or parses arguments.
"""

from __future__ import annotations

import argparse
import json
import sys
from collections.abc import Sequence
from pathlib import Path

from models.description.iwr import iwr
from models.engine.runtime import Registry
from models.error_analysis.export import magnitudes_json, result_json
from models.error_analysis.magnitudes import ErrorMagnitudes
from models.error_analysis.plot import plot_absolute, plot_axes
from models.error_analysis.report import summary
from models.error_analysis.study import DISTRIBUTIONS, error_analysis
from models.errors import CalibrationError


def _parser() -> argparse.ArgumentParser:
    defaults = magnitudes_json(ErrorMagnitudes())
    parser = argparse.ArgumentParser(
        prog="python -m models.error_analysis",
        description="The thesis's tolerance study (§4.5) on the IWR: TCP errors of the carriage, the hexapod "
        "and the whole robot, exact and first-order.",
    )
    parser.add_argument("--poses", type=int, default=40, help="random workspace poses (default 40)")
    parser.add_argument("--draws", type=int, default=200, help="Monte Carlo draws of the errors (default 200)")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--distribution", default="sign", help=f"one of {', '.join(DISTRIBUTIONS)} (default sign)")
    parser.add_argument("--leg-offset-mm", type=float, default=defaults["leg_offset_mm"])
    parser.add_argument("--joint-position-mm", type=float, default=defaults["joint_position_mm"])
    parser.add_argument("--dh-angle-deg", type=float, default=defaults["dh_angle_deg"])
    parser.add_argument("--dh-length-mm", type=float, default=defaults["dh_length_mm"])
    parser.add_argument("--plot", type=Path, help="write the per-pose absolute errors (Figs. 37-38) to this PNG/SVG")
    parser.add_argument("--plot-axes", type=Path, help="write the per-axis errors (Figs. 31-36) to this PNG/SVG")
    parser.add_argument("--json", type=Path, help="write the JSON summary (mm, deg) to this file")
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    args = _parser().parse_args(argv)
    try:
        tolerances = ErrorMagnitudes.from_boundary(
            leg_offset_mm=args.leg_offset_mm,
            joint_position_mm=args.joint_position_mm,
            dh_angle_deg=args.dh_angle_deg,
            dh_length_mm=args.dh_length_mm,
        )
        desc = iwr()
        result = error_analysis(
            desc,
            runtime=Registry().runtime(desc),  # the command's own: it builds what it uses, nothing shared
            n_poses=args.poses,
            n_draws=args.draws,
            tolerances=tolerances,
            distribution=args.distribution,
            seed=args.seed,
        )
    except CalibrationError as exc:
        print(f"error: {exc.detail}", file=sys.stderr)
        return 2
    print(summary(result))
    if args.json:
        args.json.parent.mkdir(parents=True, exist_ok=True)
        args.json.write_text(json.dumps(result_json(result), indent=1) + "\n")
        print(f"\nwrote {args.json}")
    if args.plot or args.plot_axes:
        if args.plot:
            plot_absolute(result, args.plot)
            print(f"wrote {args.plot}")
        if args.plot_axes:
            plot_axes(result, args.plot_axes)
            print(f"wrote {args.plot_axes}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
