"""Domain objects ⇄ HTTP schemas: the only place boundary units (mm, degrees, quaternions) meet internal ones
(mm, radians, rotation vectors and matrices).

One module per resource. Responses are built from the domain's frozen results' fields into the response
schemas (validated once, NaN → null by `schemas.common.OptionalFloat`); requests are turned into the domain's
arrays and options.
"""
