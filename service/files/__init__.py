"""Campaigns and parameters as files and request bodies: a campaign read from its request (JSON, CSV, joint +
point files), the text/csv codec and the parameters' CSV export and re-import.
"""
