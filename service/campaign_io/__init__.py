"""Campaign files as users send them: tolerant CSV, joint + point files joined by pose id, Leica-style tracker
exports and SpatialAnalyzer point exports, each turned into the API's measurement records with notes."""

from service.campaign_io.errors import CampaignFileError
from service.campaign_io.records import (
    ImportOptions,
    QuaternionOrder,
    UncertaintyKind,
    campaign_records,
    joined_records,
    measured_points,
)
from service.campaign_io.spatial_analyzer import read_spatial_analyzer
from service.campaign_io.tabular import Table, read_table

__all__ = [
    "CampaignFileError",
    "ImportOptions",
    "QuaternionOrder",
    "Table",
    "UncertaintyKind",
    "campaign_records",
    "joined_records",
    "measured_points",
    "read_spatial_analyzer",
    "read_table",
]
