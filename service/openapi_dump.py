"""Write the application's OpenAPI document to `service/openapi.json` (`python -m service.openapi_dump`).

The committed file is the contract clients generate code from; a test fails when it and the app drift apart.
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

from service.http.app import create_app
from service.settings import Settings

SNAPSHOT = Path(__file__).resolve().parent / "openapi.json"


def document() -> dict[str, Any]:
    app = create_app(Settings(database_url="sqlite://", warm_up=False, job_workers=0, api_keys=""))
    return app.openapi()


def render() -> str:
    return json.dumps(document(), indent=1, sort_keys=True) + "\n"


if __name__ == "__main__":
    SNAPSHOT.write_text(render())
    print(f"wrote {SNAPSHOT}")
