"""Request and response schemas: boundary units (mm, degrees), unknown fields and non-finite numbers refused."""
