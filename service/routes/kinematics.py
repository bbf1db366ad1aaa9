from __future__ import annotations

from typing import Any

import numpy as np
from fastapi import APIRouter, Depends, Request, Response

from models import forward_kinematics
from models.compensation import inverse_kinematics
from service import operations
from service.conversions import joints_in, joints_out, poses_out
from service.persistence import Database
from service.routes.csv_io import joints_csv
from service.routes.deps import compute, database, wants_csv
from service.schemas.kinematics import ForwardRequest, ForwardResponse, InverseRequest, InverseResponse

router = APIRouter(prefix="/v1/robots/{robot_id}", tags=["kinematics"])


INLINE_POSES = 16
"""Up to this many poses (≈0.3 ms with the cached model) run on the event loop: a hop to a worker thread,
and the GIL hand-over it implies, would cost more than the work."""


@router.post("/forward-kinematics", response_model=ForwardResponse)
async def forward(robot_id: str, body: ForwardRequest, request: Request, db: Database = Depends(database)) -> Any:
    def run() -> dict[str, Any]:
        desc, theta = operations.current_model(db, robot_id)
        fk = forward_kinematics(desc, joints_in(desc, body.joints), theta)
        return {"poses": poses_out(fk.positions, fk.rotations)}

    return run() if len(body.joints) <= INLINE_POSES else await compute(request, "forward_kinematics", run)


@router.post(
    "/inverse-kinematics",
    response_model=InverseResponse,
    responses={200: {"content": {"text/csv": {"schema": {"type": "string"}}}}},
)
async def inverse(robot_id: str, body: InverseRequest, request: Request, db: Database = Depends(database)) -> Any:
    positions, quats = operations.targets_in(body.targets)
    weights = np.asarray(body.weights, dtype=float) if body.weights is not None else None

    def run() -> dict[str, Any]:
        desc, theta = operations.current_model(db, robot_id)
        seed = joints_in(desc, [body.seed])[0] if body.seed is not None else None
        answer = inverse_kinematics(desc, positions, quats, theta, seed=seed, weights=weights, follow=body.follow)
        out = answer.to_dict(desc)
        out["joints"] = joints_out(desc, answer.joints)
        return out

    out = await compute(request, "inverse_kinematics", run)
    if wants_csv(request):
        return Response(joints_csv(out["joints"]), media_type="text/csv")
    return out
