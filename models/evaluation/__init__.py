"""A parameter version judged against measurements: accuracy on fresh poses, ISO 9283, the quick check and a
fleet's population. They evaluate results; identification never imports them.
"""
