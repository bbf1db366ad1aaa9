"""The use cases, one module per resource, shared by the routes and the job workers.

Each function is keyword-only and follows one shape: read what it needs, compute outside any transaction
(domain errors raised there leave the database untouched), then write in one transaction.
"""
