"""SpatialAnalyzer's ASCII point export: `collection group target x y z [uncertainty]`, one point a line.

SA writes whitespace- (or comma-) separated fields, no header by default, `//` or `#` comment lines; names have no
spaces (SA replaces them). The result is a `Table` like any CSV's, so units, uncertainty and the join with the
controller's joint file by target name work the same way.
"""

from __future__ import annotations

import re

from service.campaign_io.errors import CampaignFileError
from service.campaign_io.tabular import Row, Table

COLUMNS = ("collection", "group", "target", "x", "y", "z", "uncertainty")
HEADER_WORDS = {"collection", "group", "target", "point", "x", "y", "z"}


def read_spatial_analyzer(text: str) -> Table:
    rows: list[Row] = []
    for number, raw in enumerate(text.removeprefix("\ufeff").splitlines(), start=1):
        line = raw.strip()
        if not line or line.startswith(("//", "#")):
            continue
        fields = [f for f in re.split(r"[\s,;]+", line) if f]
        if {f.lower() for f in fields[:4]} & HEADER_WORDS and not rows:
            continue  # an optional header line
        if len(fields) not in (6, 7):
            raise CampaignFileError(
                f"line {number}: expected 'collection group target x y z [uncertainty]' (6 or 7 fields), "
                f"got {len(fields)}",
                line=number,
            )
        rows.append(Row(line=number, cells=dict(zip(COLUMNS, fields, strict=False))))
    if not rows:
        raise CampaignFileError("the SpatialAnalyzer export holds no point", line=1)
    with_uncertainty = all(len(r.cells) == 7 for r in rows)
    columns = COLUMNS if with_uncertainty else COLUMNS[:6]
    if not with_uncertainty and any(len(r.cells) == 7 for r in rows):
        raise CampaignFileError("some points have an uncertainty and some do not: give it for all or none")
    return Table(columns=columns, units={}, rows=tuple(rows), delimiter=" ", decimal_comma=False)
