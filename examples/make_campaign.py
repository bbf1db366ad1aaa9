"""Regenerate `campaign.csv`: 40 poses of a simulated IWR (thesis-sized errors, tracker 3 m away), measured
with 0.025 mm / 0.01° noise. `python examples/make_campaign.py`"""

from __future__ import annotations

import csv
from pathlib import Path

from models import iwr, sample_workspace
from models.simulation import measure, perturbed_robot

HEADER = ["q1", "q2", "q3", "q4", "l1", "l2", "l3", "l4", "l5", "l6", "x", "y", "z", "qw", "qx", "qy", "qz"]


def main() -> None:
    desc = iwr()
    campaign = measure(perturbed_robot(desc, seed=2009), sample_workspace(desc, 40, seed=2009), seed=2010)
    assert campaign.quaternions is not None
    path = Path(__file__).with_name("campaign.csv")
    with path.open("w", newline="") as f:
        writer = csv.writer(f)
        writer.writerow(HEADER)
        for q, p, o in zip(
            campaign.joints * desc.joint_to_boundary, campaign.positions, campaign.quaternions, strict=True
        ):
            writer.writerow([f"{v:.6f}" for v in q] + [f"{v:.4f}" for v in p] + [f"{v:.9f}" for v in o])
    print(f"wrote {path}")


if __name__ == "__main__":
    main()
