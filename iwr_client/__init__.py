"""The service's Python client and the `iwr` command line: standard library only (it imports nothing of the
maths or the service), so any Python ≥ 3.11 runs it against a running service.

    from iwr_client import Client
    client = Client("http://127.0.0.1:8000")
    robot = client.create_robot("cell-3")
"""

from iwr_client.client import Answer, Client, Progress
from iwr_client.errors import ApiError, CampaignFileError, JobCancelled, JobFailed, ServiceUnreachable
from iwr_client.programs import ProgramFile

__all__ = [
    "Answer",
    "ApiError",
    "CampaignFileError",
    "Client",
    "JobCancelled",
    "JobFailed",
    "ProgramFile",
    "Progress",
    "ServiceUnreachable",
]
