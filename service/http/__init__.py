"""The HTTP edge: the FastAPI application, its middleware and request guards, API keys and each route's declared
operation, idempotency, problem documents and the published OpenAPI document. The routes (`service.routes`)
sit on it; nothing below the routes imports `service.http.app`.
"""
